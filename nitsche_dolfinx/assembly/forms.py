"""Compiled forms and the small assembly tools of the systems a Newton solver works on
(:mod:`nitsche_dolfinx.assembly.systems`, docs/method.md section 8).

- :class:`Forms`: a UFL form compiled once, with the assembly operations the systems use;
- :func:`split_cell_integrals`, :func:`facet_quadrature_degrees`,
  :func:`with_facet_quadrature`: the parts of a form and their quadratures;
- :class:`CellResidualAtZero`: the cell residual at a zero unknown as matrix-vector
  products with the state of the time level;
- :class:`CouplingEntries`, :func:`csr_pointers`, :func:`add_diagonal_product`: sparse
  entries and diagonal products.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from petsc4py import PETSc
from ufl.algorithms import compute_form_data, expand_derivatives

from ..common import compat

__all__ = [
    "CellResidualAtZero",
    "CouplingEntries",
    "Forms",
    "add_diagonal_product",
    "csr_pointers",
    "facet_quadrature_degrees",
    "split_cell_integrals",
    "with_facet_quadrature",
]


def split_cell_integrals(form: ufl.Form) -> tuple[ufl.Form | None, ufl.Form | None]:
    """Split a form into its cell integrals and its other (facet) integrals; None if empty."""
    cell = [i for i in form.integrals() if i.integral_type() == "cell"]
    rest = [i for i in form.integrals() if i.integral_type() != "cell"]
    return (ufl.Form(cell) if cell else None), (ufl.Form(rest) if rest else None)


class Forms:
    """A UFL form compiled once, with the assembly operations the solver applies to it."""

    def __init__(self, form: ufl.Form, compiled=None):
        self.ufl = form
        self.form = fem.form(form) if compiled is None else compiled

    def on_facets(self, facets: np.ndarray, ids: np.ndarray) -> Forms:
        """The form, whose integrals are exterior facet integrals, on the facets ``facets``
        (sorted) with the subdomain ids ``ids`` instead: its compiled kernels are used
        again (:func:`~nitsche_dolfinx.common.compat.form_on_facets`)."""
        return Forms(self.ufl, compat.form_on_facets(self.form, self.ufl, facets, ids))

    def assemble_vector(self, b: PETSc.Vec) -> None:
        """Add the form to the (local form of the) vector ``b``."""
        fem_petsc.assemble_vector(b, self.form)

    def assemble_matrix(self, A: PETSc.Mat, bcs=(), diagonal: float = 1.0) -> None:
        """Add the form to ``A``; Dirichlet rows get ``diagonal``."""
        fem_petsc.assemble_matrix(A, self.form, list(bcs), diagonal)

    def apply_lifting(self, b: PETSc.Vec, bcs, x0, alpha: float) -> None:
        """Lifting of the Dirichlet values."""
        compat.apply_lifting(b, self.form, bcs, x0, alpha)

    def create_matrix(self, matrix_type: str | None = None) -> PETSc.Mat:
        """A matrix with the sparsity of the form, of PETSc type ``matrix_type`` (AIJ)."""
        return compat.create_matrix(self.form, matrix_type)


def facet_quadrature_degrees(form: ufl.Form) -> dict:
    """The quadrature degree FFCx gives each exterior facet integral of ``form`` (the
    degree UFL estimates for it), by subdomain id."""
    data = compute_form_data(
        form,
        do_apply_function_pullbacks=True,
        do_apply_integral_scaling=True,
        do_apply_geometry_lowering=True,
        preserve_geometry_types=(ufl.classes.Jacobian,),
        do_apply_restrictions=True,
        do_append_everywhere_integrals=False,
    )
    degrees = {}
    for integral_data in data.integral_data:
        if integral_data.integral_type == "exterior_facet":
            for integral in integral_data.integrals:
                degree = integral.metadata().get("quadrature_degree")
                if degree is None or degree < 0:
                    degree = integral.metadata()["estimated_polynomial_degree"]
                ids = integral_data.subdomain_id
                for key in ids if isinstance(ids, (tuple, list)) else (ids,):
                    degrees[key] = max(degrees.get(key, 0), int(np.max(degree)))
    return degrees


def with_facet_quadrature(form: ufl.Form, degrees: dict) -> ufl.Form:
    """``form`` with its exterior facet integrals on subdomain ``i`` computed by the
    quadrature of degree ``degrees[i]`` (the others as they are)."""
    integrals = []
    for integral in form.integrals():
        degree = degrees.get(integral.subdomain_id())
        if integral.integral_type() == "exterior_facet" and degree is not None:
            metadata = {**integral.metadata(), "quadrature_degree": degree}
            integral = integral.reconstruct(metadata=metadata)
        integrals.append(integral)
    return ufl.Form(integrals)


class CouplingEntries(NamedTuple):
    """Entries of a matrix on some of its owned rows, in CSR form: the global ``rows``,
    the row pointers ``indptr`` and the global ``columns`` (PETSc's integer type)."""

    rows: np.ndarray
    indptr: np.ndarray
    columns: np.ndarray


def csr_pointers(lengths) -> np.ndarray:
    """CSR row pointers of rows of ``lengths`` entries (PETSc's integer type)."""
    return np.concatenate(([0], np.cumsum(lengths))).astype(PETSc.IntType)


def add_diagonal_product(b: PETSc.Vec, D: PETSc.Vec, x: PETSc.Vec) -> None:
    """b += D x for a diagonal matrix D given as a vector (owned entries)."""
    product = D.duplicate()
    product.pointwiseMult(D, x)
    b.axpy(1.0, product)
    product.destroy()


class CellResidualAtZero:
    """F_cell(0), the cell terms of a residual at a zero unknown, without a cell assembly.

    The cell terms are affine in the unknown and in the ``state`` functions (at a time
    step: u^n, v^n, a^n), with coefficients that change only with :meth:`update`, so
    ``F_cell(0) = F_cell(0)|_{state = 0} + sum_s (dF_cell / ds) s``: one matrix per state
    function that appears in them, assembled by :meth:`update`, and the rest (the loads)
    assembled again only when the values of its constants change (or at each call if it
    holds Functions). On P2 cells of second order, a cell assembly costs about 25
    matrix-vector products (docs/method.md section 8).
    """

    def __init__(self, F_cell: ufl.Form, unknown: fem.Function, state, matrix_type=None):
        V = unknown.function_space
        trial = ufl.TrialFunction(V)
        zeros = {f: ufl.zero(*f.ufl_shape) for f in (unknown, *state)}
        rest = ufl.replace(F_cell, zeros)
        self._rest = None if rest.empty() else Forms(rest)
        self._rest_vector = compat.create_vector(V)
        # with constants only, the rest changes only with their values
        self._constants = None if rest.empty() or rest.coefficients() else rest.constants()
        self._rest_key = None
        self._terms = []  # (Forms, matrix, state function)
        for function in state:
            derivative = expand_derivatives(ufl.derivative(F_cell, function, trial))
            if not derivative.empty():
                forms = Forms(derivative)
                self._terms.append((forms, forms.create_matrix(matrix_type), function))
        self.update()

    @property
    def functions(self) -> list[fem.Function]:
        """The state functions that enter by matrix-vector products (the others are
        absent from the cell terms)."""
        return [function for _, _, function in self._terms]

    def update(self) -> None:
        """Assemble the matrices dF_cell / ds (again after a constant in them changed)."""
        for forms, matrix, _ in self._terms:
            matrix.zeroEntries()
            forms.assemble_matrix(matrix)
            matrix.assemble()

    def assemble(self, b: PETSc.Vec) -> None:
        """b = F_cell(0) at the current state (owned entries)."""
        key = None
        if self._constants is not None:
            key = tuple(np.asarray(constant.value).tobytes() for constant in self._constants)
        if key is None or key != self._rest_key:
            rest = self._rest_vector
            with rest.localForm() as local:
                local.set(0.0)
            if self._rest is not None:
                self._rest.assemble_vector(rest)
                rest.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
            self._rest_key = key
        self._rest_vector.copy(b)
        for _, matrix, function in self._terms:
            matrix.multAdd(compat.petsc_vector(function), b, b)

    def petsc_objects(self) -> list:
        """Its PETSc objects, for the system that holds it to destroy: the vector of the
        rest and the matrices dF_cell / ds."""
        return [self._rest_vector] + [matrix for _, matrix, _ in self._terms]
