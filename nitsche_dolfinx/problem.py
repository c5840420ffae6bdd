"""The problem object (a model to which terms are added) and the time loop.

A :class:`ContactProblem` holds the mesh, the material and the terms of the
weak form: Dirichlet conditions, loads, and one Nitsche contact per rigid
obstacle. A :class:`Simulation` marches it in time with a scheme of
:mod:`nitsche_dolfinx.schemes`, one SNES solve per step, and reports the
diagnostics of :mod:`nitsche_dolfinx.diagnostics`.

Example (the 1D bar of the talk)::

    mesh, tags = bar_mesh(100)
    problem = ContactProblem(mesh, tags, Material(E=1.0, nu=0.0, rho=1.0),
                             gamma0=1e-6, nitsche_theta=1.0)
    problem.add_dirichlet(BAR_CLAMPED, 0.0)
    problem.add_obstacle(PlaneObstacle([0.0], [1.0]), BAR_CONTACT)
    problem.set_initial_conditions(displacement=lambda x: 0.5 - x[0] / 2)
    sim = Simulation(problem, HybridScheme(), dt=0.015, t_end=6.0)
    sim.run(out="out/bar")
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc

from . import compat
from .checkpoint import (
    CheckpointError,
    RunInterrupted,
    SavedState,
    StopSignals,
    agree,
    all_ranks_reach,
    match_points,
    read_checkpoint,
    write_checkpoint,
)
from .contact import NitscheContact, PenaltyContact, positive_part
from .diagnostics import BoundaryField, Diagnostics, assemble_global
from .mass import lumped_mass, redistributed_mass
from .material import Material, sigma, von_mises
from .meshes import cell_diameter
from .output import HistoryWriter, SolutionWriter, continue_solution, ensure_directory
from .schemes import HybridScheme, TimeScheme
from .solver import SNESSolver, SolverError

__all__ = [
    "BALANCE_COLUMNS",
    "CONTACT_METHODS",
    "FRICTION_HISTORY_COLUMNS",
    "ContactProblem",
    "HISTORY_COLUMNS",
    "MASS_MATRICES",
    "STATE_COLUMNS",
    "Simulation",
]

#: Contact methods of :class:`ContactProblem` (the mixed method is :mod:`nitsche_dolfinx.mixed`).
CONTACT_METHODS = ("nitsche", "penalty")
#: Mass matrices of :class:`ContactProblem`.
MASS_MATRICES = ("consistent", "lumped", "redistributed")

#: The physical quantities of ``history.csv``: energies and contact (reduced over MPI).
STATE_COLUMNS = (
    "energy",
    "energy_theta",
    "kinetic",
    "elastic",
    "potential",
    "contact_force",
    "contact_area",
    "penetration_max",
)
#: Columns of ``history.csv`` for the 2D/3D demos (SPEC section 6).
HISTORY_COLUMNS = ("t", *STATE_COLUMNS, "newton_iterations", "step_seconds")
#: The energy balance of a step, reported by :meth:`Simulation.state` at every level:
#: D^n, the work of the friction term on the step's increment, and
#: E_Theta^{n+1} - E_Theta^n + D^n (both 0 at t = 0).
BALANCE_COLUMNS = ("friction_dissipation", "energy_balance_residual")
#: Columns of ``history.csv`` for the friction demos.
FRICTION_HISTORY_COLUMNS = (*HISTORY_COLUMNS[:-2], *BALANCE_COLUMNS, *HISTORY_COLUMNS[-2:])


def check_time_parameters(dt: float, t_end: float) -> None:
    """Raise a ValueError naming dt or t_end unless 0 < dt <= t_end, both finite."""
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"the time step must be positive, got dt={dt!r}")
    if not (np.isfinite(t_end) and t_end >= dt):
        raise ValueError(
            f"the final time must be at least one time step, got t_end={t_end!r} < dt={dt!r}"
        )


def _massless_velocity(massless, u, u1, v1, a1, dt) -> None:
    """At massless dofs (redistributed mass) the scheme's velocity update means nothing:
    the node follows its constraint. Report the step's mean velocity there instead."""
    if massless.size:
        v1[massless] = (u1[massless] - u[massless]) / dt
        a1[massless] = 0.0


class _TimeDependentValue:
    """A constant or a function of t, held in a ``fem.Constant`` that follows the time."""

    def __init__(self, mesh, value, shape: tuple[int, ...], what: str):
        self._function = value if callable(value) else None
        initial = value(0.0) if callable(value) else value
        self.constant = fem.Constant(mesh, _as_array(initial, shape, what))
        self.shape = shape
        self.what = what

    @property
    def time_dependent(self) -> bool:
        """Whether the value is a function of t."""
        return self._function is not None

    def value_at(self, t: float) -> np.ndarray:
        if self._function is None:
            return np.asarray(self.constant.value)
        return _as_array(self._function(t), self.shape, self.what)

    def set_time(self, t: float) -> None:
        if self._function is not None:
            self.constant.value = self.value_at(t)


def _as_array(value, shape, what) -> np.ndarray:
    array = np.asarray(value, dtype=float)
    if array.shape != shape:
        if array.size == 1 and shape == (1,):
            return array.reshape(shape)
        raise ValueError(f"{what} must have shape {shape}, got {array.tolist()!r}")
    return array


class _ContactTerms:
    """A contact quantity of a problem behind the model interface of the time schemes
    (no inertia, bulk or load), so that ``scheme.residual(terms, w, u, v, a, dt, test)``
    evaluates it with the step's own normal force, slip velocity and threshold (hybrid:
    Phi, v^{n+1/2} and mu_f Phi; theta and Newmark: [P_gamma(u^{n+1})]_+, v^{n+1} and
    mu_f [P_gamma(u^{n+1})]_+).

    ``term(contact, u, velocity, normal_force, test)`` is the form of one contact.
    """

    def __init__(self, contacts, term):
        self.contacts = list(contacts)
        self.term = term

    def inertia(self, acceleration, v):
        return 0

    def load(self, v):
        return 0

    def operator(self, u, v, velocity=None):
        forms = (
            self.term(c, u, velocity, positive_part(c.projection(u)), v) for c in self.contacts
        )
        return sum(forms, 0)

    def hybrid_operator(self, u_old, u_new, v, velocity=None):
        form = 0
        for contact in self.contacts:
            u_mid, force = contact.hybrid_state(u_old, u_new)
            form = form + self.term(contact, u_mid, velocity, force, v)
        return form


