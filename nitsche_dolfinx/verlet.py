"""The explicit Verlet (central difference) scheme with Nitsche contact (docs/method.md
section 12): with a diagonal mass, a step is one product with the matrix of the affine
terms, one assembly of the contact force on Gamma_C and one division, without Newton and
without a linear solve::

    u^{n+1} = u^n + tau v^n + tau^2/2 a^n
    D a^{n+1} = L(t^{n+1}) - A_Thgamma(u^{n+1}, .)
                - int_Gamma_C (1/gamma_h) [P_gamma(u^{n+1})]_+ P_Thgamma(.)
    v^{n+1} = v^n + tau/2 (a^n + a^{n+1})

The stable step is estimated when the stepper is built
(:mod:`~nitsche_dolfinx.stable_step`); ``dt = "auto"`` takes its scheme's safety share.
The mass is lumped, redistributed (its massless contact nodes in equilibrium at each
level) or consistent with a CG solve a step (:mod:`~nitsche_dolfinx.explicit_mass`).
Rigid obstacles and contact pairs, Nitsche's method, frictionless; the penalty method and
friction are refused in one line.
"""

from __future__ import annotations

import time
from collections import deque
from typing import Any

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from petsc4py import PETSc

from . import compat
from .coercivity import coercivity_ratio, constant_value
from .collective import sum_over_ranks
from .contact import positive_part
from .contact_quadrature import QuadratureContact
from .damping import DampingPower, damped_stable_step
from .diagnostics import Diagnostics, assembled_matrix
from .dirichlet import DirichletDofs
from .explicit_mass import ConsistentMass, DiagonalMass, MasslessNodes
from .fields import ContactFields, LevelRefresh, body_fields
from .model import ContactProblem
from .obstacle_work import ObstacleWork
from .pair_coupling import add_partner_terms
from .parameters import ParameterError, TimeStepping, require_choice
from .schemes import VerletScheme
from .solver import SolverError
from .stable_step import largest_eigenvalue, round_down, stable_step
from .stepping import (
    check_initial_gap,
    check_pairs_apart,
    checkpoint_description,
    interpolate_initial,
    massless_velocity,
)
from .timelevels import TimeLevels
from .work import BalanceSums, ExternalWork

__all__ = ["ExplicitStepper", "UnstableStep", "VerletScheme"]

#: A blow-up: kinetic + elastic energy above this many times its largest value up to
#: :data:`BLOWUP_WINDOW` steps before (an unstable explicit step grows geometrically).
BLOWUP_FACTOR = 100.0
BLOWUP_WINDOW = 100
#: How the steps get the contact's force terms: "quadrature" (the obstacles that stand
#: still from operators on Gamma_C's quadrature points, the others by assembly) or "forms"
#: (all by assembly).
CONTACT_FORCES = ("quadrature", "forms")


class UnstableStep(SolverError):
    """The explicit steps blew up: the energy grew geometrically or is no longer finite.
    Smaller steps from here would not undo it: the run stops (``cut_may_help`` False)."""

    cut_may_help = False

    def __init__(self, energy: float, reference: float, dt: float, stable_dt: float,
                 drift: bool = False):  # fmt: skip
        self.energy, self.reference = energy, reference
        self.dt, self.stable_dt, self.drift = dt, stable_dt, drift
        super().__init__(0, 0, float("nan"))
        self.reason_name = "UNSTABLE"

    def _message(self) -> str:
        where = "" if self.step is None else f"at step {self.step} (t = {self.t:.6g}): "
        grown = (
            f"the energy drifted by {self.energy:.6g} from its initial value, more than "
            f"{BLOWUP_FACTOR:g} times its initial scale {self.reference:.6g} (no load or "
            "Dirichlet value depends on t)"
            if self.drift
            else f"kinetic + elastic energy {self.energy:.6g}, against at most "
            f"{self.reference:.6g} until {BLOWUP_WINDOW} steps before"
        )
        return (
            f"{where}the verlet steps blew up: {grown}; "
            f"dt = {self.dt:.6g} for an estimated stable step of {self.stable_dt:.6g}: take a "
            "smaller dt (or safety); a growth at every step whatever dt is gamma0 beyond the "
            "stability limit of the mesh (gamma0 * E near 1): a smaller gamma0"
        )


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


