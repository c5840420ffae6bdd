"""The mixed method, for comparison: a Lagrange multiplier for the contact pressure.

The multiplier ``lambda`` (= sigma_n on Gamma_C, <= 0) lives in a P1 field on the
whole mesh whose dofs off Gamma_C are fixed to zero, which builds on every
supported dolfinx version. The contact conditions are written with the
Alart-Curnier complementarity function

    lambda + (1/r) [u_n - g - r lambda]_+ = 0      on Gamma_C   (r = h_T / E),

and the whole system, time-discretised by Crank-Nicolson (equation at t^{n+1},
u^{n+1} = u^n + tau v^n + tau^2/4 (a^n + a^{n+1})), is solved by the same SNES
semismooth Newton:

    <rho a^{n+1}, v> + a(u^{n+1}, v) - int_Gamma_C lambda^{n+1} v_n = L^{n+1}(v).

This is the "Mixed + CN" method of the talk, known to be ill-posed at the
semi-discrete level with the consistent mass (Khenous, Laborde & Renard 2008);
with ``mass="redistributed"`` it is the modified mass method.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import ufl
from dolfinx import fem
from petsc4py import PETSc

from ..common import compat
from ..common.parameters import ParameterError, TimeStepping
from ..contact.nitsche import positive_part
from ..model.problem import ContactProblem
from ..output.diagnostics import Penetration
from ..output.fields import ContactFields, LevelRefresh, body_fields
from ..output.mass_moments import MassMoments
from ..output.probes import assemble_global
from ..physics.dirichlet import DirichletDofs
from ..solvers.linear_solvers import LinearSolver
from ..solvers.solver import SNESSolver
from .base import (
    StepperBase,
    check_initial_gap,
    initial_acceleration,
    interpolate_initial,
    massless_velocity,
)
from .schemes import CrankNicolson

__all__ = ["MixedStepper"]


def _node_keys(V) -> np.ndarray:
    """(coordinates..., component) of every local dof of V, for matching two numberings."""
    points = compat.node_coordinates(V)
    bs = V.dofmap.index_map_bs
    keys = np.repeat(points, bs, axis=0).T.tolist() + [np.tile(np.arange(bs), len(points))]
    return np.round(np.array(keys), 12)


def _matching_dofs(target, source) -> np.ndarray:
    """The permutation p with target dof i = source dof p[i] (same nodes, two numberings)."""
    keys_t, keys_s = _node_keys(target), _node_keys(source)
    order_t = np.lexsort(keys_t[::-1])
    order_s = np.lexsort(keys_s[::-1])
    if keys_t.shape != keys_s.shape or not np.array_equal(keys_t[:, order_t], keys_s[:, order_s]):
        raise RuntimeError("the displacement part of the mixed space does not match V")
    permutation = np.empty_like(order_t)
    permutation[order_t] = order_s
    return permutation


def _check_mixed(problem: ContactProblem, scheme) -> None:
    """What the mixed method needs: Crank-Nicolson, one obstacle, homogeneous Dirichlet data."""
    if not isinstance(scheme, CrankNicolson):
        raise ParameterError(
            "scheme",
            scheme.describe(),
            "the mixed method is time-discretised by Crank-Nicolson only",
        )
    if len(problem.contacts) != 1:
        raise ParameterError(
            "obstacles", len(problem.contacts), "the mixed method takes exactly one obstacle"
        )
    if any(c.value.time_dependent or c.value.space_dependent or np.any(c.value.value_at(0.0))
           for c in problem.dirichlet):  # fmt: skip
        raise ValueError("the mixed method supports homogeneous Dirichlet values only")


class MixedStepper(StepperBase):
    """Crank-Nicolson steps of a :class:`~nitsche_dolfinx.model.problem.ContactProblem` whose
    method is ``"mixed"``: contact by a Lagrange multiplier, one obstacle.

    A :class:`~nitsche_dolfinx.steppers.base.Stepper`:
    :class:`~nitsche_dolfinx.simulation.Simulation`
    builds it for a mixed problem and runs it like any other (history, fields,
    checkpoints, restarts). :meth:`contact_pressure` is lambda, the multiplier.
    """

    def __init__(
        self,
        problem: ContactProblem,
        scheme,
        time_stepping: TimeStepping,
        petsc_options: dict[str, Any] | None = None,
        linear_solver: LinearSolver | None = None,
    ):
        _check_mixed(problem, scheme)
        self._start(problem, scheme, time_stepping)
        self.contact, self.tag = problem.contacts[0], problem.contact_tags[0]
        V0, Q = self._spaces()
        bcs = self._boundary_conditions(V0, Q)
        diagonal = self._mass_diagonal_on_W()
        self.solver = SNESSolver(
            self._residual(), self.x, bcs, petsc_options=petsc_options, mass_diagonal=diagonal,
            linear_solver=linear_solver,
        )  # fmt: skip
        # energies: E = kinetic + elastic - L(u), no Nitsche correction
        contact, lam = self.contact, self._lambda
        self._energy_forms = [
            fem.form(0.5 * problem.material_constants.rho * ufl.inner(self.v, self.v) * problem.dx)
            if diagonal is None
            else None,
            fem.form(0.5 * problem.bulk_stiffness(self.u, self.u)),
            fem.form(-problem.load(self.u)),
            fem.form(-lam * contact.ds),
        ]
        self._area = fem.form(ufl.conditional(ufl.lt(lam, 0.0), 1.0, 0.0) * contact.ds)
        self._penetration = Penetration(problem, self.u)
        self._moments = MassMoments(problem)  # momentum and centre of mass
        self._massless = problem.massless_dofs()
        self._contact_fields = None  # ContactFields, once the output asks for them
        self._initialize()

    def _spaces(self):
        """The mixed space W of (a, lambda) and the unknown on W; returns the collapsed
        displacement and multiplier spaces."""
        problem = self.problem
        W = compat.mixed_function_space(
            problem.mesh, [("Lagrange", problem.degree, (problem.gdim,)), ("Lagrange", 1, ())]
        )
        self.W = W
        V0, u_dofs = compat.collapse(W.sub(0))
        Q, lambda_dofs = compat.collapse(W.sub(1))
        # u, v and a live on the problem's space (the collapsed one may differ in its
        # numbering, and is scalar for a 1D vector part from dolfinx 0.7): match the dofs
        V = problem.V
        self._w_index = u_dofs[_matching_dofs(V, V0)]
        self.x = fem.Function(W)  # the unknown (a^{n+1}, lambda^{n+1})
        self._lambda = ufl.split(self.x)[1]
        # the multiplier on its own space, for checkpoints (the next step starts from it)
        self.multiplier = fem.Function(Q, name="multiplier")
        self._lambda_index = np.asarray(lambda_dofs)
        return V0, Q

    def _boundary_conditions(self, V0, Q) -> list:
        """Dirichlet conditions on the displacement part, and lambda = 0 off Gamma_C."""
        problem, W = self.problem, self.W
        mesh = problem.mesh
        fdim = mesh.topology.dim - 1
        bcs = []
        for condition in problem.dirichlet:
            facets = problem.facets(condition.tag)
            if condition.component is None:
                dofs = fem.locate_dofs_topological((W.sub(0), V0), fdim, facets)
                bcs.append(fem.dirichletbc(fem.Function(V0), dofs, W.sub(0)))
            else:  # one component: a zero on the subspace of W that holds it
                part = W.sub(0).sub(condition.component)
                dofs = fem.locate_dofs_topological(part, fdim, facets)
                bcs.append(fem.dirichletbc(PETSc.ScalarType(0), dofs, part))
        mesh.topology.create_connectivity(0, mesh.topology.dim)
        num_vertices = mesh.topology.index_map(0).size_local + mesh.topology.index_map(0).num_ghosts
        every = fem.locate_dofs_topological(
            (W.sub(1), Q), 0, np.arange(num_vertices, dtype=np.int32)
        )
        on_contact = fem.locate_dofs_topological((W.sub(1), Q), fdim, problem.facets(self.tag))
        off = ~np.isin(every[0], on_contact[0])
        bcs.append(fem.dirichletbc(fem.Function(Q), [every[0][off], every[1][off]], W.sub(1)))
        return bcs

    def _residual(self):
        """The step's equation and the Alart-Curnier complementarity (docs/method.md
        section 2), Crank-Nicolson in time."""
        problem, contact = self.problem, self.contact
        w, lam = ufl.split(self.x)
        test_v, test_mu = ufl.TestFunctions(self.W)
        self._dt = fem.Constant(problem.mesh, self.dt)  # the size of the step
        u1, _, _ = self.scheme.kinematics(self.u, self.v, self.a, w, self._dt)
        # the Alart-Curnier parameter does not change the solution; h/E keeps the rows scaled
        r = problem.h / problem.material_constants.E
        complementarity = (
            lam + positive_part(contact.normal_displacement(u1) - contact.gap - r * lam) / r
        )
        return (
            problem.inertia(w, test_v)  # zero for a diagonal mass, added by the solver
            + problem.bulk_stiffness(u1, test_v)
            - lam * contact.normal_displacement(test_v) * contact.ds
            - problem.load(test_v)
            + complementarity * test_mu * contact.ds
        )

    def _mass_diagonal_on_W(self):
        """The problem's diagonal mass (lumped, redistributed) on the displacement dofs of W."""
        diagonal = self.problem.mass_diagonal()
        if diagonal is None:
            return None
        self._mass_V = diagonal
        on_W = compat.create_vector(self.W)
        with on_W.localForm() as target, diagonal.localForm() as source:
            target.set(0.0)
            target.array[self._w_index] = source.array
        return on_W

    def _kinetic(self) -> float:
        """1/2 v . M v with the diagonal mass."""
        velocity = compat.petsc_vector(self.v)
        product = velocity.duplicate()
        product.pointwiseMult(self._mass_V, velocity)
        value = 0.5 * product.dot(velocity)
        product.destroy()
        return value

    def _initialize(self) -> None:
        """u0, v0 and a0 from M a0 = L(0) - K u0: the body starts apart from the obstacle
        with the multiplier zero."""
        problem = self.problem
        interpolate_initial(self.u, problem.initial_displacement, problem.gdim)
        interpolate_initial(self.v, problem.initial_velocity, problem.gdim)
        check_initial_gap(self._penetration.max(), problem.mesh)
        initial_acceleration(
            problem,
            self.a,
            lambda test: problem.bulk_stiffness(self.u, test),
            DirichletDofs(problem),
        )

    def state(self, columns=None) -> dict:
        """t, the energies (E = E_Theta here: no Nitsche term), the contact force
        -int lambda, the contact area (where lambda < 0) and the largest penetration; the
        momentum, the centre of mass and the totals of the one obstacle (``_1``)."""
        kinetic, elastic, potential, force = (
            self._kinetic() if form is None else assemble_global(form, self.comm)
            for form in self._energy_forms
        )
        energy = kinetic + elastic + potential
        values = {
            "t": self.t,
            "energy": energy,
            "energy_theta": energy,
            "kinetic": kinetic,
            "elastic": elastic,
            "potential": potential,
            "contact_force": force,
            "contact_area": assemble_global(self._area, self.comm),
            "penetration_max": self._penetration.max(),
            **self._clock_columns(),
            **self._moments.values(self.u, self.v),
        }
        values["contact_force_1"], values["contact_area_1"] = force, values["contact_area"]
        return values

    def step(self, t_new: float | None = None, cuts: int = 0) -> int:
        """One Crank-Nicolson step to ``t_new`` (default: the next nominal level); returns
        the Newton iterations. If Newton fails, the state stays that of t^n."""
        start = time.perf_counter()
        t_new, dt = self._step_to(t_new)
        self._dt.value = dt  # no constant bulk Jacobian here: nothing to assemble again
        self.problem.set_time(t_new)
        self.x.x.array[self._w_index] = self.a.x.array  # guess: the last acceleration
        iterations = self.solver.solve_with_line_search()
        w = self.x.x.array[self._w_index]
        u1, v1, a1 = self.scheme.kinematics(self.u.x.array, self.v.x.array, self.a.x.array, w, dt)
        massless_velocity(self._massless, self.u.x.array, u1, v1, a1, dt)
        self.u.x.array[:], self.v.x.array[:], self.a.x.array[:] = u1, v1, a1
        self._arrive(t_new, dt, cuts)
        self.newton_iterations = iterations
        self.step_seconds = time.perf_counter() - start
        return iterations

    def contact_pressure(self):
        """The contact pressure: the multiplier lambda (<= 0), a UFL expression."""
        return self._lambda

    def output_fields(self) -> dict:
        """Displacement, velocity, von Mises stress and the contact fields of
        :class:`~nitsche_dolfinx.output.fields.ContactFields`, with the multiplier lambda (zero
        off Gamma_C) as ``contact_pressure`` and lambda < 0 as the contact set."""
        if self._contact_fields is None:  # compiled when first asked for
            in_contact = ufl.conditional(ufl.lt(self._lambda, 0.0), 1.0, 0.0)
            self._contact_fields = ContactFields(
                self.problem, self.u, pressure=self.multiplier, in_contact=in_contact
            )
        refresh = LevelRefresh(self._update_projections, lambda: (self.step_index, self.t))
        contact = {
            name: (refresh.wrap(f), s) for name, (f, s) in self._contact_fields.fields().items()
        }
        return {**body_fields(self.problem, self.u, self.v), **contact}

    def _update_projections(self) -> None:
        """The multiplier and the contact fields' projections at the state."""
        self.multiplier.x.array[:] = self.x.x.array[self._lambda_index]
        self._contact_fields.update()  # lambda and the state are those of the level

    def checkpoint_functions(self) -> dict[str, fem.Function]:
        """u, v, a and the multiplier lambda (copied out of the mixed unknown), by name:
        everything the next step depends on."""
        self.multiplier.x.array[:] = self.x.x.array[self._lambda_index]
        return {**self._state_functions(), "multiplier": self.multiplier}

    def restore(self, t: float, step_index: int, saved: dict[str, Any]) -> None:
        """Move to a loaded time level; the multiplier becomes the next step's guess."""
        self.x.x.array[self._lambda_index] = self.multiplier.x.array
        super().restore(t, step_index, saved)