class _GuardedFriction:
    """A :class:`ContactProblem` whose friction law is guarded by a reference state
    (:func:`~nitsche_dolfinx.contact.guarded_projection`), behind the model interface of
    the time schemes. ``reference`` maps an expression of the unknown to its value at
    the reference state."""

    def __init__(self, problem, reference):
        self.problem = problem
        self.reference = reference

    def inertia(self, acceleration, v):
        return self.problem.inertia(acceleration, v)

    def load(self, v):
        return self.problem.load(v)

    def operator(self, u, v, velocity=None):
        return self.problem.operator(u, v, velocity, self.reference)

    def hybrid_operator(self, u_old, u_new, v, velocity=None):
        return self.problem.hybrid_operator(u_old, u_new, v, velocity, self.reference)


#: Friction quantities of :meth:`ContactProblem.friction_terms`.
_FRICTION_QUANTITIES = {
    # the friction term of the equation: tested with the step's increment, its work
    "work": lambda c, u, velocity, force, v: c.friction_term(u, velocity, force, v),
    # int lambda_t . v and int u'_t . v, for output on Gamma_C
    "traction": lambda c, u, velocity, force, v: (
        ufl.inner(c.friction_traction(u, velocity, force), v) * c.ds
    ),
    "slip_velocity": lambda c, u, velocity, force, v: ufl.inner(c.tangential(velocity), v) * c.ds,
}


