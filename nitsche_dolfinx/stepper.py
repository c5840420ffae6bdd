"""One time step of a :class:`~nitsche_dolfinx.model.ContactProblem`, and its state.

A stepper holds the state (u^n, v^n, a^n) at t^n and advances it by one step of
its time scheme: one SNES solve for the scheme's unknown ``w``
(docs/method.md section 3), then the kinematic update. It reports the
diagnostics of the time level (:meth:`NitscheStepper.state`), the fields to write
and the functions a checkpoint must hold.
:class:`~nitsche_dolfinx.simulation.Simulation` drives any stepper of the
:class:`Stepper` protocol through a run; :class:`NitscheStepper` steps the Nitsche
and penalty methods, :class:`~nitsche_dolfinx.mixed.MixedStepper` the mixed one.
"""

from __future__ import annotations

import time
from typing import Any, Protocol

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI

from . import compat
from .diagnostics import Diagnostics
from .dirichlet import DirichletDofs, as_array
from .fields import ContactFields, OnBoundary
from .friction import ContactTerms, FrictionOutput, GuardedNewton
from .material import von_mises
from .model import ContactProblem
from .parameters import ParameterError, TimeStepping, require
from .schemes import HybridScheme, TimeScheme
from .solver import SNESSolver, SolverError
from .timelevels import TimeLevels

__all__ = [
    "ENERGY_CONTROL",
    "NitscheStepper",
    "Stepper",
    "UncontrolledStep",
    "check_initial_gap",
    "initial_acceleration",
    "interpolate_initial",
    "massless_velocity",
]


#: The least share of the kinetic plus elastic energy that E_Theta - potential must keep at
#: a new level (docs/method.md section 8). Measured: at least 0.9999 in the healthy runs
#: of the package (ring, friction block, every scheme); a P2 box whose gamma0 is beyond
#: the stability limit falls to 0.67, then 0.07, while E grows without bound.
ENERGY_CONTROL = 0.5


class UncontrolledStep(SolverError):
    """A step whose Newton solve converged to a state that E_Theta no longer controls
    (E_Theta - potential < :data:`ENERGY_CONTROL` (kinetic + elastic)), or whose
    diagnostics are not finite: the discrete problem has left its stability range.

    ``cut_may_help`` is False for lost energy control: it is a matter of gamma0 and the
    mesh, not of the step size.
    """

    def __init__(self, values: dict[str, float], iterations: int, hint: str):
        self.values = values
        self.cut_may_help = not _finite_values(values)
        self._hint_text = hint
        super().__init__(0, iterations, float("nan"))
        self.reason_name = "NOT_FINITE" if self.cut_may_help else "ENERGY_NOT_CONTROLLED"

    def _message(self) -> str:
        where = "" if self.step is None else f"at step {self.step} (t = {self.t:.6g}): "
        values = self.values
        if self.cut_may_help:
            return f"{where}the converged state is not finite (E = {values['energy']:.6g})"
        kinetic_elastic = values["kinetic"] + values["elastic"]
        controlled = values["energy_theta"] - values["potential"]
        return (
            f"{where}E_Theta no longer controls the energy: E_Theta - potential = "
            f"{controlled:.6g} for kinetic + elastic = {kinetic_elastic:.6g} (E = "
            f"{values['energy']:.6g}); {self._hint_text}"
        )


def _finite_values(values: dict[str, float]) -> bool:
    return all(np.isfinite(value) for key, value in values.items() if key != "penetration_max")


def energy_controlled(values: dict[str, float]) -> bool:
    """Whether the diagnostics of a level are finite and E_Theta - potential keeps at least
    :data:`ENERGY_CONTROL` of kinetic + elastic (docs/method.md section 8)."""
    if not _finite_values(values):
        return False
    kinetic_elastic = values["kinetic"] + values["elastic"]
    return values["energy_theta"] - values["potential"] >= ENERGY_CONTROL * kinetic_elastic


