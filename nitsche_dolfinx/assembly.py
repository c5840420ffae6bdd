"""The assembled pieces of a step's equation, for :class:`~nitsche_dolfinx.solver.SNESSolver`.

- :class:`Forms`: a UFL form compiled once, with the assembly operations the solver uses;
- :class:`AffineCellSplit`: the residual and Jacobian split into the cell integrals
  (affine in the unknown: linear elastodynamics, assembled once) and the facet
  integrals (the contact terms, re-assembled, and skipped while inactive);
  docs/method.md section 8.
"""

from __future__ import annotations

import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from petsc4py import PETSc

from . import compat

__all__ = ["AffineCellSplit", "Forms", "add_diagonal_product", "split_cell_integrals"]


def split_cell_integrals(form: ufl.Form) -> tuple[ufl.Form | None, ufl.Form | None]:
    """Split a form into its cell integrals and its other (facet) integrals; None if empty."""
    cell = [i for i in form.integrals() if i.integral_type() == "cell"]
    rest = [i for i in form.integrals() if i.integral_type() != "cell"]
    return (ufl.Form(cell) if cell else None), (ufl.Form(rest) if rest else None)


class Forms:
    """A UFL form compiled once, with the assembly operations the solver applies to it."""

    def __init__(self, form: ufl.Form):
        self.form = fem.form(form)

    def assemble_vector(self, b: PETSc.Vec) -> None:
        """Add the form to the (local form of the) vector ``b``."""
        fem_petsc.assemble_vector(b, self.form)

    def assemble_matrix(self, A: PETSc.Mat, bcs=(), diagonal: float = 1.0) -> None:
        """Add the form to ``A``; Dirichlet rows get ``diagonal``."""
        fem_petsc.assemble_matrix(A, self.form, list(bcs), diagonal)

    def apply_lifting(self, b: PETSc.Vec, bcs, x0, alpha: float) -> None:
        """Lifting of the Dirichlet values."""
        compat.apply_lifting(b, self.form, bcs, x0, alpha)

    def create_matrix(self) -> PETSc.Mat:
        """A matrix with the sparsity of the form."""
        return fem_petsc.create_matrix(self.form)


def add_diagonal_product(b: PETSc.Vec, D: PETSc.Vec, x: PETSc.Vec) -> None:
    """b += D x for a diagonal matrix D given as a vector (owned entries)."""
    product = D.duplicate()
    product.pointwiseMult(D, x)
    b.axpy(1.0, product)
    product.destroy()


