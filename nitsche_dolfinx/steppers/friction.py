"""Coulomb friction in the steps of a run (docs/method.md section 8): the guarded
semismooth Newton of a frictional step, and the friction output.

- :class:`GuardedNewton`: the step's Newton solve on the friction law guarded by a
  reference state (:class:`~nitsche_dolfinx.contact.terms.GuardedFriction`);
- :class:`FrictionOutput`: the work D^n of a step and the friction fields on Gamma_C;
- :class:`FrictionWork`: D^n as a part of the steps
  (:class:`~nitsche_dolfinx.steppers.parts.StepPart`), summed since t = 0.
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from petsc4py import PETSc

from ..contact.terms import ContactTerms, GuardedFriction, friction_terms
from ..output.probes import BoundaryField, assemble_global
from ..solvers.solver import SNESSolver, SolverError
from .parts import StepEnds, StepPart

__all__ = ["FrictionOutput", "FrictionWork", "GuardedNewton"]


class FrictionOutput:
    """The friction quantities of a stepper
    (:class:`~nitsche_dolfinx.steppers.implicit.NitscheStepper`:
    ``problem``, ``scheme``, the unknown ``w``, the state ``u``, ``v``, ``a``): the work D^n
    of each step, and the fields ``slip_velocity`` and ``friction_traction`` on Gamma_C.

    D^n is the friction term of the step's equation tested with the step's increment
    u^{n+1} - u^n (the scheme's slip velocity and threshold), so that
    E_Theta^{n+1} - E_Theta^n + D^n is what the contact terms' energy identity leaves.
    The fields are the friction law at the time level: u'_t and
    lambda_t = -(1/gamma_h) [u'_t - gamma_h sigma_t(u)]_{mu_f [P_gamma(u)]_+}.
    """

    def __init__(self, stepper, dt):
        sim, problem = stepper, stepper.problem
        self.comm = problem.mesh.comm
        self.problem = problem
        self.increment = fem.Function(problem.V)
        problem.track_partners(self.increment)  # a pair's work is on T du too
        terms = friction_terms(problem, "work")
        work = sim.scheme.residual(terms, sim.w, sim.u, sim.v, sim.a, dt, self.increment)
        self._work = fem.form(work)
        tags = tuple(tag for c, tag in zip(problem.contacts, problem.contact_tags) if c.frictional)
        ds = problem.ds(tags)
        shape = (problem.gdim,)
        self.fields = []
        for name, quantity in (
            ("slip_velocity", "slip_velocity"),
            ("friction_traction", "traction"),
        ):
            terms = friction_terms(problem, quantity)
            self.fields.append(
                BoundaryField(
                    problem.mesh,
                    shape,
                    ds,
                    lambda mu, terms=terms: terms.operator(sim.u, mu, sim.v),
                    name,
                )
            )

    def work(self, increment: np.ndarray) -> float:
        """D^n for the step from the current state with the increment (dof array)."""
        self.increment.x.array[:] = increment
        self.problem.update_partners()
        return assemble_global(self._work, self.comm)

    def update_fields(self) -> None:
        """Evaluate ``slip_velocity`` and ``friction_traction`` at the current state
        (collective)."""
        for field in self.fields:
            field.update()


class FrictionWork(StepPart):
    """The friction's work D^n of each step (``friction_dissipation``) and its sum since
    t = 0, the friction's share of the energy balance (docs/method.md section 13)."""

    def __init__(self, output: FrictionOutput):
        self.output = output

    def step(self, ends: StepEnds) -> None:
        self.step_dissipation = self.output.work(ends.u1 - ends.u)  # before u^n is overwritten

    def accept(self, level: int, ends: StepEnds) -> None:
        self.dissipated += self.step_dissipation

    def columns(self) -> dict[str, float]:
        return {"friction_dissipation": self.step_dissipation}

    def saved(self) -> dict[str, float]:
        return {"friction_total": self.dissipated}

    def restore(self, saved: dict) -> None:
        self.dissipated = float(saved.get("friction_total", 0.0))


class GuardedNewton:
    """Semismooth Newton on the friction law guarded by a reference state (see the
    ``guard_friction`` argument of
    :class:`~nitsche_dolfinx.simulation.Simulation`).

    ``model`` is the problem with the guarded law, for the step's residual. With the
    reference at the unknown itself the guarded law is Coulomb's, value for value
    (:func:`~nitsche_dolfinx.contact.nitsche.guarded_projection`), so the same solver also
    evaluates Coulomb's residual (:meth:`coulomb_residual`).

    Args:
        problem: The frictional problem.
        scheme: The time scheme.
        state: ``(w, u, v, a, dt)`` of the simulation: the unknown, the state at t^n
            and the time step (a Constant).
    """

    def __init__(self, problem, scheme, state):
        w = state[0]
        self.w = w
        self.reference = fem.Function(w.function_space, name="reference")
        # a pair's law sees the partner of the unknown: at the reference, its partner
        problem.track_partners(self.reference)
        self._pairs = problem.pairs
        at_reference = {w: self.reference}
        for pair in self._pairs:
            at_reference[pair.partners[w]] = pair.partners[self.reference]

        def reference(expr):
            return ufl.replace(expr, at_reference)

        self.model = GuardedFriction(problem, reference)
        activity = ContactTerms(
            problem.frictional_contacts,
            lambda c, u, velocity, force, v: c.guard_activity(u, velocity, force, reference),
        )
        self.activity = fem.form(scheme.residual(activity, *state, None))
        self.comm = problem.mesh.comm

    def coulomb_residual(self, solver: SNESSolver, new_coefficients: bool = True) -> float:
        """The norm of Coulomb's residual at the current ``w`` (the reference is moved
        to ``w``); ``solver`` is the SNES of :attr:`model`'s residual."""
        self._set_reference(self.w.x.array)
        return solver.residual_norm(new_coefficients)

    def coulomb_scale(self, solver: SNESSolver) -> float:
        """The scale of Coulomb's equation at the current ``w`` (the reference is moved
        to ``w``): :meth:`~nitsche_dolfinx.solvers.solver.SNESSolver.equation_scale`."""
        self._set_reference(self.w.x.array)
        return solver.equation_scale()

    def solve(
        self, solver: SNESSolver, first_reference: np.ndarray, tolerance: float, updates: int
    ) -> int:
        """Solve from the current ``w`` with the reference ``first_reference`` (an array
        of the unknown), moving the reference to each guarded solution until the guarded
        law is Coulomb's (at most ``updates`` times). Every solve has the absolute
        residual tolerance ``tolerance``. Returns the Newton iterations of all the solves."""
        self._set_reference(first_reference)
        spent = 0
        for _ in range(updates + 1):
            spent += self._solve_once(solver, tolerance)
            if assemble_global(self.activity, self.comm) == 0.0:
                return spent
            self._set_reference(self.w.x.array)
        raise SolverError(PETSc.SNES.ConvergedReason.DIVERGED_MAX_IT, spent, float("nan"))

    def _set_reference(self, values: np.ndarray) -> None:
        """Move the reference to ``values`` (an array of the unknown), and its partners."""
        self.reference.x.array[:] = values
        for pair in self._pairs:
            pair.update([self.reference])

    def _solve_once(self, solver: SNESSolver, tolerance: float) -> int:
        """One solve with a fixed reference: full Newton steps and, should they cycle
        among the pieces of the law, again from the same start with the l2 line search
        (measured: the block just stopped, its edges still slipping)."""
        return solver.solve_with_line_search(tolerance)