class Stepper(Protocol):
    """What :class:`~nitsche_dolfinx.simulation.Simulation` needs of a stepper.

    Attributes: ``problem``, ``scheme``, ``comm``; the clock of
    :class:`~nitsche_dolfinx.timelevels.TimeLevels` (``dt``, ``t``, ``step_index``,
    ``next_time()``, ``finished``, ...); the state ``u``, ``v``, ``a`` (Functions on
    ``problem.V``), and ``newton_iterations`` and ``step_seconds`` of the last step.
    """

    def step(self, t_new: float | None = None, cuts: int = 0) -> int:
        """Advance one step to ``t_new`` (default: the next nominal level), a step halved
        ``cuts`` times; return the Newton iterations. On a SolverError the state is
        that of before the step."""

    def state(self) -> dict[str, float]:
        """The diagnostics of the current time level, identical on every rank."""

    def output_fields(self) -> dict:
        """``{name: (source, value shape)}`` for the field output: a source is a Function, a
        UFL expression or an object with ``evaluate(target)`` (see
        :class:`~nitsche_dolfinx.output.SolutionWriter`)."""

    def checkpoint_functions(self) -> dict[str, fem.Function]:
        """Everything the next step depends on, by name."""

    def describe(self) -> dict[str, Any]:
        """What a checkpoint must share with the stepper that reloads it."""

    def restore(self, t: float, step_index: int, saved: dict[str, Any]) -> None:
        """Move to a time level whose functions were just loaded (``saved``: the
        checkpoint's description)."""


def massless_velocity(massless, u, u1, v1, a1, dt) -> None:
    """At massless dofs (redistributed mass) the scheme's velocity update means nothing:
    the node follows its constraint. Report the step's mean velocity there instead."""
    if massless.size:
        v1[massless] = (u1[massless] - u[massless]) / dt
        a1[massless] = 0.0


def interpolate_initial(target: fem.Function, value, gdim: int) -> None:
    """Set ``target`` to an initial value: None (zero), a Function, a function of the
    coordinates returning (gdim, N) or (N,) values, or a constant vector."""
    if value is None:
        target.x.array[:] = 0.0
    elif isinstance(value, fem.Function):
        target.interpolate(value)
    elif callable(value):
        target.interpolate(lambda x: np.asarray(value(x), dtype=float).reshape(gdim, -1))
    else:
        array = as_array(value, (gdim,), "initial value")
        target.interpolate(lambda x: np.tile(array[:, None], (1, x.shape[1])))
    target.x.scatter_forward()
    finite = target.function_space.mesh.comm.allreduce(
        bool(np.all(np.isfinite(target.x.array))), op=MPI.LAND
    )
    require(finite, f"initial {target.name}", "NaN or inf", "the initial values must be finite")


def check_initial_gap(penetration: float, mesh) -> None:
    """Refuse a body that starts inside an obstacle: ``penetration`` is the largest
    u_n - g on Gamma_C at t = 0, allowed up to round-off of the mesh's extent."""
    x = mesh.geometry.x
    extent = mesh.comm.allreduce(float(np.abs(x).max(initial=0.0)), op=MPI.MAX)
    if penetration > 1e-8 * max(extent, 1e-300):
        raise ParameterError(
            "initial_displacement",
            penetration,
            "it must start outside (u_n <= g on Gamma_C)",
            label=f"initial displacement: the body starts {penetration:.3g} inside an obstacle",
        )


def check_pairs_apart(problem: ContactProblem, u: fem.Function) -> None:
    """Refuse contact pairs pressed together at t = 0 (a positive contact force): the
    initial acceleration leaves out the reaction on the master side."""
    if not problem.pairs:
        return
    problem.update_partners()
    force = sum(pair.force(u) for pair in problem.pairs)
    value = problem.mesh.comm.allreduce(fem.assemble_scalar(fem.form(force)), op=MPI.SUM)
    if value > 0:
        raise ParameterError(
            "initial_displacement",
            value,
            "the bodies of a contact pair must start apart",
            label=f"initial state: the bodies of a contact pair press on each other "
            f"(contact force {value:.3g})",
        )


