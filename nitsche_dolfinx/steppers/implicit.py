"""One time step of a :class:`~nitsche_dolfinx.model.problem.ContactProblem` with Nitsche or penalty
contact, and its state.

A stepper holds the state (u^n, v^n, a^n) at t^n and advances it by one step of its time
scheme: one SNES solve for the scheme's unknown ``w`` (docs/method.md section 3), then the
kinematic update. It reports the diagnostics of the time level
(:meth:`NitscheStepper.state`), the fields to write and the functions a checkpoint must
hold. :class:`~nitsche_dolfinx.simulation.Simulation` drives any stepper of the
:class:`~nitsche_dolfinx.steppers.base.Stepper` protocol through a run;
:class:`~nitsche_dolfinx.steppers.mixed.MixedStepper` steps the mixed method.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from petsc4py import PETSc

from ..assembly.affine_system import AffineSystem, StepForms
from ..assembly.pair_coupling import PairCoupling
from ..assembly.systems import FormSystem
from ..common import compat
from ..common.parameters import ParameterError, TimeStepping
from ..contact.terms import ContactTerms, contact_activity, contact_parts
from ..model.problem import ContactProblem
from ..output.diagnostics import Diagnostics
from ..output.fields import ContactFields, LevelRefresh, OnBoundary, body_fields
from ..physics.damping import DampingPower, DiagonalDamping
from ..physics.dirichlet import DirichletDofs
from ..solvers.linear_solvers import LinearSolver
from ..solvers.petsc_snes import SolverSettings
from ..solvers.solver import SNESSolver, SolverError
from .base import (
    UncontrolledStep,
    check_initial_gap,
    check_pairs_apart,
    checkpoint_description,
    energy_controlled,
    initial_acceleration,
    interpolate_initial,
    massless_velocity,
)
from .friction import FrictionOutput, GuardedNewton
from .obstacle_work import ObstacleWork
from .schemes import HybridScheme, TimeScheme
from .timelevels import TimeLevels
from .work import BalanceSums, ExternalWork

__all__ = ["NitscheStepper", "step_solver"]


def step_solver(
    problem: ContactProblem, scheme: TimeScheme, state: tuple, bcs, settings: SolverSettings,
    reuse_jacobian: bool = True, model=None, dirichlet_dofs=(), bc_values=None,
) -> SNESSolver:  # fmt: skip
    """The SNES of a step's equation F(w) = 0 (docs/method.md section 8).

    Args:
        problem: The problem.
        scheme: The time scheme, which writes F from the problem's terms.
        state: ``(w, u, v, a, dt)``: the unknown, the state at t^n, the step (a Constant).
        bcs: The Dirichlet conditions on ``w``.
        settings: The solver's :class:`~nitsche_dolfinx.solvers.petsc_snes.SolverSettings`.
        reuse_jacobian: Solve the :class:`~nitsche_dolfinx.assembly.systems.AffineSystem` (the bulk
            is linear elastodynamics: its cell terms are affine in the unknown, and only
            the contact terms on Gamma_C change the Jacobian); False: assemble every
            Jacobian in full (with contact pairs, their coupling added), as at finite
            strains.
        model: The model whose terms F holds (``problem``, or its friction law guarded by
            :class:`~nitsche_dolfinx.steppers.friction.GuardedNewton`).
        dirichlet_dofs: The local indices of the Dirichlet dofs (for contact pairs).
        bc_values: The Function whose values ``bcs`` give the Dirichlet dofs, if any.
    """
    model = problem if model is None else model
    w, u, v, a, _ = state
    test = ufl.TestFunction(problem.V)
    F = scheme.residual(model, *state, test)
    if not reuse_jacobian or problem.finite:  # finite strains: no affine bulk to keep
        # contact pairs: their coupling added to the full Jacobian (docs/method.md
        # section 15)
        coupling = _pair_coupling(problem, scheme, F, state, test, dirichlet_dofs, model)
        diagonal = _mass_diagonal(problem, scheme, state)
        system = FormSystem(F, w, bcs, mass_diagonal=diagonal, coupling=coupling)
        return SNESSolver.for_system(system, settings)
    activity, facet_parts = None, None
    if problem.contacts:  # lets the solver skip the contact Jacobian out of contact
        cellwise = ufl.TestFunction(compat.function_space(problem.mesh, "DG", 0))
        activity = scheme.residual(contact_activity(problem), *state, cellwise)
        facet_parts = [
            scheme.residual(part, *state, test)
            for part in contact_parts(problem, getattr(model, "reference", None))
        ]
    coupling = _pair_coupling(problem, scheme, F, state, test, dirichlet_dofs, model)
    forms = StepForms(F, None, activity, facet_parts, (u, v, a), coupling)
    diagonal = _mass_diagonal(problem, scheme, state)
    system = AffineSystem(forms, w, bcs, diagonal, settings.matrix_type)
    if bc_values is not None:
        system.prescribe(dirichlet_dofs, bc_values)
    return SNESSolver.for_system(system, settings)


def _mass_diagonal(problem: ContactProblem, scheme: TimeScheme, state: tuple):
    """The diagonal mass the solver adds (None: the consistent mass, in the forms); with
    damping, with its alpha part at the scheme's damping velocity v_d(w) = v_0 + c w
    (:class:`~nitsche_dolfinx.physics.damping.DiagonalDamping`, docs/method.md section 14)."""
    diagonal = problem.mass_diagonal()
    if diagonal is None or problem.damping is None:
        return diagonal
    _, u, v, a, dt = state

    def velocity():
        arrays = (u.x.array, v.x.array, a.x.array)
        return scheme.damping_velocity(*arrays, 0.0, float(dt.value))

    def coefficient():
        return scheme.damping_velocity(0.0, 0.0, 0.0, 1.0, float(dt.value))

    return DiagonalDamping(diagonal, problem.damping.alpha, velocity, coefficient)


def _pair_coupling(
    problem, scheme, F, state, test, dirichlet_dofs, model=None
) -> PairCoupling | None:
    """The terms of contact between bodies beyond the UFL forms (None without pairs): each
    pair's partner-tested residual, written by the scheme like its own terms (with the
    friction law of ``model``, guarded or not)."""
    if not problem.pairs:
        return None
    reference = getattr(model, "reference", None)

    def partner_term(pair, u, velocity, force, v):
        return pair.partner_force_terms(u, velocity, force, v, reference)

    residuals = [
        scheme.residual(ContactTerms([pair], partner_term), *state, test) for pair in problem.pairs
    ]
    return PairCoupling(
        problem.pairs, F, residuals, state[0], dirichlet_dofs, problem.symmetric_jacobian
    )


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


class NitscheStepper(TimeLevels, BalanceSums):
    """Steps of a :class:`~nitsche_dolfinx.model.problem.ContactProblem` with Nitsche or penalty
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
        linear_solver: LinearSolver | None = None,
        reuse_jacobian: bool = True,
        guard_friction: bool = True,
    ):
        _check_scheme(problem, scheme, time_stepping.dt)
        self.problem, self.scheme = problem, scheme
        self._start_levels(time_stepping)
        self.comm = problem.mesh.comm
        V = problem.V
        self.u = fem.Function(V, name="displacement")
        self.v = fem.Function(V, name="velocity")
        self.a = fem.Function(V, name="acceleration")
        self.w = fem.Function(V, name="unknown")
        #: At finite strains, the last step's unknown, the next step's initial guess (kept in
        #: checkpoints: a restart takes the same guess); None otherwise.
        self._last_unknown = fem.Function(V, name="last_unknown") if problem.finite else None
        problem.track_partners(self.u, self.v, self.a, self.w)  # contact between bodies
        self.newton_iterations, self.step_seconds = 0, 0.0

        self._dirichlet = DirichletDofs(problem)
        self._w_bc = fem.Function(V)  # the unknown's values at the Dirichlet dofs
        bcs = self._dirichlet.boundary_conditions(self._w_bc)
        self._dt = dt_c = fem.Constant(problem.mesh, self.dt)  # the size of the step
        settings = SolverSettings(
            self.comm, petsc_options, linear_solver,
            linear_solver.preconditioner_lag if linear_solver and reuse_jacobian else 0,
            problem.symmetric_jacobian,
        )  # fmt: skip
        state = (self.w, self.u, self.v, self.a, dt_c)
        self._guarded = None
        if problem.frictional and guard_friction:
            self._guarded = GuardedNewton(problem, scheme, state)
        model = problem if self._guarded is None else self._guarded.model
        self.solver = step_solver(
            problem, scheme, state, bcs, settings, reuse_jacobian, model,
            self._dirichlet.dofs, self._w_bc,
        )  # fmt: skip
        self.diagnostics = Diagnostics(problem, self.u, self.v)
        self.friction_dissipation = 0.0
        #: The energy dissipated by damping since t = 0, and by the last step (docs/method.md
        #: section 14).
        self.damping_dissipation, self._damping_step = 0.0, 0.0
        self.pairing_energy = 0.0  # E_Theta changed by pairings (docs/method.md section 11)
        self._damping_power = None
        if problem.damping is not None:
            moments = self.diagnostics.moments
            self._damping_power = DampingPower(
                problem.damping, moments.matrix.mult, self.diagnostics.stiffness_matrix,
                self.comm,
            )  # fmt: skip
        self._energy_before = None  # E_Theta^n of the last step
        self._previous = [np.empty_like(f.x.array) for f in (self.u, self.v, self.a)]
        self._friction = FrictionOutput(self, dt_c) if problem.frictional else None
        self._contact_fields = None  # ContactFields, once the output asks for them
        self._massless = problem.massless_dofs()
        # the energy balance (docs/method.md section 13): the obstacles' work and the contact
        # dissipation, the work of the loads and the supports, the supports' reactions
        self._obstacles = None
        if self._keeps_accounts(problem):
            self._u_new = fem.Function(V)
            self._obstacles = ObstacleWork(problem, scheme, self.u, self._u_new)
        self._external = None
        if self._dirichlet or problem.has_loads:
            self._external = ExternalWork(
                problem, self._dirichlet, isinstance(scheme, HybridScheme)
            )
            self._load_form = fem.form(problem.load(ufl.TestFunction(V)))
            self._loads = None  # the loads' vector while they do not depend on t
        self._friction_total = 0.0  # the friction dissipation since t = 0
        self._initialize(petsc_options, linear_solver)
        if self._last_unknown is not None:  # the first step's guess: a0
            self._last_unknown.x.array[:] = self.a.x.array
        self._internal_energy0 = self._internal_energy()

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
        if not self.problem.has_loads:
            return None
        if self._loads is not None and not self.problem.loads_in_time:
            return self._loads
        vector = compat.create_vector(self.problem.V)
        with vector.localForm() as local:
            local.set(0.0)
        fem_petsc.assemble_vector(vector, self._load_form)
        vector.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        self._loads = vector.array_r.copy()
        vector.destroy()
        return self._loads

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

    def state(self, columns=None) -> dict[str, float]:
        """Diagnostics at the current time level, identical on every rank: those of every
        level, and the optional ones (:class:`~nitsche_dolfinx.output.diagnostics.Diagnostics`)
        that ``columns`` name (None: all)."""
        values = {"t": self.t, **self.diagnostics.of_level(self.step_index, columns)}
        values.update(self._balance_columns())
        values["friction_dissipation"] = self.friction_dissipation
        dissipated = self.friction_dissipation + self._damping_step
        values["energy_balance_residual"] = (
            0.0
            if self._energy_before is None
            else values["energy_theta"] - self._energy_before + dissipated
        )
        if self._damping_power is not None:
            values["damping_dissipation"] = self.damping_dissipation
        values["newton_iterations"] = self.newton_iterations
        values["pairing_energy"] = self.pairing_energy
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
        if self._dirichlet:  # the unknown's values that give u^{n+1} its prescribed ones
            dofs = self._dirichlet.prescribed
            u_free, _, _ = scheme.kinematics(u[dofs], v[dofs], a[dofs], 0.0, dt)
            prescribed = self._dirichlet.values(t_new)
            coefficient = scheme.displacement_coefficient(dt)
            self._w_bc.x.array[dofs] = (prescribed - u_free) / coefficient
        self._energy_before = self._energy_theta()
        problem.move_obstacles(self.t, t_new)
        # initial guess: the last acceleration; at finite strains the last step's unknown
        # (the hybrid scheme's a^{n+1} = 2 w - a^n alternates from step to step, too poor a
        # guess for a nonlinear solve: Newton diverged from it on the P2 disk)
        self.w.x.array[:] = a if self._last_unknown is None else self._last_unknown.x.array
        if self._external is not None:  # at rest in equilibrium, the scale of the equation
            self.solver.force_scale = self._external.force_norm()
        if problem.finite:  # no exact iterate to recognise (docs/method.md section 15)
            inertia = self.diagnostics.moments.inertia_norm(self.v, dt)
            self.solver.force_scale = max(self.solver.force_scale, inertia)
        try:
            iterations = self._solve()
        except SolverError as error:
            problem.move_obstacles(self.t)
            error.add_context(step=self.step_index + 1, t=t_new)
            raise
        u1, v1, a1 = scheme.kinematics(u, v, a, self.w.x.array, dt)
        damping = self._damping_work(v, v1, dt)  # (the kinematic v^{n+1}: the equation's)
        massless_velocity(self._massless, u, u1, v1, a1, dt)
        if self._friction is not None:  # before u^n is overwritten
            self.friction_dissipation = self._friction.work(u1 - u)
        sums = self._running_sums()  # to put back if the step is refused
        if self._obstacles is not None:
            self._u_new.x.array[:] = u1
            self._obstacles.step()
        if self._external is not None:  # the equation's reactions and loads, before u moves
            self._external.step(u1 - u, self._reactions(), self._load_vector())
        for previous, new, array in zip(self._previous, (u1, v1, a1), (u, v, a)):
            previous[:], array[:] = array, new
        try:
            self._check_energy_control(iterations, t_new)
        except UncontrolledStep:
            problem.move_obstacles(self.t)
            self._restore_sums(sums)
            raise
        if self._last_unknown is not None:  # the guess of the next step: an accepted one
            self._last_unknown.x.array[:] = self.w.x.array
        self._damping_step = damping
        self.damping_dissipation += damping
        self._friction_total += self.friction_dissipation
        self._arrive(t_new, dt, cuts)
        problem.set_time(self.t)
        problem.move_obstacles(self.t)
        self.pairing_energy += self.diagnostics.follow_pairs(self.step_index)
        self.newton_iterations = iterations
        self.step_seconds = time.perf_counter() - start
        return iterations

    def _damping_work(self, v: np.ndarray, v1: np.ndarray, dt: float) -> float:
        """The energy damping dissipates over a step, tau (v_m, C v_m) with
        v_m = (v^n + v^{n+1}) / 2 (docs/method.md section 14): the trapezoidal rule of the
        power of the levels' forces C v^n and C v^{n+1} for theta and Newmark, the
        midpoint force C v^{n+1/2} of the hybrid scheme; 0 without damping."""
        if self._damping_power is None:
            return 0.0
        mean = (v + v1) / 2
        return dt * self._damping_power(mean)

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
        for previous, function in zip(self._previous, (self.u, self.v, self.a)):
            function.x.array[:] = previous
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

    def contact_pressure(self):
        """The contact pressure lambda_h = -(1/gamma_h) [P_gamma(u)]_+ of the first contact
        term (an obstacle or a pair's half), as a UFL expression on its Gamma_C
        (docs/method.md section 2)."""
        return self.problem.contacts[0].pressure(self.u)

    def output_fields(self) -> dict:
        """Displacement, velocity, von Mises stress, the contact fields on Gamma_C
        (:class:`~nitsche_dolfinx.output.fields.ContactFields`: contact pressure, gap, contact
        status) and with friction the slip velocity and the friction traction
        (:class:`~nitsche_dolfinx.steppers.friction.FrictionOutput`)."""
        shape = (self.problem.gdim,)
        fields = body_fields(self.problem, self.u, self.v)
        if self.problem.contacts:
            if self._contact_fields is None:  # compiled when first asked for
                self._contact_fields = ContactFields(self.problem, self.u)
            on_contact = dict(self._contact_fields.fields())
            if self._friction is not None:
                for field in self._friction.fields:
                    source = OnBoundary(field.function, self._contact_fields.facets)
                    on_contact[field.function.name] = (source, shape)
            refresh = LevelRefresh(self._update_projections, lambda: (self.step_index, self.t))
            fields.update({name: (refresh.wrap(f), s) for name, (f, s) in on_contact.items()})
        return fields

    def _update_projections(self) -> None:
        """The boundary projections of the contact and friction fields at the state."""
        self._contact_fields.update()
        if self._friction is not None:
            self._friction.update_fields()

    def checkpoint_functions(self) -> dict[str, fem.Function]:
        """Everything the next step depends on, by name: u, v and a; at finite strain the
        last accepted unknown (the next step's first guess); the supports' reactions; the
        displacements the contact pairs were paired in."""
        functions = {"displacement": self.u, "velocity": self.v, "acceleration": self.a}
        if self._last_unknown is not None:
            functions["last_unknown"] = self._last_unknown
        return {**functions, **self._balance_functions(), **self.problem.pairing_state()}

    def describe(self) -> dict[str, Any]:
        """What a checkpoint shares with the stepper that reloads it
        (:func:`~nitsche_dolfinx.steppers.base.checkpoint_description`)."""
        return checkpoint_description(self)

    def levels(self) -> dict[str, Any]:
        """The clock, and what the next inexact linear solve depends on, for a checkpoint."""
        moved = self.solver.linear_tolerances.last_move
        levels = {**super().levels(), "contact_set_moved": moved, **self._saved_sums()}
        if self.problem.pairs:
            levels["pairing_energy"] = self.pairing_energy
        if self._damping_power is not None:  # the running total (docs/method.md section 14)
            levels["damping_dissipation"] = self.damping_dissipation
        return levels

    def restore(self, t: float, step_index: int, saved: dict[str, Any]) -> None:
        """Move to a time level whose functions were just loaded (``saved``: the
        checkpoint's description and :meth:`levels`): the clock, the pairings, the sums
        of the balance, the data and the obstacles at ``t``; the level's diagnostics are
        computed anew."""
        self._restore_levels(t, step_index, saved)
        self.problem.restore_pairs()
        # (an int: the last iterate at which the set moved; a bool in older checkpoints)
        self.solver.linear_tolerances.last_move = int(saved.get("contact_set_moved", 0))
        self.diagnostics.remember(step_index, None)  # the loaded state's are computed anew
        self.newton_iterations = int(saved.get("newton_iterations", 0))
        self.step_seconds = 0.0
        self.damping_dissipation = float(saved.get("damping_dissipation", 0.0))
        self._damping_step = 0.0
        self.pairing_energy = float(saved.get("pairing_energy", 0.0))
        self.problem.set_time(t)
        self.problem.move_obstacles(t)
        self._load_sums(saved, self._load_vector() if self._external is not None else None)
