"""The system of a step of linear elastodynamics with contact (docs/method.md section 8),
whose cell terms are affine in the unknown: their Jacobian K is assembled once and their
residual is a product with it, the facet (contact) Jacobian B is assembled where the contact
is, and the Jacobian K_bc + B is set again only where B changed
(:class:`~nitsche_dolfinx.assembly.jacobian_sum.JacobianSum`). It also takes the coupling of
contact pairs (:class:`~nitsche_dolfinx.assembly.pair_coupling.PairCoupling`), whose growth
widens the Jacobian's sparsity. The step's forms come as :class:`StepForms`.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
import ufl
from petsc4py import PETSc
from ufl.algorithms import expand_derivatives, extract_coefficients

from ..common import compat
from .facet_jacobian import ContactFacets, FacetJacobian
from .forms import (
    CellResidualAtZero,
    Forms,
    facet_quadrature_degrees,
    split_cell_integrals,
    with_facet_quadrature,
)
from .jacobian_sum import JacobianSum
from .systems import SystemBase

__all__ = ["AffineSystem", "StepForms"]


class StepForms(NamedTuple):
    """A step's equation as :class:`AffineSystem` takes it (docs/method.md section 8).

    Attributes:
        F: The residual; its cell integrals are affine in the unknown.
        J: Its Jacobian (``ufl.derivative(F, u)`` when None).
        activity: A linear form with one non-negative value per cell (a DG0 test
            function), zero on the cells where the facet terms are inactive: affine in
            the unknown, with a Jacobian that does not change. For contact, the normal
            force ``int [P_gamma(u)]_+ q``. While it is zero on every cell, the facet
            Jacobian is not assembled again.
        facet_parts: With ``activity``: the facet terms of F as (affine part, force part),
            whose sum they are; the force part vanishes, with its Jacobian, wherever the
            activity is zero. The affine part's constant Jacobian is then assembled once
            with the cell terms, and the force part's near the contact.
        state: The Functions other than the unknown in which the cell terms are affine and
            which change between solves (the state of the time level): the constant part
            of the residual is then a product with a matrix per Function.
        coupling: The coupling of contact pairs
            (:class:`~nitsche_dolfinx.assembly.pair_coupling.PairCoupling`), or None.
    """

    F: ufl.Form
    J: ufl.Form | None = None
    activity: ufl.Form | None = None
    facet_parts: tuple | None = None
    state: tuple = ()
    coupling: Any = None


def _derivative(form: ufl.Form, unknown, trial, degrees: dict) -> ufl.Form:
    """The derivative of ``form`` in ``unknown``, on facet quadratures of ``degrees``."""
    return with_facet_quadrature(expand_derivatives(ufl.derivative(form, unknown, trial)), degrees)


def _split_pairing_terms(form: ufl.Form, coupling) -> tuple[ufl.Form | None, ufl.Form | None]:
    """The integrals of ``form`` that hold no Function of a contact pair's pairing (its
    normal, its gap vector) and those that do (None if none); all in the first without
    ``coupling``."""
    if coupling is None:
        return form, None
    pairing = coupling.pairing_functions()
    fixed, paired = [], []
    for integral in form.integrals():
        held = set(extract_coefficients(integral.integrand()))
        (paired if held & pairing else fixed).append(integral)
    return (ufl.Form(fixed) if fixed else None), (ufl.Form(paired) if paired else None)


class AffineSystem(SystemBase):
    """F(x) = K x + F_cell(0) + F_facet(x) with the Jacobian J = K_bc + B (docs/method.md
    section 8): ``K`` the constant Jacobian of the cell terms (``K_bc`` with the Dirichlet
    rows and columns replaced by the identity and the affine facet terms added), B the
    :class:`~nitsche_dolfinx.assembly.facet_jacobian.FacetJacobian`.

    Args:
        forms: The :class:`StepForms`.
        u: The unknown Function.
        bcs: Dirichlet conditions.
        mass_diagonal: A diagonal matrix (vector) added to the problem (a lumped mass).
        matrix_type: The PETSc type of K, K_bc, B and the Jacobian (None: AIJ).
    """

    def __init__(self, forms: StepForms, u, bcs=(), mass_diagonal=None, matrix_type=None):
        super().__init__(forms.F, u, bcs, forms.J, mass_diagonal)
        F_cell, F_facet = split_cell_integrals(forms.F)
        J_cell, J_facet = split_cell_integrals(self.J)
        if F_cell is None or J_cell is None:
            raise ValueError("an affine system needs cell integrals in F and J")
        self.F_cell = Forms(F_cell)
        self.F_facet = Forms(F_facet) if F_facet is not None else None
        self._J_cell = self._J_constant = Forms(J_cell)  # the constant terms of J: K_bc's
        self._J_pairs = None  # those of them that a new pairing changes (contact pairs)
        constant, degrees, facets = J_cell, None, None
        if forms.facet_parts is not None and J_facet is not None and forms.activity is not None:
            degrees = facet_quadrature_degrees(J_facet)
            trial = self.J.arguments()[1]
            affine, force = (_derivative(part, u, trial, degrees) for part in forms.facet_parts)
            if not affine.empty():
                constant = J_cell + affine
                fixed, paired = _split_pairing_terms(affine, forms.coupling)
                self._J_constant = Forms(J_cell + fixed if fixed is not None else J_cell)
                if paired is not None:
                    self._J_pairs = Forms(paired)
            facets = ContactFacets.of_form(u.function_space.mesh, force)
            J_facet = force
        self._constants = constant.constants()  # those of K_bc: see constants_changed
        self._constants_key = None
        self._pairings_key = None
        # K_bc on the whole sparsity of J: PETSc keeps only the entries assembled into
        # a new matrix, so J is assembled once to set them (and zeroed by update_K)
        self.K_bc = self.J_forms.create_matrix(matrix_type)
        self.J_forms.assemble_matrix(self.K_bc)
        self.K_bc.assemble()
        # with contact pairs, K_bc = K_static + K_pairs: a new pairing assembles K_pairs,
        # the pairs' affine facet terms (they hold the pairs' normals), and adds it to
        # K_static, the rest of K_bc, assembled only when a constant changes
        self.K_static, self.K_pairs = self.K_bc, None
        if self._J_pairs is not None:
            self.K_static = self.K_bc.duplicate()
            self.K_pairs = self._J_pairs.create_matrix(matrix_type)
            # (the Dirichlet rows' zero diagonal, which its sparsity may lack)
            self.K_pairs.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
        # without Dirichlet conditions or facet terms in K_bc, K is K_bc: one matrix less
        separate = self.bcs or constant is not J_cell
        self.K = self._J_cell.create_matrix(matrix_type) if separate else self.K_bc
        self.facet = None
        if J_facet is not None:
            self.facet = FacetJacobian(
                J_facet, self.bcs, forms.activity, degrees, matrix_type, facets
            )
        self.sum = JacobianSum(self.K_bc, self.facet)
        self._at_zero = None
        self.coupling = forms.coupling
        self.update_K()
        if forms.state:
            self._at_zero = CellResidualAtZero(F_cell, u, forms.state, matrix_type)
        self.F0 = compat.create_vector(F_cell.arguments()[0].ufl_function_space())
        self._Kx = self.F0.duplicate()
        #: Skip the facet Jacobian while the activity is zero everywhere; False assembles
        #: it at every evaluation (the reference the skip is checked by).
        self.skip_inactive_facets = True
        #: Whether the facet terms were inactive everywhere at the last Jacobian.
        self.inactive = False
        self._known = False  # whether the Jacobian without facet terms was given out

    def create_matrix(self, matrix_type: str | None = None) -> PETSc.Mat:
        """A matrix with the sparsity of J: a copy of the structure of K_bc (zero)."""
        return self._matrix_options(self.K_bc.duplicate())

    def update_K(self) -> None:
        """Assemble K and K_bc for the current coefficients (the constant terms: again only
        when a constant in them changes, such as the time step)."""
        self._refresh_diagonal()
        pairs = [(self.K_static, self._J_constant, self.bcs, self._D_bc)]
        if self.K is not self.K_bc:
            pairs.append((self.K, self._J_cell, [], self._D))
        for matrix, forms, bcs, D in pairs:
            matrix.zeroEntries()
            forms.assemble_matrix(matrix, bcs, 1.0)
            matrix.assemble()
            if D is not None:  # a diagonal (lumped) mass belongs to the constant cell terms
                matrix.setDiagonal(D, addv=PETSc.InsertMode.ADD)
                matrix.assemble()
        if self._at_zero is not None:
            self._at_zero.update()
        self._constants_key = self._key()
        self.update_pairs(everywhere=True)

    def update_pairs(self, everywhere: bool = False) -> None:
        """K_bc = K_static + K_pairs for the current pairings of the contact pairs (only
        K_pairs, their affine facet terms, is assembled again; without pairs, K_bc is
        K_static). Unless K_static changed too (``everywhere``), the next Jacobian is set
        again on K_pairs' rows only (with those where B changed)."""
        rows = None
        if self.K_pairs is not None:
            self.K_pairs.zeroEntries()
            self._J_pairs.assemble_matrix(self.K_pairs, self.bcs, 0.0)
            self.K_pairs.assemble()
            self.K_static.copy(self.K_bc, PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
            self.K_bc.axpy(1.0, self.K_pairs, PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
            rows = np.flatnonzero(np.diff(self.K_pairs.getValuesCSR()[0]) > 0)
        self.sum.constant_changed(None if everywhere else rows)
        self._pairings_key = self._pairings()

    def _key(self) -> tuple:
        key = tuple(np.asarray(constant.value).tobytes() for constant in self._constants)
        return key if self._damped is None else (*key, *self._damped.key())

    def _pairings(self) -> tuple:
        """The pairings of the contact pairs: a new one changes the pair's normal, and with
        it the pairs' affine facet terms in K_bc."""
        return () if self.coupling is None else self.coupling.pairings()

    def constants_changed(self) -> bool:
        """Whether a constant of K_bc (the time step, gamma0, Theta, a material constant)
        or the pairing of a contact pair has another value than at the last
        :meth:`update_K` or :meth:`update_pairs`."""
        return self._key() != self._constants_key or self._pairings() != self._pairings_key

    @property
    def facet_terms_active(self) -> bool:
        return not self.inactive

    def new_coefficients(self) -> None:
        """Before a solve: the constant part F_cell(0) of the cell terms for the state of
        the time level, and the partners of the state across contact pairs."""
        self._cell_residual_at_zero()
        if self._damped is not None:
            self._damped.add_offset(self.F0)
        if self.coupling is not None:
            self.coupling.update()

    def update_constant_terms(self) -> None:
        """Assemble again the constant Jacobian after a constant in it changed (the time
        step), or only its pairs' part after a new pairing; the next Jacobian is then
        summed and factorised anew."""
        if self._key() != self._constants_key:
            self.update_K()
        else:
            self.update_pairs()
        self.forget_jacobian()

    def forget_jacobian(self) -> None:
        """Make the next Jacobian assemble B and count as changed."""
        if self.facet is not None:
            self.facet.forget()
        self._known = False

    def _cell_residual_at_zero(self) -> None:
        """F_cell(0) for the current coefficients (with the state: by matrix-vector
        products; else assembled with u = 0, u being restored)."""
        if self._at_zero is not None:
            self._at_zero.assemble(self.F0)
            return
        saved = self.u.x.array.copy()
        self.u.x.array[:] = 0.0
        with self.F0.localForm() as local:
            local.set(0.0)
        self.F_cell.assemble_vector(self.F0)
        self.F0.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        self.u.x.array[:] = saved

    def assemble_residual(
        self, x: PETSc.Vec, b: PETSc.Vec, zero: bool = False, conditions: bool = True
    ) -> None:
        """b = F(x) = K x + F_cell(0) + F_facet(x) (``zero``: x is zero, K x is skipped;
        ``conditions``: the Dirichlet rows replaced by x - g, else F's own)."""
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        if self.coupling is not None:
            self.coupling.update(x)
        x.copy(compat.petsc_vector(self.u))
        self.u.x.scatter_forward()
        with b.localForm() as b_local:
            b_local.set(0.0)
        if self.F_facet is not None:
            self.F_facet.assemble_vector(b)
        self._lift(x, b, conditions)
        if zero:
            b.axpy(1.0, self.F0)
        else:
            self.K.multAdd(x, self.F0, self._Kx)
            b.axpy(1.0, self._Kx)
        if self.coupling is not None:
            self.coupling.add_residual(b)
        if conditions:
            compat.set_bc(b, self.bcs, x, -1.0)

    def update_jacobian(self, A: PETSc.Mat, P: PETSc.Mat | None = None) -> bool:
        """A = K_bc + B (+ the coupling) if the terms changed since the last Jacobian (always
        the first time); True if they did. The coupling's growth widens A and P."""
        self.grew = False
        if not self._terms_changed(A, P):
            return False
        # every Jacobian is K_bc + B, summed in that order: a run restarted from a
        # checkpoint then factorises bit for bit the matrices of the uninterrupted run
        # (the coupling's terms are added afterwards, on rows of their own too)
        if self.coupling is None:
            self.sum.sum_into(A)
        else:
            self.sum.sum_into(A, reset=self.coupling.entries)
            self.coupling.add_jacobian(A)
        return True

    def _terms_changed(self, A: PETSc.Mat, P: PETSc.Mat | None) -> bool:
        """Assemble the Jacobian's non-constant terms (facets, coupling between bodies);
        True if any differs from the last assembly."""
        if self.facet is None:  # no facet terms: the Jacobian never changes
            changed, self._known = not self._known, True
            return changed
        changed = self.facet.update(self.skip_inactive_facets)
        self.inactive = self.facet.inactive
        if self.coupling is not None:  # zero where the facet terms are inactive
            inactive = self.skip_inactive_facets and self.facet.inactive
            active_cells = self.facet.active_cells()
            changed = self.coupling.jacobian_changed(inactive, active_cells) or changed
            if self.coupling.growth is not None:  # pairs in contact for the first time
                self.sum.widen(self.coupling.growth, [m for m in (A, P) if m is not None])
                self.grew = True
        return changed

    @property
    def facet_jacobian_assemblies(self) -> int | None:
        """How many times the facet (contact) Jacobian was assembled."""
        return self.facet.assemblies if self.facet is not None else 0

    def petsc_objects(self) -> list:
        """The PETSc objects the system made, for the solver to destroy: K_bc, K (and
        K_static, K_pairs with contact pairs), the vectors F_cell(0) and K x, and those of
        B, of :class:`~nitsche_dolfinx.assembly.forms.CellResidualAtZero` and of the coupling."""
        objects = [self.K_bc, self.F0, self._Kx]
        if self.K_pairs is not None:
            objects += [self.K_static, self.K_pairs]
        if self.K is not self.K_bc:
            objects.append(self.K)
        if self.facet is not None:
            objects += self.facet.petsc_objects()
        if self._at_zero is not None:
            objects += self._at_zero.petsc_objects()
        if self.coupling is not None:
            objects += self.coupling.petsc_objects()
        return objects