def initial_acceleration(
    problem: ContactProblem, a: fem.Function, stiffness, dirichlet, petsc_options=None
) -> None:
    """Solve M a0 = L(0) - ``stiffness`` for ``a`` (docs/method.md section 3), with a0 = 0
    at the Dirichlet dofs (``dirichlet``, a :class:`DirichletDofs`) and at the massless
    dofs of a redistributed mass.

    ``stiffness(test)`` is the operator at u0 tested with ``test``."""
    V = problem.V
    test = ufl.TestFunction(V)
    F0 = problem.inertia(a, test) + stiffness(test) - problem.load(test)
    zero = fem.Function(V)
    bcs = dirichlet.boundary_conditions(zero)
    diagonal = problem.mass_diagonal()
    if diagonal is not None:  # massless nodes (redistributed mass): no acceleration of their own
        bcs.append(fem.dirichletbc(zero, problem.massless_dofs(nodes=True)))
    a.x.array[:] = 0.0
    solver = SNESSolver(F0, a, bcs, petsc_options=petsc_options, mass_diagonal=diagonal)
    solver.solve()
    solver.destroy()


def checkpoint_description(stepper) -> dict[str, Any]:
    """The description a checkpoint of any stepper shares with the run that reloads it."""
    problem = stepper.problem
    V = problem.V
    friction = problem.friction
    return {
        "friction": 0.0 if friction is None else float(np.asarray(friction.value)),
        "dofs": int(V.dofmap.index_map.size_global * V.dofmap.index_map_bs),
        "dt": stepper.dt,
        "scheme": stepper.scheme.describe(),
        "method": problem.method,
        "mass": problem.mass,
        "degree": problem.degree,
        "gamma0": float(np.asarray(problem.gamma0.value)),
        "gamma0_scaling": problem.gamma0_scaling,
        "nitsche_theta": float(np.asarray(problem.nitsche_theta.value)),
        "functions": sorted(stepper.checkpoint_functions()),
    }