class AffineCellSplit:
    """The cell terms of an affine-in-the-bulk problem, assembled once, and the facet terms.

    The residual is ``F(x) = K x + F_cell(0) + F_facet(x)`` and the Jacobian
    ``J = K_bc + J_facet(x)``, where ``K`` is the constant Jacobian of the cell terms
    (``K_bc``: with the Dirichlet rows and columns replaced by the identity). ``K_bc``
    and the facet Jacobian live on the sparsity of J (``J_forms``), so that summing
    them is a copy and an addition of value arrays.
    """

    def __init__(self, F: ufl.Form, J: ufl.Form, J_forms, bcs, D=None, D_bc=None, activity=None):
        self.bcs = bcs
        F_cell, F_facet = split_cell_integrals(F)
        J_cell, J_facet = split_cell_integrals(J)
        if F_cell is None or J_cell is None:
            raise ValueError("affine_cell_terms needs cell integrals in F and J")
        self.F_cell = Forms(F_cell)
        self.F_facet = Forms(F_facet) if F_facet is not None else None
        self.J_facet = Forms(J_facet) if J_facet is not None else None
        self._J_cell, self._D, self._D_bc = Forms(J_cell), D, D_bc
        self.K = self._J_cell.create_matrix()
        # K_bc on the whole sparsity of J: PETSc keeps only the entries assembled into
        # a new matrix, so J is assembled once to set them (and zeroed by update_K)
        self.K_bc = J_forms.create_matrix()
        J_forms.assemble_matrix(self.K_bc)
        self.K_bc.assemble()
        self.update_K()
        self.F0 = compat.create_vector(F_cell.arguments()[0].ufl_function_space())
        self._Kx = self.F0.duplicate()
        self.B = self.K_bc.duplicate() if self.J_facet is not None else None  # zero values
        self.B_last = None
        self.activity = None
        if activity is not None and self.J_facet is not None:
            self.activity = fem.form(activity)
            self._activity = compat.create_vector(activity.arguments()[0].ufl_function_space())
        self._inactive = False  # whether B_last was assembled with the facet terms inactive
        self.assemblies = 0  # of the facet Jacobian

    def update_K(self) -> None:
        """Assemble K and K_bc for the current coefficients (the constant cell terms:
        again only when a constant in them changes, such as the time step)."""
        for matrix, bcs, D in ((self.K, [], self._D), (self.K_bc, self.bcs, self._D_bc)):
            matrix.zeroEntries()
            self._J_cell.assemble_matrix(matrix, bcs, 1.0)
            matrix.assemble()
            if D is not None:  # a diagonal (lumped) mass belongs to the constant cell terms
                matrix.setDiagonal(D, addv=PETSc.InsertMode.ADD)
                matrix.assemble()

    def update_cell_residual(self, u: fem.Function) -> None:
        """F_cell(0) for the current coefficients (assembled with u = 0; u is restored)."""
        saved = u.x.array.copy()
        u.x.array[:] = 0.0
        with self.F0.localForm() as local:
            local.set(0.0)
        self.F_cell.assemble_vector(self.F0)
        self.F0.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        u.x.array[:] = saved

    def add_cell_residual(self, x: PETSc.Vec, b: PETSc.Vec) -> None:
        """b += K x + F_cell(0) on the owned entries."""
        self.K.multAdd(x, self.F0, self._Kx)
        b.axpy(1.0, self._Kx)

    def facet_terms_inactive(self) -> bool:
        """Whether the facet activity is zero on every cell (collective; False without one)."""
        if self.activity is None:
            return False
        with self._activity.localForm() as local:
            local.set(0.0)
        fem_petsc.assemble_vector(self._activity, self.activity)
        self._activity.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        return self._activity.norm(PETSc.NormType.NORM_INFINITY) == 0.0

    @property
    def inactive(self) -> bool:
        """Whether the facet activity was zero on every cell at the last
        :meth:`facet_jacobian_changed` (False without an activity form)."""
        return self._inactive

    def facet_jacobian_changed(self, skip_inactive: bool = True) -> bool:
        """Assemble the facet Jacobian (unless it is inactive now and was at the last
        assembly, and ``skip_inactive``); True if it differs from the last one."""
        if self.B is None:  # no facet terms: the Jacobian never changes
            first, self.B_last = self.B_last is None, True
            return first
        inactive = skip_inactive and self.facet_terms_inactive()
        if inactive and self._inactive and self.B_last is not None:
            return False  # inactive now and at the last assembly: the same Jacobian
        self._inactive = inactive
        self.assemblies += 1
        self.B.zeroEntries()
        self.J_facet.assemble_matrix(self.B, self.bcs, 0.0)
        self.B.assemble()
        if self.B_last is not None and self.B.equal(self.B_last):
            return False
        if self.B_last is None:
            self.B_last = self.B.copy()
        else:
            self.B.copy(self.B_last, PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        return True

    def sum_into(self, A: PETSc.Mat) -> None:
        """A = K_bc + B (all three on the sparsity of J)."""
        same = PETSc.Mat.Structure.SAME_NONZERO_PATTERN
        self.K_bc.copy(A, same)
        if self.B is not None:
            A.axpy(1.0, self.B, same)

    def widen(self, pattern: PETSc.Mat) -> None:
        """Add the entries of ``pattern`` (zeros) to the sparsity of K_bc and B: terms of
        the Jacobian beyond the forms' sparsity (the coupling between two bodies)."""
        for matrix in (self.K_bc, self.B, self.B_last):
            if isinstance(matrix, PETSc.Mat):
                matrix.axpy(1.0, pattern, PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)

    def petsc_objects(self) -> list:
        objects = [self.K, self.K_bc, self.F0, self._Kx]
        objects += [m for m in (self.B, self.B_last) if isinstance(m, PETSc.Mat)]
        if self.activity is not None:
            objects.append(self._activity)
        return objects