class ContactProblem:
    """Linear elastodynamics with Nitsche contact against rigid obstacles.

    Args:
        mesh: The dolfinx mesh (1D, 2D or 3D).
        facet_tags: Facet tags naming the boundary parts used by the terms.
        material: The elastic material and its density.
        degree: Degree of the Lagrange displacement space (1 or 2).
        gamma0: Nitsche parameter: gamma_h = gamma0 h_T (small gamma0 = stiff contact).
        nitsche_theta: Nitsche variant Theta: 1 symmetric, 0 non-symmetric, -1 skew-symmetric.
        friction: Coulomb coefficient mu_f >= 0, or None (the default) for frictionless
            contact. With a coefficient, the frictional Nitsche term of SPEC section 2 is
            added (:meth:`~nitsche_dolfinx.contact.NitscheContact.friction_term`) with the
            tangential velocity of the time scheme; mu_f is the ``fem.Constant``
            attribute ``friction`` and mu_f = 0 is the frictionless problem.
        method: Contact method: ``"nitsche"`` (the default) or ``"penalty"``
            (:class:`~nitsche_dolfinx.contact.PenaltyContact`, eps = gamma0 h_T).
        mass: ``"consistent"`` (the default), ``"lumped"`` (P1: vertex quadrature) or
            ``"redistributed"``: the modified mass of Khenous, Laborde & Renard, lumped,
            with the mass of the contact nodes moved to their neighbours (P1). The
            contact tags are those of the obstacles added before the first simulation.
        quadrature_degree: Quadrature degree of every integral, in the equations and in
            the energies alike (so that the discrete energy identities hold to round-off,
            also on curved cells). Default: 2 * degree on affine meshes, 2 * degree + 2 on
            second-order geometries.

    ``gamma0`` and ``nitsche_theta`` are ``fem.Constant`` attributes: change
    their ``.value`` between runs without recompiling any form.
    """

    def __init__(
        self,
        mesh,
        facet_tags,
        material: Material,
        degree: int = 1,
        gamma0: float = 1.0,
        nitsche_theta: float = 1.0,
        friction: float | None = None,
        quadrature_degree: int | None = None,
        method: str = "nitsche",
        mass: str = "consistent",
    ):
        if not (np.isfinite(gamma0) and gamma0 > 0):
            raise ValueError(
                f"the Nitsche parameter gamma0 must be positive, got gamma0={gamma0!r}"
            )
        if not np.isfinite(nitsche_theta):
            raise ValueError(
                f"the Nitsche variant must be finite, got nitsche_theta={nitsche_theta!r}"
            )
        if friction is not None and not (np.isfinite(friction) and friction >= 0):
            raise ValueError(
                f"the friction coefficient must be >= 0 (or None: frictionless), "
                f"got friction={friction!r}"
            )
        if int(degree) not in (1, 2):
            raise ValueError(f"degree must be 1 or 2, got degree={degree!r}")
        if method not in CONTACT_METHODS:
            raise ValueError(
                f"unknown contact method {method!r}; choose one of {', '.join(CONTACT_METHODS)}"
            )
        if mass not in MASS_MATRICES:
            raise ValueError(f"unknown mass {mass!r}; choose one of {', '.join(MASS_MATRICES)}")
        if mass != "consistent" and int(degree) != 1:
            raise ValueError(f"mass={mass!r} needs P1 elements, got degree={degree!r}")
        self.mesh = mesh
        self.facet_tags = facet_tags
        self.material = material
        self.degree = int(degree)
        self.method = method
        self.mass = mass
        self._mass_diagonal = None
        self.gdim = mesh.geometry.dim
        self.V = compat.function_space(mesh, "Lagrange", self.degree, (self.gdim,))
        self.gamma0 = fem.Constant(mesh, float(gamma0))
        self.nitsche_theta = fem.Constant(mesh, float(nitsche_theta))
        self.friction = None if friction is None else fem.Constant(mesh, float(friction))
        self.h = cell_diameter(mesh)
        self.gamma_h = self.gamma0 * self.h
        if quadrature_degree is None:
            quadrature_degree = 2 * self.degree + 2 * (compat.geometry_degree(mesh) - 1)
        self.quadrature_degree = int(quadrature_degree)
        metadata = {"quadrature_degree": self.quadrature_degree}
        self.dx = ufl.Measure("dx", domain=mesh, metadata=metadata)
        self.ds = ufl.Measure("ds", domain=mesh, subdomain_data=facet_tags, metadata=metadata)
        self.contacts: list[NitscheContact] = []
        self.contact_tags: list[int] = []
        self.dirichlet: list[tuple[int, _TimeDependentValue]] = []
        self._body_forces: list[_TimeDependentValue] = []
        self._tractions: list[tuple[int, _TimeDependentValue]] = []
        self.initial_displacement = None
        self.initial_velocity = None

    # -- building the model ------------------------------------------------------------

    def facets(self, tag: int) -> np.ndarray:
        """Local indices of the facets tagged ``tag``; raises if no rank has any."""
        tags = self.facet_tags
        found = tags.indices[tags.values == tag].astype(np.int32) if tags is not None else []
        if self.mesh.comm.allreduce(len(found), op=MPI.SUM) == 0:
            present = sorted(
                set(
                    self.mesh.comm.allreduce(
                        [] if tags is None else np.unique(tags.values).tolist(), op=MPI.SUM
                    )
                )
            )
            raise ValueError(f"facet tag {tag!r} is not in the mesh (its facet tags are {present})")
        return np.asarray(found, dtype=np.int32)

    def add_dirichlet(self, tag: int, value=0.0) -> None:
        """Prescribe the displacement on the facets ``tag``: a vector (or scalar in 1D),
        or a function of t returning one."""
        self.facets(tag)
        self.dirichlet.append(
            (tag, _TimeDependentValue(self.mesh, value, (self.gdim,), "Dirichlet value"))
        )

    def add_body_force(self, value) -> None:
        """Add a volume force f: a vector, or a function of t returning one."""
        self._body_forces.append(_TimeDependentValue(self.mesh, value, (self.gdim,), "body force"))

    def add_traction(self, tag: int, value) -> None:
        """Add a Neumann traction g_N on the facets ``tag``: a vector, or a function of t."""
        self.facets(tag)
        self._tractions.append(
            (tag, _TimeDependentValue(self.mesh, value, (self.gdim,), "traction"))
        )

    def add_obstacle(self, obstacle, tag: int) -> NitscheContact:
        """Add unilateral contact of the facets ``tag`` (Gamma_C) with a rigid obstacle."""
        self.facets(tag)
        law = PenaltyContact if self.method == "penalty" else NitscheContact
        contact = law(
            obstacle, self.ds(tag), self.stress, self.gamma_h, self.nitsche_theta, self.friction
        )
        self.contacts.append(contact)
        self.contact_tags.append(tag)
        return contact

    def set_initial_conditions(self, displacement=None, velocity=None) -> None:
        """Initial displacement u0 and velocity v0 (zero when omitted).

        Each is a constant vector, a function of the coordinates ``x`` (shape (3, N))
        returning the values (shape (gdim, N), or (N,) in 1D), or a Function on the
        displacement space.
        """
        self.initial_displacement = displacement
        self.initial_velocity = velocity

    # -- the terms of the weak form, used by the time schemes --------------------------

    def stress(self, u):
        """sigma(u)."""
        return sigma(u, self.material)

    def bulk_stiffness(self, u, v):
        """a(u, v) = int sigma(u) : eps(v)."""
        return ufl.inner(self.stress(u), ufl.sym(ufl.grad(v))) * self.dx

    def inertia(self, acceleration, v):
        """<rho u'', v> with the consistent mass; zero for a diagonal mass
        (:meth:`mass_diagonal`), which the solver adds as a matrix."""
        rho = self.material.rho if self.mass == "consistent" else 0.0
        return rho * ufl.inner(acceleration, v) * self.dx

    def mass_diagonal(self, V=None):
        """The lumped or redistributed mass matrix as a PETSc vector (its diagonal), or None
        for the consistent mass; on ``V`` (another numbering of the displacement space)
        when given."""
        if self.mass == "consistent":
            return None
        if V is not None:
            return self._diagonal_mass(V)
        if self._mass_diagonal is None:
            self._mass_diagonal = self._diagonal_mass(self.V)
        return self._mass_diagonal

    def massless_dofs(self) -> np.ndarray:
        """Local indices (with ghosts) of the dofs whose mass is zero (redistributed mass)."""
        diagonal = self.mass_diagonal()
        if diagonal is None:
            return np.zeros(0, dtype=np.int32)
        with diagonal.localForm() as local:
            return np.flatnonzero(local.array == 0.0).astype(np.int32)

    def _diagonal_mass(self, V):
        if self.mass == "lumped":
            return lumped_mass(V, self.material.rho)
        if not self.contact_tags:
            raise ValueError("mass='redistributed' needs an obstacle: add one first")
        facets = np.concatenate([self.facets(tag) for tag in self.contact_tags])
        return redistributed_mass(V, self.material.rho, facets)

    @property
    def frictional(self) -> bool:
        """Whether the contact terms carry Coulomb friction (a coefficient was given)."""
        return self.friction is not None

    @property
    def frictional_contacts(self) -> list[NitscheContact]:
        """The contacts with a Coulomb coefficient (all of them, or none)."""
        return [contact for contact in self.contacts if contact.frictional]

    @property
    def symmetric_jacobian(self) -> bool:
        """Whether the Jacobian of every time scheme is symmetric: without friction, with
        the symmetric variant Theta = 1 or with penalty (whose test term is v_n).
        :class:`Simulation` reads it once, when it is built."""
        if self.frictional:
            return False
        return self.method == "penalty" or float(np.asarray(self.nitsche_theta.value)) == 1.0

    def operator(self, u, v, velocity=None, reference=None):
        """B(u)(v) = A_Thgamma(u, v) + the Nitsche contact terms at one time level
        (with friction, ``velocity`` is u' at that level; ``reference``: the guarded
        friction law, see :meth:`guarded_friction`)."""
        form = self.bulk_stiffness(u, v)
        for contact in self.contacts:
            form = form + contact.residual(u, v, velocity, reference)
        return form

    def hybrid_operator(self, u_old, u_new, v, velocity=None, reference=None):
        """The hybrid scheme's operator: A_Thgamma at the midpoint and the switching term
        Phi; with friction, the step's mean velocity ``velocity`` = (u_new - u_old) / tau."""
        form = self.bulk_stiffness((u_old + u_new) / 2, v)
        for contact in self.contacts:
            form = form + contact.hybrid_residual(u_old, u_new, v, velocity, reference)
        return form

    def guarded_friction(self, reference):
        """The problem with its friction law guarded by a reference state, behind the
        model interface of the time schemes (see :class:`Simulation`); ``reference`` maps
        an expression of the unknown to its value at that state."""
        return _GuardedFriction(self, reference)

    def friction_terms(self, quantity: str = "work"):
        """A friction quantity as a model with the interface of the time schemes, so that
        the scheme supplies its slip velocity and threshold:

        - ``"work"``: the friction term of the equation; with a Function ``du`` as the
          test, ``scheme.residual(problem.friction_terms(), w, u, v, a, dt, du)`` is the
          work of the step's friction force on the increment ``du``;
        - ``"traction"``: ``int lambda_t . mu`` (lambda_t the friction traction);
        - ``"slip_velocity"``: ``int u'_t . mu``.
        """
        if quantity not in _FRICTION_QUANTITIES:
            raise ValueError(
                f"unknown friction quantity {quantity!r}; "
                f"choose one of {', '.join(_FRICTION_QUANTITIES)}"
            )
        return _ContactTerms(self.frictional_contacts, _FRICTION_QUANTITIES[quantity])

    def contact_activity(self):
        """The normal force tested by a cell-wise function, ``int_Gamma_C force q``, as a
        model with the interface of the time schemes (the scheme supplies its force:
        [P_gamma(u^{n+1})]_+ or Phi). It is zero on the cells where every contact term
        is inactive: there the terms are affine and their Jacobian does not change."""
        return _ContactTerms(self.contacts, lambda c, u, velocity, force, q: force * q * c.ds)

    def load(self, v):
        """L(t)(v) = int f . v + int g_N . v, with the loads at the current time."""
        zero = fem.Constant(self.mesh, np.zeros(self.gdim))
        form = ufl.inner(zero, v) * self.dx
        for force in self._body_forces:
            form = form + ufl.inner(force.constant, v) * self.dx
        for tag, traction in self._tractions:
            form = form + ufl.inner(traction.constant, v) * self.ds(tag)
        return form

    def set_time(self, t: float) -> None:
        """Move the time-dependent loads to time ``t``."""
        for force in self._body_forces:
            force.set_time(t)
        for _, traction in self._tractions:
            traction.set_time(t)