class ExplicitStepper(TimeLevels, BalanceSums):
    """Steps of a :class:`~nitsche_dolfinx.model.ContactProblem` by the Verlet scheme: the
    force at u^{n+1} assembled as a vector, divided by the mass (a diagonal, or the
    consistent one by CG: :mod:`~nitsche_dolfinx.explicit_mass`).

    The force terms of the obstacles that stand still come from operators on the
    quadrature points of Gamma_C (:class:`~nitsche_dolfinx.contact_quadrature.
    QuadratureContact`, ``contact_force="quadrature"``, the default); those of moving
    obstacles and contact pairs, or all with ``contact_force="forms"``, from the assembly
    of their forms at each step. The two give the same force to round-off."""

    def __init__(self, problem: ContactProblem, scheme: VerletScheme, time_stepping: TimeStepping,
                 contact_force: str = "quadrature"):  # fmt: skip
        _check_problem(problem, scheme)
        require_choice(contact_force, CONTACT_FORCES, "contact_force", "contact force")
        self.problem, self.scheme = problem, scheme
        self.comm = problem.mesh.comm
        V = problem.V
        self.u = fem.Function(V, name="displacement")
        self.v = fem.Function(V, name="velocity")
        self.a = fem.Function(V, name="acceleration")
        self.newton_iterations, self.step_seconds = 0, 0.0
        self.solver = None  # no solve in a step
        self._dirichlet = DirichletDofs(problem)
        test = ufl.TestFunction(V)
        # the affine terms (the bulk and A_Thgamma's boundary part) as matrices assembled
        # once (blocked: faster products), and the contact force terms, on Gamma_C only,
        # and the tractions, on their boundaries only, as a vector each step
        trial = ufl.TrialFunction(V)
        affine = None  # A_Thgamma's boundary part, on Gamma_C: a matrix of its own, whose
        # product is cheap, so that the bulk's product K u gives the elastic energy
        forces = None  # the contact's force terms C(u)
        self._pairs = problem.pairs  # contact between bodies: the partner-tested terms apart
        problem.track_partners(self.u, self.v)
        partner_forms = []
        fixed_affine = None  # the affine terms of the obstacles that stand still
        assembled = None  # the force terms assembled at each step
        #: the obstacles that stand still, whose force terms come from quadrature operators
        still = [c for c in problem.contacts if not c.moving and c not in self._pairs]
        still = still if contact_force == "quadrature" else []
        for contact in problem.contacts:
            term = contact.affine_terms(trial, test)
            affine = term if affine is None else affine + term
            if not contact.moving:
                fixed_affine = term if fixed_affine is None else fixed_affine + term
            force = positive_part(contact.projection(self.u))
            term = contact.force_terms(self.u, self.v, force, test)
            if contact.moving:  # its normal may turn: A_Thgamma's boundary part each step
                term = term + contact.affine_terms(self.u, test)
            forces = term if forces is None else forces + term
            if contact not in still:
                assembled = term if assembled is None else assembled + term
            if contact in self._pairs:
                partner_forms.append(fem.form(contact.partner_term(force, test)))
        self._quadrature = QuadratureContact(problem, still, self.u) if still else None
        self._partner_forms = partner_forms
        self._stiffness = assembled_matrix(problem.bulk_stiffness(trial, test))
        self._boundary = None if fixed_affine is None else assembled_matrix(fixed_affine)
        boundary = -assembled if assembled is not None else None
        if problem.has_tractions:
            tractions = problem.traction_load(test)
            boundary = tractions if boundary is None else tractions + boundary
        self._force = None if boundary is None else fem.form(boundary)
        self._vector = compat.create_vector(V)
        self._product = compat.create_vector(V)
        self._work = self._product.duplicate()
        self._partner_work = (self._product.duplicate(), self._product.duplicate())
        fixed = self._dirichlet.dofs  # prescribed: no acceleration of their own
        self._fixed_owned = fixed[fixed < self._product.getLocalSize()]
        if problem.mass == "consistent":
            self._mass = ConsistentMass(V, problem.material_constants.rho, fixed)
        else:
            self._mass = DiagonalMass(problem.mass_diagonal(), fixed)
        # the body force lumped as the mass is (M f / rho): with the HRZ mass of P2, the
        # consistent int f . v puts no force on the vertices of triangles, and a falling
        # body would not fall rigidly
        #: the mass of density 1, of the same kind: it lumps the loads per unit volume
        self._unit_mass = self._unit_density_mass(fixed) if problem.has_loads else None
        self._unit_loads = self._lumped_unit_loads() if problem.has_loads else None
        self._load_field = None  # a body force in space: its interpolant (:meth:`_body_load`)
        problem.move_obstacles(0.0)
        affine = self._affine(affine)
        self._massless = MasslessNodes(problem, self.u, forces, affine, fixed)
        #: Rayleigh damping's force C x (docs/method.md section 14), None without it
        self._damping = None
        if problem.damping is not None:
            self._damping = DampingPower(problem.damping, self._mass.mult, self._stiffness,
                                         self.comm)  # fmt: skip
        #: The estimated stable step (:func:`~nitsche_dolfinx.stable_step.stable_step`), with
        #: stiffness damping :func:`~nitsche_dolfinx.damping.damped_stable_step`'s
        self.stable_dt = self._stable_step(affine)
        #: The cell-wise coercivity bound of A_Thgamma (:func:`coercivity_ratio`): at 1 or
        #: above, A_Thgamma may be indefinite and the steps grow whatever dt.
        self.coercivity = coercivity_ratio(problem)
        if affine is not self._stiffness:
            affine.destroy()
        self._start_levels(TimeStepping(self._resolve(time_stepping), time_stepping.t_end, 0))
        tractions = problem.has_tractions
        self._tractions = fem.form(-problem.traction_load(self.u)) if tractions else None
        self.diagnostics = Diagnostics(
            problem, self.u, self.v, potential=self._potential, elastic=self._elastic
        )
        self._contact_fields = None
        self.friction_dissipation = 0.0
        #: The energy dissipated by damping since t = 0, and by the last step
        self.damping_dissipation, self._damping_step = 0.0, 0.0
        self.pairing_energy = 0.0  # E_Theta changed by pairings (docs/method.md section 11)
        self._energy_before = None
        # the energy balance (docs/method.md section 13): the obstacles' work and the contact
        # dissipation, the work of the loads and the supports, the supports' reactions
        self._sums = None  # the sums before the step (put back with the state)
        self._u_old = fem.Function(V)
        if self._keeps_accounts(problem):
            self._obstacles = ObstacleWork(problem, scheme, self._u_old, self.u)
        if self._dirichlet or problem.has_loads:
            self._external = ExternalWork(problem, self._dirichlet, midpoint=False)
            self._traction_form = fem.form(problem.traction_load(test)) if tractions else None
            self._traction_loads = None  # their vector while they do not depend on t
        self._level_reactions = None  # -F at the Dirichlet dofs of the last force evaluation
        self._previous = [np.empty_like(f.x.array) for f in (self.u, self.v, self.a)]
        self._scratch = np.empty_like(self.u.x.array)
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
        #: C v at the current level: alpha M v^n + beta K v^{n-1/2} (C v0 at t = 0)
        self._damping_force = self._level_damping_force(0.0)
        initial = self.diagnostics.energies()
        #: the largest energy scale up to the window (see _check_growth)
        self._settled = max(self._energy_scale(), abs(initial["potential"]))
        #: the initial energy and its scale, for :meth:`_check_drift` (None: the loads or
        #: the Dirichlet values depend on t)
        self._initial_energy = (
            (initial["energy"], max(self._settled, abs(initial["energy"])))
            if problem.autonomous and self._settled > 0
            else None
        )
        self._recent: deque[float] = deque()  # kinetic + elastic of the last levels

    def _resolve(self, time_stepping: TimeStepping) -> float:
        """The time step: ``"auto"`` is the scheme's safety share of the stable step; a
        given one above the stable step is refused unless the scheme allows it."""
        scheme, stable, dt = self.scheme, self.stable_dt, time_stepping.dt
        if time_stepping.automatic:
            return round_down(scheme.safety * stable)
        if dt > stable and not scheme.force_dt:
            raise ParameterError(
                "dt", dt,
                f"above the verlet scheme's stable step {stable:.6g} (estimated for this "
                f"mesh, mass, gamma0 and Theta); take dt='auto' ({scheme.safety:g} of it) or "
                "insist on it (force_dt=True)",
            )  # fmt: skip
        return float(dt)

    def _assemble_force(self) -> tuple[PETSc.Vec, PETSc.Vec]:
        """The force F = L - B(u) at the current u (and loads' time), its ghosts up to
        date, and the elastic force K u."""
        vector = self._vector
        with vector.localForm() as local:
            local.set(0.0)
        for pair in self._pairs:
            pair.update([self.u])
        if self._force is not None:
            fem_petsc.assemble_vector(vector, self._force)
        if self._quadrature is not None:
            with vector.localForm() as local:
                self._quadrature.subtract(local.array)
        if self._force is not None or self._quadrature is not None:
            vector.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        add_partner_terms(self._pairs, self._partner_forms, vector, self._partner_work,
                          self._fixed_owned, scale=-1.0)  # fmt: skip
        u = compat.petsc_vector(self.u)
        self._stiffness.mult(u, self._product)
        vector.axpy(-1.0, self._product)
        if self._boundary is not None:
            self._boundary.mult(u, self._work)
            vector.axpy(-1.0, self._work)
        if self._unit_loads is not None:
            vector.array += self._body_load()
        vector.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        return vector, self._product

    def _affine(self, boundary) -> PETSc.Mat:
        """The matrix of all the affine terms, the bulk's and the ``boundary`` form's (a
        moving obstacle's at t = 0), for the set-up: the steps take their products apart."""
        if boundary is None:
            return self._stiffness
        matrix = assembled_matrix(boundary)
        total = self._stiffness.duplicate(copy=True)
        total.axpy(1.0, matrix, structure=PETSc.Mat.Structure.SUBSET)  # cells' pattern
        matrix.destroy()
        return total

    def _elastic(self) -> float:
        """1/2 u . K u from the bulk's product of the last force evaluation (at this u)."""
        n = self._product.getLocalSize()
        local = self.u.x.array[:n] @ self._product.array_r
        return float(sum_over_ranks(self.comm, [local])[0]) / 2

    def _unit_density_mass(self, fixed):
        """The mass of density 1 of the problem's kind (diagonal, or consistent)."""
        if self.problem.mass == "consistent":
            return ConsistentMass(self.problem.V, 1.0, fixed)
        return DiagonalMass(self.problem.mass_matrix.of_unit_density().diagonal(), fixed)

    def _body_load(self) -> np.ndarray:
        """M f / rho at the current time (owned rows): the body force lumped as the mass is;
        f constant in space by :meth:`_lumped_unit_loads`, else its interpolant's."""
        f = self.problem.body_force_in_space
        if f is None:
            return self.problem.body_force() @ self._unit_loads
        if self._load_field is None or self.problem.loads_in_time:
            if self._load_field is None:
                self._load_field = fem.Function(self.problem.V)
                self._load_expression = compat.expression(f, self.problem.V)
            self._load_field.interpolate(self._load_expression)
            field = compat.petsc_vector(self._load_field)
            self._unit_mass.mult(field, self._work)
            self._load = self._work.array_r.copy()
        return self._load

    def _lumped_unit_loads(self) -> np.ndarray:
        """M e_k / rho for each component k (owned rows; with several materials, the mass of
        density 1 times e_k): the body force f, constant in space, is f @ these."""
        unit, bs = self._product.duplicate(), self.problem.V.dofmap.index_map_bs
        loads = np.zeros((bs, unit.getLocalSize()))
        for k in range(bs):
            unit.array[:] = 0.0
            unit.array[k::bs] = 1.0
            self._unit_mass.mult(unit, self._work)
            loads[k] = self._work.array_r
        unit.destroy()
        return loads

    def _stable_step(self, affine: PETSc.Mat) -> float:
        """The estimated stable step; with stiffness damping beta > 0, shrunk by
        :func:`~nitsche_dolfinx.damping.damped_stable_step` with the bulk's own largest
        eigenvalue (docs/method.md section 14)."""
        stable = stable_step(self.problem, affine, self._mass)
        beta = 0.0 if self._damping is None else self.problem.damping.values[1]
        if beta == 0.0:
            return stable
        bulk = largest_eigenvalue(self.problem, self._stiffness, self._mass, with_contact=False)
        return damped_stable_step(4.0 / stable**2, bulk, beta)

    def _accelerate(self, equilibrium: bool = True, velocity=None, dt: float = 0.0) -> None:
        """a = M^-1 (L - B(u)) at the current u (and loads' time); with massless nodes and
        ``equilibrium``, their displacement first, from their equilibrium (not at t = 0:
        the initial displacement is the user's, as for the implicit schemes).

        With damping, the force C ``velocity`` is taken off, and a divided by
        1 + alpha ``dt`` / 2 (docs/method.md section 14: at a step, ``velocity`` is
        v^{n+1/2} and alpha M v^{n+1} = alpha M (v^{n+1/2} + dt/2 a^{n+1}); at t = 0, v0 and
        ``dt`` = 0)."""
        if self._massless.active and equilibrium:
            force = self._massless.solve(self._assemble_force)
        else:
            force, _ = self._assemble_force()
        if self._damping is not None:
            force.axpy(-1.0, self._damping.force(velocity, self._work))
            force.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        if self._external is not None:  # the supports hold their dofs: R = -F there
            self._level_reactions = -force.array_r[self._external.dofs]
        self._mass.divide(force, self.a)
        if self._damping is not None and dt > 0.0:
            self.a.x.array[:] /= 1.0 + self.problem.damping.values[0] * dt / 2

    def _level_damping_force(self, dt: float) -> PETSc.Vec | None:
        """C v at the current level as the steps take it, alpha M v^n + beta K v^{n-1/2}
        with v^{n-1/2} = v^n - ``dt``/2 a^n, ``dt`` the last step's size (0 at t = 0: C v0);
        from the level's own arrays, so that a restart computes it to the bit (None without
        damping)."""
        if self._damping is None:
            return None
        half_step = self.v.x.array - dt / 2 * self.a.x.array
        return self._damping.force(half_step, self._product.duplicate(), self.v.x.array)

    def step(self, t_new: float | None = None, cuts: int = 0) -> int:
        """One Verlet step to ``t_new`` (default: the next level); returns 0 (no Newton)."""
        start = time.perf_counter()
        t_new, dt = self._step_to(t_new)
        u, v, a = self.u.x.array, self.v.x.array, self.a.x.array
        for previous, array in zip(self._previous, (u, v, a)):
            previous[:] = array
        level = self.diagnostics.of_level(self.step_index)
        self._energy_before = level["energy_theta"]
        self._check_drift(level["energy"], dt)
        scratch = self._scratch  # in place: no temporaries of the size of u
        half_step = None if self._damping is None else v + dt / 2 * a  # v^{n+1/2}
        u += np.multiply(dt, v, out=scratch)
        u += np.multiply(dt**2 / 2, a, out=scratch)
        self._dirichlet.set_values(u, t_new)
        self.problem.set_time(t_new)
        self.problem.move_obstacles(self.t, t_new)
        self._sums = self._sums_now()
        try:
            self._accelerate(velocity=half_step, dt=dt)
        except SolverError as error:
            self._put_back()
            error.add_context(step=self.step_index + 1, t=t_new)
            raise
        self._u_old.x.array[:] = self._previous[0]
        if self._obstacles is not None:
            self._obstacles.step()
        if self._external is not None:
            self._external.step(u - self._previous[0], self._level_reactions,
                                self._load_vector())  # fmt: skip
        v += np.multiply(dt / 2, np.add(self._previous[2], a, out=scratch), out=scratch)
        if self._dirichlet:  # the prescribed dofs' velocity: the step's mean
            dofs = self._dirichlet.prescribed
            v[dofs] = (u[dofs] - self._previous[0][dofs]) / dt
        massless_velocity(self._massless.local, self._previous[0], u, v, a, dt)
        self._check_growth(self._energy_scale(), dt, t_new)
        if self._damping is not None:
            self._damp(dt)
        self._arrive(t_new, dt, cuts)
        self.problem.move_obstacles(self.t)
        self.pairing_energy += self.diagnostics.follow_pairs(self.step_index)
        self.step_seconds = time.perf_counter() - start
        return 0

    def _damp(self, dt: float) -> None:
        """The step's damping dissipation, tau/4 (F^n + F^{n+1}) . (v^n + v^{n+1}) with
        F the levels' damping forces (docs/method.md section 14): the damping's share of the
        kinetic energy's change in the velocity update; added to the running total."""
        force = self._level_damping_force(dt)
        n = force.getLocalSize()
        total = self._damping_force.array_r + force.array_r
        local = dt / 4 * float(total @ (self._previous[1][:n] + self.v.x.array[:n]))
        self._damping_step = float(sum_over_ranks(self.comm, [local])[0])
        self.damping_dissipation += self._damping_step
        self._damping_force.destroy()
        self._damping_force = force

    def _check_drift(self, energy: float, dt: float) -> None:
        """Raise :class:`UnstableStep` at a level whose energy drifted from its initial value
        by more than :data:`BLOWUP_FACTOR` times its initial scale, when nothing feeds the
        body energy (:attr:`ContactProblem.autonomous`): a slow geometric growth, which
        :meth:`_check_growth`'s window lets through, stops there."""
        if self._initial_energy is None:
            return
        initial, scale = self._initial_energy
        drift = abs(energy - initial)
        if not drift <= BLOWUP_FACTOR * scale:  # (NaN too)
            error = UnstableStep(drift, scale, dt, self.stable_dt, drift=True)
            error.add_context(step=self.step_index, t=self.t)
            raise error

    def _potential(self) -> float:
        """-L(t)(u), the body force lumped as the steps take it (M f / rho . u, M f / rho
        of :meth:`_body_load`), and the tractions."""
        body = 0.0
        if self._unit_loads is not None:
            n = self._product.getLocalSize()
            local = -(self._body_load() @ self.u.x.array[:n])
            body = sum_over_ranks(self.comm, [local])[0]
        if self._tractions is None:
            return float(body)
        return float(body + sum_over_ranks(self.comm, [fem.assemble_scalar(self._tractions)])[0])

    def _energy_scale(self) -> float:
        """1/2 v.M v + |1/2 u.K u| (K: the affine terms), from the last force evaluation: a
        measure of the energy for the blow-up check, without assembly."""
        n = self._product.getLocalSize()
        velocity = compat.petsc_vector(self.v)
        self._mass.mult(velocity, self._work)
        u, v = self.u.x.array[:n], self.v.x.array[:n]
        kinetic, elastic = sum_over_ranks(self.comm, [v @ self._work.array_r,
                                                      u @ self._product.array_r]) / 2  # fmt: skip
        return float(kinetic + abs(elastic))

    def _check_growth(self, energy: float, dt: float, t_new: float) -> None:
        """Raise :class:`UnstableStep` (the state put back to t^n) on a blow-up: the energy
        scale (:meth:`_energy_scale`) not finite, or above :data:`BLOWUP_FACTOR` times its
        largest value up to :data:`BLOWUP_WINDOW` steps before, the loads' potential at
        t = 0 (a body at rest may start moving), or the work moving obstacles did."""
        recent = self._recent
        reference = self._settled  # up to the window before: a blow-up cannot raise it
        if self._obstacles is not None:  # what moving obstacles put in (before the step)
            reference = max(reference, abs(self._sums[0]["obstacle_work"]))
        if np.isfinite(energy) and (reference == 0.0 or energy <= BLOWUP_FACTOR * reference):
            recent.append(energy)
            if len(recent) > BLOWUP_WINDOW:
                self._settled = max(self._settled, recent.popleft())
            return
        self._put_back()
        error = UnstableStep(energy, reference, dt, self.stable_dt)
        error.add_context(step=self.step_index + 1, t=t_new)
        raise error

    def _put_back(self) -> None:
        """The state of the last level, after a failed step."""
        for previous, array in zip(self._previous, (self.u, self.v, self.a)):
            array.x.array[:] = previous
        self.diagnostics.remember(self.step_index, None)
        self._stiffness.mult(compat.petsc_vector(self.u), self._product)  # K u of the level
        self.problem.move_obstacles(self.t)
        if self._sums is not None:
            self._restore_sums(self._sums)

    def state(self, columns=None) -> dict[str, float]:
        """Diagnostics at the current time level, identical on every rank, as
        :meth:`~nitsche_dolfinx.stepper.NitscheStepper.state` gives them, with zero friction
        dissipation and Newton iterations."""
        values = {"t": self.t, **self.diagnostics.of_level(self.step_index, columns)}
        values.update(self._balance_columns())
        values["friction_dissipation"] = 0.0
        values["energy_balance_residual"] = (
            0.0
            if self._energy_before is None
            else values["energy_theta"] - self._energy_before + self._damping_step
        )
        if self._damping is not None:
            values["damping_dissipation"] = self.damping_dissipation
        values["newton_iterations"] = 0
        values["pairing_energy"] = self.pairing_energy
        values["step_seconds"] = self.step_seconds
        values["dt"] = self.last_dt
        values["step_cuts"] = self.step_cuts
        return values

    def contact_pressure(self):
        """The contact pressure lambda_h = -(1/gamma_h) [P_gamma(u)]_+ of the first contact
        term (an obstacle or a pair's half), as a UFL expression on its Gamma_C
        (docs/method.md section 2)."""
        return self.problem.contacts[0].pressure(self.u)

    def output_fields(self) -> dict:
        """Displacement, velocity, von Mises stress and the contact fields on Gamma_C
        (:class:`~nitsche_dolfinx.fields.ContactFields`)."""
        fields = body_fields(self.problem, self.u, self.v)
        if self.problem.contacts:
            if self._contact_fields is None:
                self._contact_fields = ContactFields(self.problem, self.u)
            refresh = LevelRefresh(self._contact_fields.update, lambda: (self.step_index, self.t))
            fields.update(
                {n: (refresh.wrap(f), s) for n, (f, s) in self._contact_fields.fields().items()}
            )
        return fields

    def checkpoint_functions(self) -> dict[str, fem.Function]:
        """Everything the next step depends on, by name: u, v and a; the supports'
        reactions; the displacements the contact pairs were paired in."""
        functions = {"displacement": self.u, "velocity": self.v, "acceleration": self.a}
        return {**functions, **self._balance_functions(), **self.problem.pairing_state()}

    def _sums_now(self) -> tuple:
        """The running sums (:meth:`BalanceSums._running_sums`), None without any."""
        return None if self._obstacles is None and self._external is None else self._running_sums()

    def _load_vector(self) -> np.ndarray | None:
        """The loads' vector at the current time (owned dofs), as the steps take them: the
        body force lumped as the mass is, and the tractions; None without loads."""
        if not self.problem.has_loads:
            return None
        loads = np.zeros(self._product.getLocalSize())
        if self._unit_loads is not None:
            loads += self._body_load()
        if self._traction_form is not None:
            if self._traction_loads is None or self.problem.loads_in_time:
                vector = compat.create_vector(self.problem.V)
                with vector.localForm() as local:
                    local.set(0.0)
                fem_petsc.assemble_vector(vector, self._traction_form)
                vector.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
                self._traction_loads = vector.array_r.copy()
                vector.destroy()
            loads += self._traction_loads
        return loads

    def describe(self) -> dict[str, Any]:
        """What a checkpoint shares with the stepper that reloads it
        (:func:`~nitsche_dolfinx.stepping.checkpoint_description`)."""
        return checkpoint_description(self)

    def levels(self) -> dict[str, Any]:
        """The clock, the sums of the obstacles' work and, with damping, its running total
        and the last step's size (the level's damping force lags by half of it), for a
        checkpoint."""
        levels = {**super().levels(), **self._saved_sums()}
        if self.problem.pairs:
            levels["pairing_energy"] = self.pairing_energy
        if self._damping is not None:
            levels["damping_dissipation"] = self.damping_dissipation
            levels["damping_last_dt"] = self.last_dt
        return levels

    def restore(self, t: float, step_index: int, saved: dict[str, Any]) -> None:
        """Move to a time level whose functions were just loaded (``saved``: the
        checkpoint's description and :meth:`levels`): the clock, the pairings, the
        level's damping force, the sums of the balance, K u, the data and the obstacles
        at ``t``; the level's diagnostics are computed anew."""
        self._restore_levels(t, step_index, saved)
        self.problem.restore_pairs()
        self.pairing_energy = float(saved.get("pairing_energy", 0.0))
        if self._damping is not None:  # the level's force F^n: v^{n-1/2} = v^n - tau/2 a^n
            self.damping_dissipation = float(saved.get("damping_dissipation", 0.0))
            self._damping_step = 0.0
            self._damping_force.destroy()
            self._damping_force = self._level_damping_force(saved.get("damping_last_dt", 0.0))
        self.step_seconds = 0.0
        self.problem.set_time(t)
        self.problem.move_obstacles(t)
        self.diagnostics.remember(self.step_index, None)
        if self._external is not None:  # the level's reactions: the checkpoint's Function
            self._level_reactions = self._external.reaction.x.array[self._external.dofs].copy()
        self._load_sums(saved, self._load_vector() if self._external is not None else None)
        self._stiffness.mult(compat.petsc_vector(self.u), self._product)  # K u of the level
        self._settled, self._recent = max(self._settled, self._energy_scale()), deque()