class NitscheStepper(TimeLevels):
    """Steps of a :class:`~nitsche_dolfinx.model.ContactProblem` with Nitsche or penalty
    contact by a time scheme: one SNES solve per step.

    The arguments are those of :class:`~nitsche_dolfinx.simulation.Simulation`, which
    documents them.
    """

    #: How many times a step may move the reference of the guarded friction law.
    guard_updates = 10

    def __init__(
        self,
        problem: ContactProblem,
        scheme: TimeScheme,
        time_stepping: TimeStepping,
        petsc_options: dict[str, Any] | None = None,
        reuse_jacobian: bool = True,
        preconditioner_lag: int = 0,
        guard_friction: bool = True,
    ):
        if problem.mass == "redistributed" and isinstance(scheme, HybridScheme):
            raise ParameterError(
                "mass",
                problem.mass,
                "not with the hybrid scheme: the massless contact nodes are then left to "
                "alternate around the obstacle (measured: E grows 48-fold on the bar); use "
                "the redistributed mass with Crank-Nicolson, theta or Newmark",
            )
        if problem.dirichlet and scheme.displacement_coefficient(time_stepping.dt) == 0.0:
            raise ParameterError(
                "scheme",
                scheme.describe(),
                "an explicit scheme (theta = 0, Newmark beta = 0) gives u^{n+1} before the "
                "step's solve, so it cannot impose Dirichlet values; use theta > 0 or beta > 0",
            )
        self.problem, self.scheme = problem, scheme
        self._start_levels(time_stepping)
        self.comm = problem.mesh.comm
        V = problem.V
        self.u = fem.Function(V, name="displacement")
        self.v = fem.Function(V, name="velocity")
        self.a = fem.Function(V, name="acceleration")
        self.w = fem.Function(V, name="unknown")
        problem.track_partners(self.u, self.v, self.a, self.w)  # contact between bodies
        self.newton_iterations, self.step_seconds = 0, 0.0

        self._dirichlet = DirichletDofs(problem)
        self._w_bc = fem.Function(V)  # the unknown's values at the Dirichlet dofs
        bcs = self._dirichlet.boundary_conditions(self._w_bc)
        self._dt = dt_c = fem.Constant(problem.mesh, self.dt)  # the size of the step
        self.solver = self._step_solver(
            dt_c, bcs, petsc_options, reuse_jacobian, preconditioner_lag, guard_friction
        )
        self.diagnostics = Diagnostics(problem, self.u, self.v)
        self.friction_dissipation = 0.0
        self._energy_before = None  # E_Theta^n of the last step
        self._diagnostics_cache = None  # (step index, diagnostics) of the current level
        self._previous = [np.empty_like(f.x.array) for f in (self.u, self.v, self.a)]
        self._friction = FrictionOutput(self, dt_c) if problem.frictional else None
        self._contact_fields = None  # ContactFields, once the output asks for them
        self._massless = problem.massless_dofs()
        self._initialize(petsc_options)

    def _step_solver(self, dt_c, bcs, petsc_options, reuse_jacobian, lag, guard_friction):
        """The SNES of the step's equation F(w) = 0 (docs/method.md section 8)."""
        problem, scheme = self.problem, self.scheme
        state = (self.w, self.u, self.v, self.a, dt_c)
        self._guarded, model = None, problem
        if problem.frictional and guard_friction:
            self._guarded = GuardedNewton(problem, scheme, state)
            model = self._guarded.model
        test = ufl.TestFunction(problem.V)
        F = scheme.residual(model, *state, test)
        activity, facet_parts = None, None
        if problem.contacts:  # lets the solver skip the contact Jacobian out of contact
            cellwise = ufl.TestFunction(compat.function_space(problem.mesh, "DG", 0))
            activity = scheme.residual(problem.contact_activity(), *state, cellwise)
            facet_parts = [
                scheme.residual(part, *state, test)
                for part in problem.contact_parts(getattr(model, "reference", None))
            ]
        # The bulk is linear elastodynamics: its terms (the cell integrals) are affine in
        # the unknown, and only the contact terms on Gamma_C change the Jacobian.
        return SNESSolver(
            F,
            self.w,
            bcs,
            petsc_options=petsc_options,
            affine_cell_terms=reuse_jacobian,
            mass_diagonal=problem.mass_diagonal(),
            preconditioner_lag=lag if reuse_jacobian else 0,
            facet_activity=activity,
            symmetric=problem.symmetric_jacobian,
            coupling=self._pair_coupling(F, state, test, bcs),
            cell_state=(self.u, self.v, self.a) if reuse_jacobian else (),
            facet_parts=facet_parts,
        )

    def _pair_coupling(self, F, state, test, bcs):
        """The terms of contact between bodies beyond the UFL forms (None without pairs):
        each pair's partner-tested residual, written by the scheme like its own terms."""
        problem = self.problem
        if not problem.pairs:
            return None
        from .pairs import PairCoupling

        def partner_term(pair, u, velocity, force, v):
            return pair.partner_term(force, v)

        residuals = [
            self.scheme.residual(ContactTerms([pair], partner_term), *state, test)
            for pair in problem.pairs
        ]
        return PairCoupling(
            problem.pairs, F, residuals, self.w, self._dirichlet.dofs, problem.symmetric_jacobian
        )

    def _initialize(self, petsc_options) -> None:
        """u0, v0 and the consistent initial acceleration M a0 = L(0) - B(u0)."""
        problem, gdim = self.problem, self.problem.gdim
        interpolate_initial(self.u, problem.initial_displacement, gdim)
        interpolate_initial(self.v, problem.initial_velocity, gdim)
        self._dirichlet.set_values(self.u.x.array, 0.0)
        check_initial_gap(self.diagnostics.penetration.max(), problem.mesh)
        check_pairs_apart(problem, self.u)
        problem.set_time(0.0)
        initial_acceleration(
            problem,
            self.a,
            lambda test: problem.operator(self.u, test, self.v),
            self._dirichlet,
            petsc_options,
        )

    def state(self) -> dict[str, float]:
        """Diagnostics at the current time level, identical on every rank."""
        values = {"t": self.t, **self._diagnostics()}
        values["friction_dissipation"] = self.friction_dissipation
        values["energy_balance_residual"] = (
            0.0
            if self._energy_before is None
            else values["energy_theta"] - self._energy_before + self.friction_dissipation
        )
        values["newton_iterations"] = self.newton_iterations
        values["step_seconds"] = self.step_seconds
        values["dt"] = self.last_dt
        values["step_cuts"] = self.step_cuts
        return values

    def step(self, t_new: float | None = None, cuts: int = 0) -> int:
        """Advance one time step to ``t_new`` (default: the next nominal level); returns
        the Newton iterations. If Newton fails, the state stays that of t^n."""
        start = time.perf_counter()
        problem, scheme = self.problem, self.scheme
        t_new, dt = self._step_to(t_new)
        self._set_step_size(dt)
        problem.set_time(scheme.equation_time(self.t, dt))
        u, v, a = self.u.x.array, self.v.x.array, self.a.x.array
        if self._dirichlet:
            u_free, _, _ = scheme.kinematics(u, v, a, 0.0, dt)
            target = u_free.copy()
            self._dirichlet.set_values(target, t_new)
            self._w_bc.x.array[:] = (target - u_free) / scheme.displacement_coefficient(dt)
        self._energy_before = self._energy_theta()
        self.w.x.array[:] = a  # initial guess: the last acceleration
        try:
            iterations = self._solve()
        except SolverError as error:
            error.add_context(step=self.step_index + 1, t=t_new)
            raise
        u1, v1, a1 = scheme.kinematics(u, v, a, self.w.x.array, dt)
        massless_velocity(self._massless, u, u1, v1, a1, dt)
        if self._friction is not None:  # before u^n is overwritten
            self.friction_dissipation = self._friction.work(u1 - u)
        for previous, new, array in zip(self._previous, (u1, v1, a1), (u, v, a)):
            previous[:], array[:] = array, new
        self._check_energy_control(iterations, t_new)
        self._arrive(t_new, dt, cuts)
        problem.set_time(self.t)
        self.newton_iterations = iterations
        self.step_seconds = time.perf_counter() - start
        return iterations

    def _set_step_size(self, dt: float) -> None:
        """Make the step's equation one for a step of size ``dt`` (its bulk Jacobian, in
        which tau appears, is then assembled again)."""
        if float(self._dt.value) != dt:
            self._dt.value = dt
            self.solver.update_constant_terms()

    def _diagnostics(self) -> dict[str, float]:
        """The diagnostics of the current level, computed once per level."""
        if self._diagnostics_cache is None or self._diagnostics_cache[0] != self.step_index:
            self._diagnostics_cache = (self.step_index, self.diagnostics.compute())
        return self._diagnostics_cache[1]

    def _energy_theta(self) -> float:
        """E_Theta at the current level."""
        return self._diagnostics()["energy_theta"]

    def _check_energy_control(self, iterations: int, t_new: float) -> None:
        """Refuse the new state just written to u, v, a if E_Theta does not control it
        (:func:`energy_controlled`): u^n, v^n, a^n are put back and
        :class:`UncontrolledStep` raised."""
        values = self.diagnostics.compute()
        if energy_controlled(values):
            self._diagnostics_cache = (self.step_index + 1, values)
            return
        for previous, function in zip(self._previous, (self.u, self.v, self.a)):
            function.x.array[:] = previous
        error = UncontrolledStep(values, iterations, self.problem.stability_hint())
        error.add_context(step=self.step_index + 1, t=t_new)
        raise error

    def _solve(self) -> int:
        """The step's Newton solve from the current ``w``; returns the Newton iterations.
        With friction, guarded (see :class:`~nitsche_dolfinx.friction.GuardedNewton`)."""
        if self._guarded is None:
            return self.solver.solve_with_line_search()
        guarded, solver = self._guarded, self.solver
        # every guarded solve of the step has the tolerance of Coulomb's equation
        tolerance = solver.snes.getTolerances()[0] * guarded.coulomb_scale(solver)
        try:
            return guarded.solve(solver, self._coasting_unknown(), tolerance, self.guard_updates)
        except SolverError as error:
            error.residual_norm = guarded.coulomb_residual(solver, new_coefficients=False)
            raise

    def _coasting_unknown(self) -> np.ndarray:
        """The unknown w of the step whose new velocity is v^n: the state coasting at
        constant velocity, where the guarded friction law takes its first reference."""
        u, v, a, dt = self.u.x.array, self.v.x.array, self.a.x.array, float(self._dt.value)
        _, v_0, _ = self.scheme.kinematics(u, v, a, 0.0, dt)
        _, v_1, _ = self.scheme.kinematics(u, v, a, 1.0, dt)
        return (v - v_0) / (v_1 - v_0)

    def contact_pressure(self):
        """The contact pressure lambda_h = -(1/gamma_h) [P_gamma(u)]_+ of the first
        obstacle, as a UFL expression on its Gamma_C (docs/method.md section 2)."""
        return self.problem.contacts[0].pressure(self.u)

    def output_fields(self) -> dict:
        """Displacement, velocity, von Mises stress, the contact fields on Gamma_C
        (:class:`~nitsche_dolfinx.fields.ContactFields`: contact pressure, gap, contact
        status) and with friction the slip velocity and the friction traction
        (:class:`~nitsche_dolfinx.friction.FrictionOutput`)."""
        shape = (self.problem.gdim,)
        fields = {
            "displacement": (self.u, shape),
            "velocity": (self.v, shape),
            "von_mises": (von_mises(self.u, self.problem.material_constants), ()),
        }
        if self.problem.contacts:
            if self._contact_fields is None:  # compiled when first asked for
                self._contact_fields = ContactFields(self.problem, self.u)
            fields.update(self._contact_fields.fields())
            if self._friction is not None:
                for field in self._friction.fields:
                    source = OnBoundary(field.function, self._contact_fields.facets)
                    fields[field.function.name] = (source, shape)
        return fields

    def before_output(self) -> None:
        """Update the boundary projections of the contact and friction fields (only when
        written)."""
        if self._contact_fields is not None:
            self._contact_fields.update()
        if self._friction is not None:
            self._friction.update_fields()

    def checkpoint_functions(self) -> dict[str, fem.Function]:
        return {"displacement": self.u, "velocity": self.v, "acceleration": self.a}

    def describe(self) -> dict[str, Any]:
        return checkpoint_description(self)

    def levels(self) -> dict[str, Any]:
        """The clock, and what the next inexact linear solve depends on, for a checkpoint."""
        moved = self.solver.linear_tolerances.last_move
        return {**super().levels(), "contact_set_moved": moved}

    def restore(self, t: float, step_index: int, saved: dict[str, Any]) -> None:
        self._restore_levels(t, step_index, saved)
        # (an int: the last iterate at which the set moved; a bool in older checkpoints)
        self.solver.linear_tolerances.last_move = int(saved.get("contact_set_moved", 0))
        self._diagnostics_cache = None  # the loaded state's are computed anew
        self.newton_iterations = int(saved.get("newton_iterations", 0))
        self.step_seconds = 0.0
        self.problem.set_time(t)