class _FrictionOutput:
    """The friction quantities of a :class:`Simulation`: the work D^n of each step, and
    the fields ``slip_velocity`` and ``friction_traction`` on Gamma_C.

    D^n is the friction term of the step's equation tested with the step's increment
    u^{n+1} - u^n (the scheme's slip velocity and threshold), so that
    E_Theta^{n+1} - E_Theta^n + D^n is what the contact terms' energy identity leaves.
    The fields are the friction law at the time level: u'_t and
    lambda_t = -(1/gamma_h) [u'_t - gamma_h sigma_t(u)]_{mu_f [P_gamma(u)]_+}.
    """

    def __init__(self, simulation, dt):
        sim, problem = simulation, simulation.problem
        self.comm = problem.mesh.comm
        self.increment = fem.Function(problem.V)
        terms = problem.friction_terms("work")
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
            terms = problem.friction_terms(quantity)
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
        return assemble_global(self._work, self.comm)

    def update_fields(self) -> None:
        for field in self.fields:
            field.update()


class _GuardedNewton:
    """Semismooth Newton on the friction law guarded by a reference state (see the
    ``guard_friction`` argument of :class:`Simulation`).

    ``model`` is the problem with the guarded law, for the step's residual. With the
    reference at the unknown itself the guarded law is Coulomb's, value for value
    (:func:`~nitsche_dolfinx.contact.guarded_projection`), so the same solver also
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
        at_reference = {w: self.reference}

        def reference(expr):
            return ufl.replace(expr, at_reference)

        self.model = problem.guarded_friction(reference)
        activity = _ContactTerms(
            problem.frictional_contacts,
            lambda c, u, velocity, force, v: c.guard_activity(u, velocity, force, reference),
        )
        self.activity = fem.form(scheme.residual(activity, *state, None))
        self.comm = problem.mesh.comm

    def coulomb_residual(self, solver: SNESSolver, new_coefficients: bool = True) -> float:
        """The norm of Coulomb's residual at the current ``w`` (the reference is moved
        to ``w``); ``solver`` is the SNES of :attr:`model`'s residual."""
        self.reference.x.array[:] = self.w.x.array
        return solver.residual_norm(new_coefficients)

    def solve(
        self, solver: SNESSolver, first_reference: np.ndarray, tolerance: float, updates: int
    ) -> int:
        """Solve from the current ``w`` with the reference ``first_reference`` (an array
        of the unknown), moving the reference to each guarded solution until the guarded
        law is Coulomb's (at most ``updates`` times). The SNES residual tolerance is the
        absolute ``tolerance``. Returns the Newton iterations of all the solves."""
        solver.snes.setTolerances(rtol=0.0, atol=tolerance)
        self.reference.x.array[:] = first_reference
        spent = 0
        for _ in range(updates + 1):
            spent += self._solve_once(solver)
            if assemble_global(self.activity, self.comm) == 0.0:
                return spent
            self.reference.x.array[:] = self.w.x.array
        raise SolverError(PETSc.SNES.ConvergedReason.DIVERGED_MAX_IT, spent, float("nan"))

    def _solve_once(self, solver: SNESSolver) -> int:
        """One solve with a fixed reference: full Newton steps and, should they cycle
        among the pieces of the law, again from the same start with the l2 line search
        (measured: the block just stopped, its edges still slipping)."""
        start = self.w.x.array.copy()
        try:
            return solver.solve()
        except SolverError as error:
            spent = error.iterations
        self.w.x.array[:] = start
        with solver.line_search("l2"):
            try:
                return spent + solver.solve()
            except SolverError as error:
                error.iterations += spent
                raise


