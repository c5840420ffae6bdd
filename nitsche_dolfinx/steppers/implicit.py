"""One time step of a :class:`~nitsche_dolfinx.model.problem.ContactProblem` with Nitsche or
penalty contact, and its state.

A stepper holds the state (u^n, v^n, a^n) at t^n and advances it by one step of its time
scheme: one SNES solve for the scheme's unknown ``w`` (docs/method.md section 3; the solver:
:func:`~nitsche_dolfinx.steppers.step_solver.step_solver`), then the kinematic update and
the parts of the step (:mod:`~nitsche_dolfinx.steppers.parts`). It reports the diagnostics
of the time level, the fields to write and the functions a checkpoint must hold
(:class:`~nitsche_dolfinx.steppers.balance.BalancedStepper`).
:class:`~nitsche_dolfinx.simulation.Simulation` drives any stepper of the
:class:`~nitsche_dolfinx.steppers.base.Stepper` protocol through a run;
:class:`~nitsche_dolfinx.steppers.mixed.MixedStepper` steps the mixed method.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import ufl
from dolfinx import fem

from ..common import compat
from ..common.parameters import ParameterError, TimeStepping
from ..model.problem import ContactProblem
from ..output.diagnostics import Diagnostics
from ..physics.damping import DampingPower
from ..physics.dirichlet import DirichletDofs
from ..solvers.linear_solvers import LinearSolver
from ..solvers.petsc_snes import SolverSettings
from ..solvers.solver import SolverError
from .balance import BalancedStepper
from .base import (
    LoadVector,
    UncontrolledStep,
    check_initial_gap,
    check_pairs_apart,
    energy_controlled,
    initial_acceleration,
    interpolate_initial,
    massless_velocity,
)
from .damping_work import ImplicitDamping
from .friction import FrictionOutput, FrictionWork, GuardedNewton
from .obstacle_work import ObstacleWork
from .parts import PairingEnergy, StepEnds, StepParts
from .schemes import HybridScheme, TimeScheme
from .step_solver import step_solver
from .work import ExternalWork

__all__ = ["NitscheStepper", "step_solver"]


def _check_scheme(problem: ContactProblem, scheme: TimeScheme, dt: float) -> None:
    """Refuse the schemes that cannot step ``problem``."""
    if problem.mass == "redistributed" and isinstance(scheme, HybridScheme):
        raise ParameterError(
            "mass",
            problem.mass,
            "not with the hybrid scheme: the massless contact nodes are then left to "
            "alternate around the obstacle (measured: E grows 48-fold on the bar); use "
            "the redistributed mass with Crank-Nicolson, theta or Newmark",
        )
    if problem.mass == "lumped" and problem.degree > 1:
        raise ParameterError(
            "mass", problem.mass,
            "the P2 lumped (HRZ) mass is for the verlet scheme: the implicit schemes would "
            "take the body force consistently (none on the vertices) against a lumped mass",
        )  # fmt: skip
    if scheme.displacement_coefficient(dt) == 0.0:
        raise ParameterError(
            "scheme",
            scheme.describe(),
            "theta = 0 and Newmark beta = 0 are explicit: u^{n+1} is known before the "
            "step's solve, whose equation then has no stiffness (nor contact) part for "
            "this implicit stepper to solve, and no time step limit is checked; use the "
            "verlet scheme (explicit, with its stable step), or theta > 0 or beta > 0",
        )


class NitscheStepper(BalancedStepper):
    """Steps of a :class:`~nitsche_dolfinx.model.problem.ContactProblem` with Nitsche or
    penalty contact by a time scheme: one SNES solve per step.

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
        linear_solver: LinearSolver | None = None,
        reuse_jacobian: bool = True,
        guard_friction: bool = True,
    ):
        _check_scheme(problem, scheme, time_stepping.dt)
        self._start(problem, scheme, time_stepping)
        V = problem.V
        self.w = fem.Function(V, name="unknown")
        #: At finite strains, the last step's unknown, the next step's initial guess (kept in
        #: checkpoints: a restart takes the same guess); None otherwise.
        self._last_unknown = fem.Function(V, name="last_unknown") if problem.finite else None
        problem.track_partners(self.u, self.v, self.a, self.w)  # contact between bodies
        self._dirichlet = DirichletDofs(problem)
        self._w_bc = fem.Function(V)  # the unknown's values at the Dirichlet dofs
        self._dt = fem.Constant(problem.mesh, self.dt)  # the size of the step
        self._build_solver(petsc_options, linear_solver, reuse_jacobian, guard_friction)
        self.diagnostics = Diagnostics(problem, self.u, self.v)
        self._massless = problem.massless_dofs()
        self._loads = None  # the loads' vector (a LoadVector), with loads
        if problem.has_loads:
            self._loads = LoadVector(problem, fem.form(problem.load(ufl.TestFunction(V))))
        self.parts = StepParts(self._make_parts())
        self._initialize(petsc_options, linear_solver)
        if self._last_unknown is not None:  # the first step's guess: a0
            self._last_unknown.x.array[:] = self.a.x.array
        self._internal_energy0 = self._internal_energy()

    def _build_solver(self, petsc_options, linear_solver, reuse_jacobian, guard_friction):
        """The step's solver (:func:`~nitsche_dolfinx.steppers.step_solver.step_solver`),
        with friction on the guarded law (:class:`~nitsche_dolfinx.steppers.friction.
        GuardedNewton`) unless ``guard_friction`` is False."""
        problem = self.problem
        bcs = self._dirichlet.boundary_conditions(self._w_bc)
        settings = SolverSettings(
            self.comm, petsc_options, linear_solver,
            linear_solver.preconditioner_lag if linear_solver and reuse_jacobian else 0,
            problem.symmetric_jacobian,
        )  # fmt: skip
        state = (self.w, self.u, self.v, self.a, self._dt)
        self._guarded = None
        if problem.frictional and guard_friction:
            self._guarded = GuardedNewton(problem, self.scheme, state)
        model = problem if self._guarded is None else self._guarded.model
        self.solver = step_solver(
            problem, self.scheme, state, bcs, settings, reuse_jacobian, model,
            self._dirichlet.dofs, self._w_bc,
        )  # fmt: skip

    def _make_parts(self) -> list:
        """The parts of the steps, in the order they are called: the friction's work, the
        damping's dissipation, the energy balance's sums (docs/method.md section 13: the
        obstacles' work and the contact dissipation, the work of the loads and the
        supports, the supports' reactions) and the pairings' energy."""
        problem, midpoint = self.problem, self.scheme.midpoint
        friction = damping = obstacles = self._external = None
        if problem.frictional:
            self._friction_output = FrictionOutput(self, self._dt)
            friction = FrictionWork(self._friction_output)
        if problem.damping is not None:
            moments = self.diagnostics.moments
            damping = ImplicitDamping(DampingPower(
                problem.damping, moments.matrix.mult, self.diagnostics.stiffness_matrix,
                self.comm,
            ))  # fmt: skip
        if self._keeps_accounts(problem):
            obstacles = ObstacleWork(problem, midpoint, self.u)
        if self._dirichlet or problem.has_loads:
            self._external = ExternalWork(problem, self._dirichlet, midpoint, self._load_vector)
        pairing = PairingEnergy(problem, self.diagnostics)
        return [friction, damping, obstacles, self._external, pairing]

    def _initialize(self, petsc_options, linear_solver) -> None:
        """u0, v0 and the consistent initial acceleration M a0 = L(0) - B(u0)."""
        problem, gdim = self.problem, self.problem.gdim
        interpolate_initial(self.u, problem.initial_displacement, gdim)
        interpolate_initial(self.v, problem.initial_velocity, gdim)
        self._dirichlet.set_values(self.u.x.array, 0.0)
        check_initial_gap(self.diagnostics.penetration.max(), problem.mesh)
        check_pairs_apart(problem, self.u)
        problem.set_time(0.0)
        problem.move_obstacles(0.0)
        residual = initial_acceleration(
            problem,
            self.a,
            lambda test: problem.operator(self.u, test, self.v),
            self._dirichlet,
            petsc_options,
            linear_solver,
            velocity=self.v,
        )
        if self._external is not None:
            self._external.start(residual[self._external.dofs], self._load_vector())

    def _load_vector(self) -> np.ndarray | None:
        """The loads' vector L(t) at the problem's time (owned dofs), None without loads;
        assembled once when the loads do not depend on t."""
        return None if self._loads is None else self._loads()

    def _reactions(self) -> np.ndarray:
        """The step's equation's residual at its solution, at the owned Dirichlet dofs: the
        supports' reactions (docs/method.md section 13); none without supports (no
        residual to assemble)."""
        if not self._dirichlet:
            return np.zeros(0)
        system = self.solver.system
        x = compat.petsc_vector(self.w).copy()
        b = x.duplicate()
        system.assemble_residual(x, b, conditions=False)
        reactions = b.array_r[self._external.dofs].copy()
        for vector in (x, b):
            vector.destroy()
        return reactions

    def step(self, t_new: float | None = None, cuts: int = 0) -> int:
        """Advance one time step to ``t_new`` (default: the next nominal level); returns
        the Newton iterations. If Newton fails, the state stays that of t^n."""
        start = time.perf_counter()
        problem, scheme = self.problem, self.scheme
        t_new, dt = self._step_to(t_new)
        self._set_step_size(dt)
        problem.set_time(scheme.equation_time(self.t, dt))
        u, v, a = self.u.x.array, self.v.x.array, self.a.x.array
        self._prescribe_unknown(t_new, dt)
        self._energy_before = self._energy_theta()
        problem.move_obstacles(self.t, t_new)
        iterations = self._solve_step(t_new, dt)
        u1, v1, a1 = scheme.kinematics(u, v, a, self.w.x.array, dt)
        ends = StepEnds(u, u1, v, v1, dt, self._reactions, self._load_vector)
        running = self.parts.running()  # to put back if the step is refused
        self.parts.step(ends)  # before u^n is overwritten
        massless_velocity(self._massless, u, u1, v1, a1, dt)
        self._keep_state()
        u[:], v[:], a[:] = u1, v1, a1
        try:
            self._check_energy_control(iterations, t_new)
        except UncontrolledStep:
            problem.move_obstacles(self.t)
            self.parts.put_back(running)
            raise
        if self._last_unknown is not None:  # the guess of the next step: an accepted one
            self._last_unknown.x.array[:] = self.w.x.array
        self._arrive(t_new, dt, cuts)
        problem.set_time(self.t)
        problem.move_obstacles(self.t)
        self.parts.accept(self.step_index, ends)
        self.newton_iterations = iterations
        self.step_seconds = time.perf_counter() - start
        return iterations

    def _prescribe_unknown(self, t_new: float, dt: float) -> None:
        """The unknown's values that give u^{n+1} its prescribed ones at the Dirichlet dofs."""
        if not self._dirichlet:
            return
        u, v, a = self.u.x.array, self.v.x.array, self.a.x.array
        dofs = self._dirichlet.prescribed
        u_free, _, _ = self.scheme.kinematics(u[dofs], v[dofs], a[dofs], 0.0, dt)
        prescribed = self._dirichlet.values(t_new)
        coefficient = self.scheme.displacement_coefficient(dt)
        self._w_bc.x.array[dofs] = (prescribed - u_free) / coefficient

    def _solve_step(self, t_new: float, dt: float) -> int:
        """The step's solve from its initial guess, on the scale of its equation; on a
        failure the obstacles are put back at t^n."""
        # initial guess: the last acceleration; at finite strains the last step's unknown
        # (the hybrid scheme's a^{n+1} = 2 w - a^n alternates from step to step, too poor a
        # guess for a nonlinear solve: Newton diverged from it on the P2 disk)
        guess = self.a if self._last_unknown is None else self._last_unknown
        self.w.x.array[:] = guess.x.array
        if self._external is not None:  # at rest in equilibrium, the scale of the equation
            self.solver.force_scale = self._external.force_norm()
        if self.problem.finite:  # no exact iterate to recognise (docs/method.md section 15)
            inertia = self.diagnostics.moments.inertia_norm(self.v, dt)
            self.solver.force_scale = max(self.solver.force_scale, inertia)
        try:
            return self._solve()
        except SolverError as error:
            self.problem.move_obstacles(self.t)
            error.add_context(step=self.step_index + 1, t=t_new)
            raise

    def _set_step_size(self, dt: float) -> None:
        """Make the step's equation one for a step of size ``dt`` (its bulk Jacobian, in
        which tau appears, is then assembled again)."""
        if float(self._dt.value) != dt:
            self._dt.value = dt
            self.solver.update_constant_terms()

    def _energy_theta(self) -> float:
        """E_Theta at the current level."""
        return self.diagnostics.of_level(self.step_index)["energy_theta"]

    def _check_energy_control(self, iterations: int, t_new: float) -> None:
        """Refuse the new state just written to u, v, a if E_Theta does not control it
        (:func:`energy_controlled`): u^n, v^n, a^n are put back and
        :class:`UncontrolledStep` raised."""
        values = self.diagnostics.energies()
        if self.problem.finite:  # an inverted element is no state (docs/method.md section 15)
            values["det_F_min"] = self.diagnostics.smallest_determinant()
        if energy_controlled(values):
            self.diagnostics.remember(self.step_index + 1, values)
            return
        self._put_back_state()
        error = UncontrolledStep(values, iterations, self.problem.stability_hint())
        error.add_context(step=self.step_index + 1, t=t_new)
        raise error

    def _solve(self) -> int:
        """The step's Newton solve from the current ``w``; returns the Newton iterations.
        With friction, guarded (see :class:`~nitsche_dolfinx.steppers.friction.GuardedNewton`)."""
        if self._guarded is None:
            return self.solver.solve_with_line_search()
        guarded, solver = self._guarded, self.solver
        # every guarded solve of the step has the tolerance of Coulomb's equation, on the
        # scale of a plain solve's: at rest, the loads and the supports' reactions
        scale = max(guarded.coulomb_scale(solver), solver.force_scale)
        tolerance = solver.snes.getTolerances()[0] * scale
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

    def _state_functions(self) -> dict[str, fem.Function]:
        """u, v and a; at finite strain the last accepted unknown (the next step's first
        guess)."""
        functions = super()._state_functions()
        if self._last_unknown is not None:
            functions["last_unknown"] = self._last_unknown
        return functions

    def levels(self) -> dict[str, Any]:
        """The clock, the sums of the balance and what the next inexact linear solve depends
        on, for a checkpoint."""
        moved = self.solver.linear_tolerances.last_move
        return {**super().levels(), "contact_set_moved": moved}

    def restore(self, t: float, step_index: int, saved: dict[str, Any]) -> None:
        """Move to a time level whose functions were just loaded
        (:meth:`BalancedStepper.restore`), with what the next inexact linear solve depends
        on."""
        super().restore(t, step_index, saved)
        # (an int: the last iterate at which the set moved; a bool in older checkpoints)
        self.solver.linear_tolerances.last_move = int(saved.get("contact_set_moved", 0))
