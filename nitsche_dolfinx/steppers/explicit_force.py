"""The force of the explicit Verlet steps, F = L - B(u) at the current u (docs/method.md
section 12), assembled as a vector without a solve:

- the affine terms (the bulk's stiffness K and A_Thgamma's boundary part on Gamma_C of the
  obstacles that stand still) as matrices assembled once, in blocks, applied by products;
  K u alone also gives the elastic energy;
- the contact's force terms on Gamma_C: those of the obstacles that stand still from
  operators on Gamma_C's quadrature points
  (:class:`~nitsche_dolfinx.contact.quadrature.QuadratureContact`,
  ``contact_force="quadrature"``), those of moving obstacles and contact pairs, or all with
  ``contact_force="forms"``, by the assembly of their forms (the two give the same force
  to round-off); the partner-tested terms of contact pairs;
- the loads: the tractions on their boundaries, and the body force lumped as the mass is
  (M f / rho: with the HRZ mass of P2 the consistent int f . v puts no force on the
  vertices of triangles, and a falling body would not fall rigidly).
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from petsc4py import PETSc

from ..assembly.pair_coupling import add_partner_terms
from ..common import compat
from ..common.collective import sum_over_ranks
from ..contact.nitsche import positive_part
from ..contact.quadrature import QuadratureContact
from ..model.problem import ContactProblem
from ..output.mass_moments import assembled_matrix
from .base import LoadVector
from .explicit_mass import unit_density_mass

__all__ = ["CONTACT_FORCES", "ExplicitForce"]

#: How the steps get the contact's force terms: "quadrature" (the obstacles that stand
#: still from operators on Gamma_C's quadrature points, the others by assembly) or "forms"
#: (all by assembly).
CONTACT_FORCES = ("quadrature", "forms")


class ExplicitForce:
    """The force F = L - B(u) of the explicit steps (see the module docstring).

    Args:
        problem: The problem.
        u, v: The stepper's displacement and velocity.
        contact_force: One of :data:`CONTACT_FORCES`.
        fixed: The local Dirichlet dofs.

    Attributes:
        stiffness: The bulk's stiffness matrix K.
        product: K u of the last force evaluation.
        work: A vector of the layout, for products.
        affine_form: The boundary part of A_Thgamma of every contact (a form; None without
            contact), for the set-up of the stable step.
        contact_forces: The contact's force terms C(u) (a form; None without contact),
            for the massless nodes.
    """

    def __init__(self, problem: ContactProblem, u, v, contact_force: str, fixed: np.ndarray):
        self.problem, self.u, self.comm = problem, u, problem.mesh.comm
        V = problem.V
        test = ufl.TestFunction(V)
        self.pairs = problem.pairs  # contact between bodies: the partner-tested terms apart
        assembled = self._contact_terms(v, test, contact_force)
        self.stiffness = assembled_matrix(problem.bulk_stiffness(ufl.TrialFunction(V), test))
        fixed_affine = self._fixed_affine
        self.boundary = None if fixed_affine is None else assembled_matrix(fixed_affine)
        boundary = -assembled if assembled is not None else None
        if problem.has_tractions:
            tractions = problem.traction_load(test)
            boundary = tractions if boundary is None else tractions + boundary
        self._form = None if boundary is None else fem.form(boundary)
        self._vector = compat.create_vector(V)
        self.product = compat.create_vector(V)
        self.work = self.product.duplicate()
        self._partner_work = (self.product.duplicate(), self.product.duplicate())
        self._fixed_owned = fixed[fixed < self.product.getLocalSize()]
        #: the mass of density 1, of the same kind: it lumps the loads per unit volume
        self._unit_mass = unit_density_mass(problem, fixed) if problem.has_loads else None
        self._unit_loads = self._lumped_unit_loads() if problem.has_loads else None
        self._load_field = None  # a body force in space: its interpolant (:meth:`_body_load`)
        tractions = problem.has_tractions
        self._tractions = fem.form(-problem.traction_load(u)) if tractions else None
        self._traction_loads = None  # the tractions' vector (a LoadVector), with tractions
        if tractions:
            self._traction_loads = LoadVector(problem, fem.form(problem.traction_load(test)))

    def _contact_terms(self, v, test, contact_force: str):
        """The contact's terms: A_Thgamma's boundary part (all, and of the obstacles that
        stand still), the force terms (all, and those assembled at each step: returned),
        the quadrature operators of the obstacles that stand still and the pairs' partner
        forms."""
        problem, u = self.problem, self.u
        trial = ufl.TrialFunction(problem.V)
        affine = forces = fixed_affine = assembled = None
        partner_forms = []
        #: the obstacles that stand still, whose force terms come from quadrature operators
        still = [c for c in problem.contacts if not c.moving and c not in self.pairs]
        still = still if contact_force == "quadrature" else []
        for contact in problem.contacts:
            term = contact.affine_terms(trial, test)
            affine = term if affine is None else affine + term
            if not contact.moving:
                fixed_affine = term if fixed_affine is None else fixed_affine + term
            force = positive_part(contact.projection(u))
            term = contact.force_terms(u, v, force, test)
            if contact.moving:  # its normal may turn: A_Thgamma's boundary part each step
                term = term + contact.affine_terms(u, test)
            forces = term if forces is None else forces + term
            if contact not in still:
                assembled = term if assembled is None else assembled + term
            if contact in self.pairs:
                partner_forms.append(fem.form(contact.partner_term(force, test)))
        self.quadrature = QuadratureContact(problem, still, u) if still else None
        self._partner_forms = partner_forms
        self.affine_form, self.contact_forces = affine, forces
        self._fixed_affine = fixed_affine
        return assembled

    def assemble(self) -> tuple[PETSc.Vec, PETSc.Vec]:
        """The force F = L - B(u) at the current u (and loads' time), its ghosts up to
        date, and the elastic force K u."""
        vector = self._vector
        with vector.localForm() as local:
            local.set(0.0)
        for pair in self.pairs:
            pair.update([self.u])
        if self._form is not None:
            fem_petsc.assemble_vector(vector, self._form)
        if self.quadrature is not None:
            with vector.localForm() as local:
                self.quadrature.subtract(local.array)
        if self._form is not None or self.quadrature is not None:
            vector.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        add_partner_terms(self.pairs, self._partner_forms, vector, self._partner_work,
                          self._fixed_owned, scale=-1.0)  # fmt: skip
        u = compat.petsc_vector(self.u)
        self.stiffness.mult(u, self.product)
        vector.axpy(-1.0, self.product)
        if self.boundary is not None:
            self.boundary.mult(u, self.work)
            vector.axpy(-1.0, self.work)
        if self._unit_loads is not None:
            vector.array += self._body_load()
        vector.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        return vector, self.product

    def stiffness_product(self) -> None:
        """K u of the current u into :attr:`product` (after the state is put back or
        loaded)."""
        self.stiffness.mult(compat.petsc_vector(self.u), self.product)

    def affine_matrix(self) -> PETSc.Mat:
        """The matrix of all the affine terms, the bulk's and :attr:`affine_form` (a moving
        obstacle's at t = 0), for the set-up: the steps take their products apart."""
        if self.affine_form is None:
            return self.stiffness
        matrix = assembled_matrix(self.affine_form)
        total = self.stiffness.duplicate(copy=True)
        total.axpy(1.0, matrix, structure=PETSc.Mat.Structure.SUBSET)  # cells' pattern
        matrix.destroy()
        return total

    def elastic(self) -> float:
        """1/2 u . K u from the bulk's product of the last force evaluation (at this u)."""
        n = self.product.getLocalSize()
        local = self.u.x.array[:n] @ self.product.array_r
        return float(sum_over_ranks(self.comm, [local])[0]) / 2

    def potential(self) -> float:
        """-L(t)(u), the body force lumped as the steps take it (M f / rho . u, M f / rho
        of :meth:`_body_load`), and the tractions."""
        body = 0.0
        if self._unit_loads is not None:
            n = self.product.getLocalSize()
            local = -(self._body_load() @ self.u.x.array[:n])
            body = sum_over_ranks(self.comm, [local])[0]
        if self._tractions is None:
            return float(body)
        return float(body + sum_over_ranks(self.comm, [fem.assemble_scalar(self._tractions)])[0])

    def load_vector(self) -> np.ndarray | None:
        """The loads' vector at the current time (owned dofs), as the steps take them: the
        body force lumped as the mass is, and the tractions; None without loads."""
        if not self.problem.has_loads:
            return None
        loads = np.zeros(self.product.getLocalSize())
        if self._unit_loads is not None:
            loads += self._body_load()
        if self._traction_loads is not None:
            loads += self._traction_loads()
        return loads

    def _body_load(self) -> np.ndarray:
        """M f / rho at the current time (owned rows): the body force lumped as the mass is;
        f constant in space by :meth:`_lumped_unit_loads`, else its interpolant's."""
        problem = self.problem
        f = problem.body_force_in_space
        if f is None:
            return problem.body_force() @ self._unit_loads
        if self._load_field is None or problem.loads_in_time:
            if self._load_field is None:
                self._load_field = fem.Function(problem.V)
                self._load_expression = compat.expression(f, problem.V)
            self._load_field.interpolate(self._load_expression)
            field = compat.petsc_vector(self._load_field)
            self._unit_mass.mult(field, self.work)
            self._load = self.work.array_r.copy()
        return self._load

    def _lumped_unit_loads(self) -> np.ndarray:
        """M e_k / rho for each component k (owned rows; with several materials, the mass of
        density 1 times e_k): the body force f, constant in space, is f @ these."""
        unit, bs = self.product.duplicate(), self.problem.V.dofmap.index_map_bs
        loads = np.zeros((bs, unit.getLocalSize()))
        for k in range(bs):
            unit.array[:] = 0.0
            unit.array[k::bs] = 1.0
            self._unit_mass.mult(unit, self.work)
            loads[k] = self.work.array_r
        unit.destroy()
        return loads