class Simulation:
    """March a :class:`ContactProblem` in time with one SNES solve per step.

    Args:
        problem: The problem.
        scheme: The time scheme.
        dt: Time step tau (> 0).
        t_end: Final time T (>= dt).
        petsc_options: PETSc options for the step's SNES
            (see :class:`~nitsche_dolfinx.solver.SNESSolver`).
        progress: Print one line per step on rank 0.
        reuse_jacobian: Assemble the constant bulk Jacobian once and re-factorise only
            when the contact part of the Jacobian changes (the default); False
            re-assembles and re-factorises at every Newton iteration.
        preconditioner_lag: When > 0, keep the last factorised Jacobian as the
            preconditioner of GMRES until a linear solve needs more than this many
            iterations (see :class:`~nitsche_dolfinx.solver.SNESSolver`).
        guard_friction: With friction, solve each step's Coulomb law by semismooth
            Newton guarded by a reference state (the default; False: plain semismooth
            Newton on [P_t]_r). The stick band |P_t| <= mu_f [P_gamma]_+ is about
            gamma_h |lambda_n| wide in velocity, far thinner than a step's change of
            velocity: plain Newton jumps over it from one slip direction to the other
            and cycles where a point must stop. The guarded law
            (:func:`~nitsche_dolfinx.contact.guarded_projection`) keeps the stick branch
            where the reference sticks and behind the reference's slip direction. The
            first reference is the state coasting at the velocity v^n; after each guarded
            solve (to the tolerance of the step's SNES) an assembled indicator tells
            whether the guarded law is Coulomb's at every quadrature point, and while it
            is not, the reference moves to that solution (at most ``guard_updates``
            times). Newton iterations count all the guarded solves.
    """

    #: How many times a step may move the reference of the guarded friction law.
    guard_updates = 10

    def __init__(
        self,
        problem: ContactProblem,
        scheme: TimeScheme,
        dt: float,
        t_end: float,
        petsc_options: dict[str, Any] | None = None,
        progress: bool = False,
        reuse_jacobian: bool = True,
        preconditioner_lag: int = 0,
        guard_friction: bool = True,
    ):
        check_time_parameters(dt, t_end)
        if problem.mass == "redistributed" and isinstance(scheme, HybridScheme):
            raise ValueError(
                "mass='redistributed' with the hybrid scheme: the massless contact nodes "
                "are then left to alternate around the obstacle (measured: E grows 48-fold "
                "on the bar); use it with Crank-Nicolson, theta or Newmark"
            )
        self.problem = problem
        self.scheme = scheme
        self.dt = float(dt)
        self.t_end = float(t_end)
        self.num_steps = int(round(self.t_end / self.dt))
        self.progress = progress
        self.comm = problem.mesh.comm
        V = problem.V
        self.u = fem.Function(V, name="displacement")
        self.v = fem.Function(V, name="velocity")
        self.a = fem.Function(V, name="acceleration")
        self.w = fem.Function(V, name="unknown")
        self.t = 0.0
        self.step_index = 0
        self.newton_iterations = 0
        self.step_seconds = 0.0
        self._probes: dict[str, Callable[[], float]] = {}

        fdim = problem.mesh.topology.dim - 1
        self._bc_dofs = [
            (fem.locate_dofs_topological(V, fdim, problem.facets(tag)), value)
            for tag, value in problem.dirichlet
        ]
        self._w_bc = fem.Function(V)
        bcs = [fem.dirichletbc(self._w_bc, dofs) for dofs, _ in self._bc_dofs]
        test = ufl.TestFunction(V)
        dt_c = fem.Constant(problem.mesh, self.dt)
        self._guarded = None
        model = problem
        if problem.frictional and guard_friction:
            self._guarded = _GuardedNewton(problem, scheme, (self.w, self.u, self.v, self.a, dt_c))
            model = self._guarded.model
        F = scheme.residual(model, self.w, self.u, self.v, self.a, dt_c, test)
        activity = None
        if problem.contacts:  # lets the solver skip the contact Jacobian out of contact
            cellwise = ufl.TestFunction(compat.function_space(problem.mesh, "DG", 0))
            terms = problem.contact_activity()
            activity = scheme.residual(terms, self.w, self.u, self.v, self.a, dt_c, cellwise)
        # The bulk is linear elastodynamics: its terms (the cell integrals) are affine in
        # the unknown, and only the contact terms on Gamma_C change the Jacobian.
        self.solver = SNESSolver(
            F,
            self.w,
            bcs,
            petsc_options=petsc_options,
            affine_cell_terms=reuse_jacobian,
            mass_diagonal=problem.mass_diagonal(),
            preconditioner_lag=preconditioner_lag if reuse_jacobian else 0,
            facet_activity=activity,
            symmetric=problem.symmetric_jacobian,
        )
        # the guarded solves set their own absolute tolerance from these at every step
        self._tolerances = self.solver.snes.getTolerances()[:2]
        self.diagnostics = Diagnostics(problem, self.u, self.v)
        self.friction_dissipation = 0.0
        self._energy_before = None  # E_Theta^n of the last step
        self._energy_cache = None  # (step index, E_Theta) of the last state()
        self._friction = _FrictionOutput(self, dt_c) if problem.frictional else None
        self._massless = problem.massless_dofs()
        self._petsc_options = petsc_options
        self._initialize()

    # -- state ---------------------------------------------------------------------------

    def _interpolate_initial(self, target: fem.Function, value) -> None:
        if value is None:
            target.x.array[:] = 0.0
        elif isinstance(value, fem.Function):
            target.interpolate(value)
        elif callable(value):
            gdim = self.problem.gdim
            target.interpolate(lambda x: np.asarray(value(x), dtype=float).reshape(gdim, -1))
        else:
            array = _as_array(value, (self.problem.gdim,), "initial value")
            target.interpolate(lambda x: np.tile(array[:, None], (1, x.shape[1])))
        target.x.scatter_forward()

    def _set_dirichlet(self, target: np.ndarray, t: float) -> None:
        """Write the Dirichlet values at time t into the dof array ``target``."""
        bs = self.problem.V.dofmap.index_map_bs
        for dofs, value in self._bc_dofs:
            target.reshape(-1, bs)[dofs] = value.value_at(t)

    def _initialize(self) -> None:
        """u0, v0 and the consistent initial acceleration M a0 = L(0) - B(u0)."""
        problem = self.problem
        self._interpolate_initial(self.u, problem.initial_displacement)
        self._interpolate_initial(self.v, problem.initial_velocity)
        self._set_dirichlet(self.u.x.array, 0.0)
        problem.set_time(0.0)
        V = problem.V
        test = ufl.TestFunction(V)
        F0 = (
            problem.inertia(self.a, test)
            + problem.operator(self.u, test, self.v)
            - problem.load(test)
        )
        zero = fem.Function(V)
        bcs = [fem.dirichletbc(zero, dofs) for dofs, _ in self._bc_dofs]
        diagonal = problem.mass_diagonal()
        if diagonal is not None:
            # massless nodes (redistributed mass) have no acceleration of their own
            with diagonal.localForm() as local:
                bs = V.dofmap.index_map_bs
                massless = np.flatnonzero(local.array.reshape(-1, bs)[:, 0] == 0.0)
            bcs.append(fem.dirichletbc(zero, massless.astype(np.int32)))
        self.a.x.array[:] = 0.0
        solver = SNESSolver(
            F0, self.a, bcs, petsc_options=self._petsc_options, mass_diagonal=diagonal
        )
        solver.solve()
        solver.destroy()

    def add_probe(self, name: str, probe: Callable[[], float]) -> None:
        """Add a history column computed by ``probe()`` at every time level."""
        self._probes[name] = probe

    def state(self) -> dict[str, float]:
        """Diagnostics at the current time level, identical on every rank."""
        values = {"t": self.t, **self.diagnostics.compute()}
        self._energy_cache = (self.step_index, values["energy_theta"])
        values["friction_dissipation"] = self.friction_dissipation
        values["energy_balance_residual"] = (
            0.0
            if self._energy_before is None
            else values["energy_theta"] - self._energy_before + self.friction_dissipation
        )
        values["newton_iterations"] = self.newton_iterations
        values["step_seconds"] = self.step_seconds
        for name, probe in self._probes.items():
            values[name] = probe()
        return values

    # -- time stepping -------------------------------------------------------------------

    def step(self) -> int:
        """Advance one time step; returns the Newton iterations."""
        start = time.perf_counter()
        problem, scheme, dt = self.problem, self.scheme, self.dt
        t_new = (self.step_index + 1) * dt  # no drift from adding dt up
        problem.set_time(scheme.equation_time(self.t, dt))
        if self._bc_dofs:
            u_free, _, _ = scheme.kinematics(
                self.u.x.array, self.v.x.array, self.a.x.array, 0.0, dt
            )
            target = u_free.copy()
            self._set_dirichlet(target, t_new)
            self._w_bc.x.array[:] = (target - u_free) / scheme.displacement_coefficient(dt)
        self._energy_before = self._energy_theta()
        self.w.x.array[:] = self.a.x.array  # initial guess: the last acceleration
        try:
            iterations = self._solve()
        except SolverError as error:
            error.add_context(step=self.step_index + 1, t=t_new)
            raise
        u1, v1, a1 = scheme.kinematics(
            self.u.x.array, self.v.x.array, self.a.x.array, self.w.x.array, dt
        )
        _massless_velocity(self._massless, self.u.x.array, u1, v1, a1, dt)
        if self._friction is not None:  # before u^n is overwritten
            self.friction_dissipation = self._friction.work(u1 - self.u.x.array)
        self.u.x.array[:] = u1
        self.v.x.array[:] = v1
        self.a.x.array[:] = a1
        self.t = t_new
        self.step_index += 1
        problem.set_time(self.t)
        self.newton_iterations = iterations
        self.step_seconds = time.perf_counter() - start
        return iterations

    def _energy_theta(self) -> float:
        """E_Theta at the current level (from the last state() when it was at this level)."""
        if self._energy_cache is not None and self._energy_cache[0] == self.step_index:
            return self._energy_cache[1]
        return self.diagnostics.compute()["energy_theta"]

    def output_fields(self) -> dict:
        """The fields of ``solution.xdmf``: ``{name: (function or expression, shape)}``:
        displacement, velocity, von Mises stress, and with friction the slip velocity and
        the friction traction on Gamma_C (see :class:`_FrictionOutput`)."""
        shape = (self.problem.gdim,)
        fields = {
            "displacement": (self.u, shape),
            "velocity": (self.v, shape),
            "von_mises": (self.von_mises(), ()),
        }
        if self._friction is not None:
            for field in self._friction.fields:
                fields[field.function.name] = (field.function, shape)
        return fields

    def _solve(self) -> int:
        """The step's Newton solve from the current ``w``; returns the Newton iterations.
        With friction, guarded as described in the class docstring."""
        if self._guarded is None:
            return self.solver.solve()
        guarded, solver = self._guarded, self.solver
        rtol, atol = self._tolerances
        tolerance = max(atol, rtol * guarded.coulomb_residual(solver))
        try:
            return guarded.solve(solver, self._coasting_unknown(), tolerance, self.guard_updates)
        except SolverError as error:
            error.residual_norm = guarded.coulomb_residual(solver, new_coefficients=False)
            raise

    def _coasting_unknown(self) -> np.ndarray:
        """The unknown w of the step whose new velocity is v^n: the state coasting at
        constant velocity, where the guarded friction law takes its first reference."""
        u, v, a, dt = self.u.x.array, self.v.x.array, self.a.x.array, self.dt
        _, v_0, _ = self.scheme.kinematics(u, v, a, 0.0, dt)
        _, v_1, _ = self.scheme.kinematics(u, v, a, 1.0, dt)
        return (v - v_0) / (v_1 - v_0)

    def von_mises(self):
        """The von Mises stress of the current displacement, as a UFL expression."""
        return von_mises(self.u, self.problem.material)

    def run(
        self,
        out: str | None = None,
        columns=HISTORY_COLUMNS,
        callback: Callable[[Simulation], None] | None = None,
        output_every: int = 0,
        checkpoint_every: int = 0,
        restart: str | bool | None = None,
    ) -> list[dict[str, float]]:
        """Run to t_end, or until a solver failure or a signal stops it cleanly.

        Args:
            out: Output folder for ``history.csv`` (and ``solution.xdmf`` when
                ``output_every > 0``, and the checkpoints in ``out/checkpoint``);
                nothing is written when omitted.
            columns: History columns: names of :meth:`state` entries.
            callback: Called as ``callback(simulation)`` after every step.
            output_every: Write the XDMF fields every this many steps (0: never).
            checkpoint_every: Write a checkpoint every this many steps and at the end
                (0: only when the run stops early). Needs ``out``.
            restart: Continue from a checkpoint: its folder, or True for
                ``out/checkpoint``. The history keeps its rows up to the checkpoint
                and continues; the XDMF series is appended to (see
                :func:`~nitsche_dolfinx.output.continue_solution`).

        Returns:
            The history, one dict of :meth:`state` values per time level (after a
            restart, the rows kept from ``history.csv`` come first).

        Raises:
            SolverError: A step's Newton solve failed. The history and the fields stay
                readable up to the last converged step, and that state is saved in
                ``out/checkpoint`` (``error.checkpoint``, a
                :class:`~nitsche_dolfinx.checkpoint.SavedState`).
            RunInterrupted: SIGINT or SIGTERM arrived (on any rank): every rank stops
                after the same step, which is saved the same way.
            CheckpointError: The checkpoint to restart from is missing or does not fit.
        """
        columns = list(columns)
        checkpoint_every = int(checkpoint_every)
        if checkpoint_every < 0:
            raise ValueError(f"checkpoint_every must be >= 0, got {checkpoint_every!r}")
        if checkpoint_every and out is None:
            raise ValueError("checkpoint_every needs an output folder (out)")
        checkpoints = os.path.join(out, "checkpoint") if out is not None else None
        if restart is True and checkpoints is None:
            raise ValueError("restart=True needs an output folder (out), or give the folder")
        if out is not None:
            ensure_directory(out, self.comm)
        last_saved = None  # the checkpoint of the current step, if there is one
        if restart not in (None, False):
            source = checkpoints if restart is True else str(restart)
            saved = self.load_checkpoint(source, columns)
            if source == checkpoints:
                last_saved = saved
            if self.progress and self.comm.rank == 0:
                print(f"restart: from {source}, step {saved.step}, t = {saved.t:.6g}", flush=True)
        else:
            restart = None
        history, xdmf = None, None
        records = []
        if out is not None:
            history = HistoryWriter(
                os.path.join(out, "history.csv"),
                columns,
                self.comm,
                resume_at=self.t if restart is not None else None,
            )
            records.extend(history.previous_rows)
            if output_every > 0:
                xdmf = self._solution_writer(out, restart is not None)
        # failures are compared on a communicator of their own (see all_ranks_reach)
        errors = self.comm.Dup() if self.comm.size > 1 else None
        collective_exit = False
        try:
            with StopSignals() as signals:
                if restart is None or history is None:
                    self._record(records, history, xdmf, output_every, write=restart is None)
                while self.step_index < self.num_steps:
                    try:
                        self.step()
                    except SolverError as error:
                        error.checkpoint = self._save_on_stop(checkpoints, last_saved, columns)
                        raise
                    self._record(records, history, xdmf, output_every)
                    if callback is not None:
                        callback(self)
                    if checkpoint_every and self.step_index % checkpoint_every == 0:
                        last_saved = self.save_checkpoint(checkpoints, columns)
                    number = signals.requested(self.comm)
                    if number:
                        saved = self._save_on_stop(checkpoints, last_saved, columns)
                        raise RunInterrupted(number, self.step_index, self.t, saved)
                if checkpoint_every and (last_saved is None or last_saved.step != self.step_index):
                    self.save_checkpoint(checkpoints, columns)
            collective_exit = True
        except (SolverError, RunInterrupted, CheckpointError):
            collective_exit = True  # raised on every rank alike
            raise
        except BaseException:
            # closing the XDMF file is collective: if the other ranks did not fail, they
            # wait elsewhere, and the file is left to the end of the process
            collective_exit = errors is None or all_ranks_reach(errors)
            raise
        finally:
            if history is not None:
                history.close()
            if collective_exit:
                if xdmf is not None:
                    xdmf.close()
                if errors is not None:
                    errors.Free()
        return records

    def _solution_writer(self, out: str, restarted: bool) -> SolutionWriter:
        path = os.path.join(out, "solution.xdmf")
        append = False
        if restarted:
            path, append = continue_solution(path, self.t, self.step_index, self.comm)
            if not append and os.path.basename(path) != "solution.xdmf" and self.progress:
                if self.comm.rank == 0:
                    print(
                        f"restart: solution.xdmf holds fields after t = {self.t:.6g} (or "
                        f"cannot be read); the fields from step {self.step_index} on go to "
                        f"{path}",
                        flush=True,
                    )
        return SolutionWriter(path, self.problem.mesh, self.output_fields(), append=append)

    def _record(self, records, history, xdmf, output_every, write: bool = True) -> None:
        values = self.state()
        records.append(values)
        if not write:  # the restarted time level: already in the files
            return
        if history is not None:
            history.write(values)
        if xdmf is not None and self.step_index % output_every == 0:
            if self._friction is not None:  # boundary projections: only when written
                self._friction.update_fields()
            xdmf.write(self.t)
        if self.progress and self.comm.rank == 0:
            print(
                f"step {self.step_index:5d}  t = {self.t:9.4f}"
                f"  newton = {values['newton_iterations']:2d}  E = {values['energy']: .10e}"
                f"  contact force = {values['contact_force']:.4e}",
                flush=True,
            )

    # -- checkpoints ---------------------------------------------------------------------

    def checkpoint_functions(self) -> dict[str, fem.Function]:
        """The Functions a checkpoint holds, by name: everything the next step depends on."""
        return {"displacement": self.u, "velocity": self.v, "acceleration": self.a}

    def _checkpoint_description(self) -> dict:
        """What a checkpoint must share with the simulation that reloads it."""
        problem = self.problem
        V = problem.V
        friction = getattr(problem, "friction", None)  # a number, a fem.Constant or None
        friction = (
            0.0 if friction is None else float(np.asarray(getattr(friction, "value", friction)))
        )
        return {
            "friction": friction,
            "dofs": int(V.dofmap.index_map.size_global * V.dofmap.index_map_bs),
            "dt": self.dt,
            "scheme": self.scheme.describe(),
            "method": problem.method,
            "mass": problem.mass,
            "degree": problem.degree,
            "gamma0": float(np.asarray(problem.gamma0.value)),
            "nitsche_theta": float(np.asarray(problem.nitsche_theta.value)),
            "functions": sorted(self.checkpoint_functions()),
        }

    def save_checkpoint(self, folder: str, columns=None) -> SavedState:
        """Save the current time level in the checkpoint folder ``folder`` (collective).

        Args:
            folder: The folder; it keeps only the latest checkpoint.
            columns: The history columns of the run, recorded so that a restart
                writing other columns is refused.

        Returns:
            The :class:`~nitsche_dolfinx.checkpoint.SavedState`.
        """
        V = self.problem.V
        owned = V.dofmap.index_map.size_local
        bs = V.dofmap.index_map_bs
        arrays = {
            name: f.x.array.reshape(-1, bs)[:owned]
            for name, f in self.checkpoint_functions().items()
        }
        arrays["points"] = self._node_coordinates()[:owned]
        metadata = {
            **self._checkpoint_description(),
            "newton_iterations": int(self.newton_iterations),
            "columns": list(columns) if columns is not None else None,
        }
        return write_checkpoint(folder, self.comm, self.step_index, self.t, arrays, metadata)

    def load_checkpoint(self, folder: str, columns=None) -> SavedState:
        """Restore the time level saved in ``folder`` by :meth:`save_checkpoint` (collective).

        The values are matched to the dofs by the coordinates of their nodes, so any
        partition of the same mesh, on any number of ranks, reloads them.

        Raises:
            CheckpointError: On every rank, if the checkpoint is missing or unreadable, or
                was written for another mesh, space, scheme, time step, Nitsche parameters
                or set of history columns, or lies past t_end.
        """
        metadata, arrays = read_checkpoint(folder, self.comm)
        expected = self._checkpoint_description()
        for key, value in expected.items():
            if metadata.get(key) != value:
                raise CheckpointError(
                    f"checkpoint {folder!r} does not fit this run: its {key} is "
                    f"{metadata.get(key)!r}, this run's is {value!r}"
                )
        saved_columns = metadata.get("columns")
        if columns is not None and saved_columns is not None and saved_columns != list(columns):
            raise CheckpointError(
                f"checkpoint {folder!r} was written by a run with the history columns "
                f"{','.join(saved_columns)}, this run writes {','.join(columns)}"
            )
        if metadata["step"] > self.num_steps:
            raise CheckpointError(
                f"checkpoint {folder!r} is at t = {metadata['t']:.6g}, past t_end = {self.t_end:g}"
            )
        points = self._node_coordinates()
        extent = self.comm.allreduce(float(np.abs(points).max(initial=0.0)), op=MPI.MAX)
        index = match_points(arrays["points"], points, 1e-8 * max(extent, 1.0))
        missing = int(np.count_nonzero(index < 0))
        agree(
            self.comm,
            f"checkpoint {folder!r} does not fit this run: {missing} of its nodes are not "
            "nodes of this mesh (another mesh?)"
            if missing
            else None,
        )
        bs = self.problem.V.dofmap.index_map_bs
        for name, function in self.checkpoint_functions().items():
            function.x.array.reshape(-1, bs)[:] = arrays[name][index]
        self.t = float(metadata["t"])
        self.step_index = int(metadata["step"])
        self.newton_iterations = int(metadata.get("newton_iterations", 0))
        self.step_seconds = 0.0
        self.problem.set_time(self.t)
        return SavedState(str(folder), self.step_index, self.t)

    def _node_coordinates(self) -> np.ndarray:
        """The coordinates of the nodes of the displacement space, one row per block of its
        dof array (owned, then ghosts): x interpolated into it, which works for every space
        on every dolfinx (``tabulate_dof_coordinates`` refuses 1D vector spaces in 0.5)."""
        V, gdim = self.problem.V, self.problem.gdim
        x = fem.Function(V)
        x.interpolate(lambda points: points[:gdim])
        x.x.scatter_forward()
        return x.x.array.reshape(-1, V.dofmap.index_map_bs).copy()

    def _save_on_stop(self, folder, last_saved, columns) -> SavedState | None:
        """The checkpoint of the last completed step when a run stops early, if it has a place."""
        if folder is None:
            return None
        if last_saved is not None and last_saved.step == self.step_index:
            return last_saved
        return self.save_checkpoint(folder, columns)
