"""The explicit Verlet (central difference) scheme with Nitsche contact (docs/method.md
section 12): with a diagonal mass, a step is one product with the matrix of the affine
terms, one assembly of the contact force on Gamma_C and one division, without Newton and
without a linear solve::

    u^{n+1} = u^n + tau v^n + tau^2/2 a^n
    D a^{n+1} = L(t^{n+1}) - A_Thgamma(u^{n+1}, .)
                - int_Gamma_C (1/gamma_h) [P_gamma(u^{n+1})]_+ P_Thgamma(.)
    v^{n+1} = v^n + tau/2 (a^n + a^{n+1})

The stable step is estimated when the stepper is built
(:mod:`~nitsche_dolfinx.steppers.stable_step`); ``dt = "auto"`` takes its scheme's safety share.
The mass is lumped, redistributed (its massless contact nodes in equilibrium at each
level) or consistent with a CG solve a step (:mod:`~nitsche_dolfinx.steppers.explicit_mass`).
Rigid obstacles and contact pairs, Nitsche's method, frictionless; the penalty method and
friction are refused in one line.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from petsc4py import PETSc

from ..common import compat
from ..common.collective import sum_over_ranks
from ..common.parameters import ParameterError, TimeStepping, require_choice
from ..contact.coercivity import coercivity_ratio, constant_value
from ..model.problem import ContactProblem
from ..output.diagnostics import Diagnostics
from ..physics.dirichlet import DirichletDofs
from ..solvers.solver import SolverError
from .balance import BalancedStepper
from .base import check_initial_gap, check_pairs_apart, interpolate_initial, massless_velocity
from .blowup import BlowUpWatch, UnstableStep
from .damping_work import ExplicitDamping
from .explicit_force import CONTACT_FORCES, ExplicitForce
from .explicit_mass import MasslessNodes, explicit_mass
from .obstacle_work import ObstacleWork
from .parts import PairingEnergy, StepEnds, StepParts
from .schemes import VerletScheme
from .stable_step import damped_step, resolve_step
from .work import ExternalWork

__all__ = ["CONTACT_FORCES", "ExplicitStepper", "UnstableStep", "VerletScheme"]


def _check_problem(problem: ContactProblem, scheme: VerletScheme) -> None:
    """Refuse what the explicit steps do not take yet, in one line each."""
    refusals = [
        (problem.mass == "consistent" and scheme.mass_solver == "none", "mass", problem.mass,
         "the verlet scheme with the consistent mass needs a linear solve a step: say which "
         "(mass_solver='cg'), or take mass='lumped'"),
        (problem.method != "nitsche", "method", problem.method,
         "the verlet scheme takes Nitsche's method"),
        (problem.finite, "law", problem.materials[0].law,
         "the verlet scheme takes linear elasticity so far: use the hybrid scheme with a "
         "hyperelastic material"),
        (bool(problem.pairs) and problem.mass == "redistributed", "mass", problem.mass,
         "the verlet scheme takes contact between bodies with the lumped or consistent "
         "mass"),
        (bool(problem.moving_contacts) and problem.mass == "redistributed", "mass",
         problem.mass, "the verlet scheme takes a moving obstacle with the lumped or "
         "consistent mass"),
        (problem.frictional, "friction",
         constant_value(problem.friction) if problem.frictional else None,
         "the verlet scheme is frictionless"),
        (problem.damping is not None and problem.mass == "redistributed"
         and problem.damping.values[1] > 0.0, "damping_beta",
         None if problem.damping is None else problem.damping.values[1],
         "the verlet scheme takes stiffness damping with the lumped or consistent mass (the "
         "massless nodes' equilibrium has no damping force)"),
    ]  # fmt: skip
    for refused, name, value, why in refusals:
        if refused:
            raise ParameterError(name, value, why)


class ExplicitStepper(BalancedStepper):
    """Steps of a :class:`~nitsche_dolfinx.model.problem.ContactProblem` by the Verlet scheme:
    the force at u^{n+1} assembled as a vector
    (:class:`~nitsche_dolfinx.steppers.explicit_force.ExplicitForce`, ``contact_force`` one
    of :data:`~nitsche_dolfinx.steppers.explicit_force.CONTACT_FORCES`), divided by the mass
    (a diagonal, or the consistent one by CG: :mod:`~nitsche_dolfinx.steppers.explicit_mass`).
    """

    def __init__(self, problem: ContactProblem, scheme: VerletScheme, time_stepping: TimeStepping,
                 contact_force: str = "quadrature"):  # fmt: skip
        _check_problem(problem, scheme)
        require_choice(contact_force, CONTACT_FORCES, "contact_force", "contact force")
        self._start(problem, scheme, None)  # the clock once the stable step is known
        self.solver = None  # no solve in a step
        self._dirichlet = DirichletDofs(problem)
        problem.track_partners(self.u, self.v)
        fixed = self._dirichlet.dofs  # prescribed: no acceleration of their own
        self._force = ExplicitForce(problem, self.u, self.v, contact_force, fixed)
        self._mass = explicit_mass(problem, fixed)
        problem.move_obstacles(0.0)
        self._set_up_stable_step(fixed, time_stepping)
        self.diagnostics = Diagnostics(
            problem, self.u, self.v, potential=self._force.potential, elastic=self._force.elastic
        )
        self._level_reactions = None  # -F at the Dirichlet dofs of the last force evaluation
        self.parts = StepParts(self._make_parts())
        self._scratch = np.empty_like(self.u.x.array)
        self._initialize()

    def _set_up_stable_step(self, fixed, time_stepping: TimeStepping) -> None:
        """With the matrix of all the affine terms: the massless nodes, the damping, the
        estimated stable step (:func:`~nitsche_dolfinx.steppers.stable_step.damped_step`),
        the coercivity bound, and the clock with the step it resolves."""
        problem, force = self.problem, self._force
        affine = force.affine_matrix()
        self._massless = MasslessNodes(problem, self.u, force.contact_forces, affine, fixed)
        #: Rayleigh damping's force C x and dissipation (docs/method.md section 14)
        self._damping = None
        if problem.damping is not None:
            self._damping = ExplicitDamping(problem, self._mass, force.stiffness, self,
                                            force.product)  # fmt: skip
        #: The estimated stable step, with stiffness damping shrunk
        #: (:func:`~nitsche_dolfinx.physics.damping.damped_stable_step`)
        self.stable_dt = damped_step(problem, affine, self._mass, force.stiffness)
        #: The cell-wise coercivity bound of A_Thgamma (:func:`coercivity_ratio`): at 1 or
        #: above, A_Thgamma may be indefinite and the steps grow whatever dt.
        self.coercivity = coercivity_ratio(problem)
        if affine is not force.stiffness:
            affine.destroy()
        dt = resolve_step(self.scheme, self.stable_dt, time_stepping)
        self._start_levels(TimeStepping(dt, time_stepping.t_end, 0))

    def _make_parts(self) -> list:
        """The parts of the steps, in the order they are called: the damping's dissipation,
        the energy balance's sums (docs/method.md section 13: the obstacles' work and the
        contact dissipation, the work of the loads and the supports, the supports'
        reactions) and the pairings' energy."""
        problem = self.problem
        self._obstacles = self._external = None
        if self._keeps_accounts(problem):
            self._obstacles = ObstacleWork(problem, self.scheme.midpoint, self.u, True)
        if self._dirichlet or problem.has_loads:
            self._external = ExternalWork(problem, self._dirichlet, False, self._load_vector)
        pairing = PairingEnergy(problem, self.diagnostics)
        return [self._damping, self._obstacles, self._external, pairing]

    def _initialize(self) -> None:
        """u0, v0 and a0 from the force at t = 0 (with damping, less C v0); the energies the
        blow-up stops compare with."""
        problem = self.problem
        interpolate_initial(self.u, problem.initial_displacement, problem.gdim)
        interpolate_initial(self.v, problem.initial_velocity, problem.gdim)
        self._dirichlet.set_values(self.u.x.array, 0.0)
        check_initial_gap(self.diagnostics.penetration.max(), problem.mesh)
        check_pairs_apart(problem, self.u)
        problem.set_time(0.0)
        self._accelerate(equilibrium=False, velocity=self.v.x.array)
        if self._external is not None:
            self._external.start(self._level_reactions, self._load_vector())
        self._internal_energy0 = self._internal_energy()
        if self._damping is not None:
            self._damping.start()
        initial = self.diagnostics.energies()
        self._watch = BlowUpWatch(self._energy_scale(), initial, problem.autonomous,
                                  self.stable_dt)  # fmt: skip

    def _load_vector(self) -> np.ndarray | None:
        """The loads' vector at the current time, as the steps take them."""
        return self._force.load_vector()

    def _accelerate(self, equilibrium: bool = True, velocity=None, dt: float = 0.0) -> None:
        """a = M^-1 (L - B(u)) at the current u (and loads' time); with massless nodes and
        ``equilibrium``, their displacement first, from their equilibrium (not at t = 0:
        the initial displacement is the user's, as for the implicit schemes).

        With damping, the force C ``velocity`` is taken off, and a divided by
        1 + alpha ``dt`` / 2 (docs/method.md section 14: at a step, ``velocity`` is
        v^{n+1/2} and alpha M v^{n+1} = alpha M (v^{n+1/2} + dt/2 a^{n+1}); at t = 0, v0 and
        ``dt`` = 0)."""
        if self._massless.active and equilibrium:
            force = self._massless.solve(self._force.assemble)
        else:
            force, _ = self._force.assemble()
        if self._damping is not None:
            force.axpy(-1.0, self._damping.force(velocity, self._force.work))
            force.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        if self._external is not None:  # the supports hold their dofs: R = -F there
            self._level_reactions = -force.array_r[self._external.dofs]
        self._mass.divide(force, self.a)
        if self._damping is not None and dt > 0.0:
            self.a.x.array[:] /= 1.0 + self._damping.alpha * dt / 2

    def step(self, t_new: float | None = None, cuts: int = 0) -> int:
        """One Verlet step to ``t_new`` (default: the next level); returns 0 (no Newton)."""
        start = time.perf_counter()
        t_new, dt = self._step_to(t_new)
        u, v, a = self.u.x.array, self.v.x.array, self.a.x.array
        self._keep_state()
        level = self.diagnostics.of_level(self.step_index)
        self._energy_before = level["energy_theta"]
        self._watch.check_drift(level["energy"], dt, self.step_index, self.t)
        scratch = self._scratch  # in place: no temporaries of the size of u
        half_step = None if self._damping is None else v + dt / 2 * a  # v^{n+1/2}
        u += np.multiply(dt, v, out=scratch)
        u += np.multiply(dt**2 / 2, a, out=scratch)
        self._dirichlet.set_values(u, t_new)
        self.problem.set_time(t_new)
        self.problem.move_obstacles(self.t, t_new)
        self._running = self.parts.running()  # the sums before the step
        try:
            self._accelerate(velocity=half_step, dt=dt)
        except SolverError as error:
            self._put_back()
            error.add_context(step=self.step_index + 1, t=t_new)
            raise
        u0, v0, a0 = self._previous
        ends = StepEnds(u0, u, v0, v, dt, lambda: self._level_reactions, self._load_vector)
        obstacle_work = None if self._obstacles is None else self._obstacles.work
        self.parts.step(ends)
        v += np.multiply(dt / 2, np.add(a0, a, out=scratch), out=scratch)
        if self._dirichlet:  # the prescribed dofs' velocity: the step's mean
            dofs = self._dirichlet.prescribed
            v[dofs] = (u[dofs] - u0[dofs]) / dt
        massless_velocity(self._massless.local, u0, u, v, a, dt)
        error = self._watch.growth(self._energy_scale(), dt, obstacle_work)
        if error is not None:
            self._put_back()
            error.add_context(step=self.step_index + 1, t=t_new)
            raise error
        self._arrive(t_new, dt, cuts)
        self.problem.move_obstacles(self.t)
        self.parts.accept(self.step_index, ends)
        self.step_seconds = time.perf_counter() - start
        return 0

    def _energy_scale(self) -> float:
        """1/2 v.M v + |1/2 u.K u| (K: the affine terms), from the last force evaluation: a
        measure of the energy for the blow-up check, without assembly."""
        force = self._force
        n = force.product.getLocalSize()
        velocity = compat.petsc_vector(self.v)
        self._mass.mult(velocity, force.work)
        u, v = self.u.x.array[:n], self.v.x.array[:n]
        kinetic, elastic = sum_over_ranks(self.comm, [v @ force.work.array_r,
                                                      u @ force.product.array_r]) / 2  # fmt: skip
        return float(kinetic + abs(elastic))

    def _put_back(self) -> None:
        """The state of the last level, after a failed step."""
        self._put_back_state()
        self.diagnostics.remember(self.step_index, None)
        self._force.stiffness_product()  # K u of the level
        self.problem.move_obstacles(self.t)
        self.parts.put_back(self._running)

    def restore(self, t: float, step_index: int, saved: dict[str, Any]) -> None:
        """Move to a time level whose functions were just loaded
        (:meth:`BalancedStepper.restore`, the level's damping force with it), with the
        level's reactions and K u; the blow-up window starts again."""
        super().restore(t, step_index, saved)
        if self._external is not None:  # the level's reactions: the checkpoint's Function
            self._level_reactions = self._external.reaction.x.array[self._external.dofs].copy()
        self._force.stiffness_product()  # K u of the level
        self._watch.restart(self._energy_scale())
