"""The assembled pieces of a step's equation, for :class:`~nitsche_dolfinx.solver.SNESSolver`.

- :class:`Forms`: a UFL form compiled once, with the assembly operations the solver uses;
- :class:`AffineCellSplit`: the residual and Jacobian split into the cell integrals
  (affine in the unknown: linear elastodynamics, assembled once) and the facet
  integrals (the contact terms, re-assembled, and skipped while inactive);
- :class:`CellResidualAtZero`: the cell residual at a zero unknown as matrix-vector
  products with the state of the time level;
docs/method.md section 8.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import ufl
from dolfinx import fem
from dolfinx import mesh as dmesh
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc
from ufl.algorithms import compute_form_data, expand_derivatives

from . import compat
from .meshes import facet_cells, facet_vertices

__all__ = [
    "AffineCellSplit",
    "CellResidualAtZero",
    "ContactFacets",
    "CouplingEntries",
    "Forms",
    "add_diagonal_product",
    "csr_pointers",
    "pattern_matrix",
    "split_cell_integrals",
]

#: Forms restricted to the facets near contact are compiled again on fewer facets once
#: they are assembled on more than this many times the facets needed (plus a few).
_SHRINK = 2


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
        again (:func:`~nitsche_dolfinx.compat.form_on_facets`)."""
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


class ContactFacets:
    """The facets on which terms that vanish out of contact are assembled: those of the
    cells whose contact terms are active, with one ring of neighbours (facets sharing a
    vertex) as a margin, so that the set is made again only when the contact zone has
    moved beyond it, or when it holds more than :data:`_SHRINK` times the facets needed.
    All facets at first. A term that is exactly zero on the other facets has the same
    values to the bit on these (its sums lack only zeros), whatever their history.

    Args:
        mesh: The mesh.
        tags: The facet tags of the exterior facet integrals.
        ids: The tags of the facets (subdomain ids of the integrals).
    """

    def __init__(self, mesh, tags, ids):
        self._mesh = mesh
        chosen = np.isin(tags.values, np.asarray(list(ids)))
        order = np.argsort(tags.indices[chosen], kind="stable")
        self.facets = tags.indices[chosen][order].astype(np.int32)
        self._values = tags.values[chosen][order].astype(np.int32)
        self._cells = facet_cells(mesh, self.facets)
        self._vertices = facet_vertices(mesh, self.facets)
        self.current = np.ones(len(self.facets), dtype=bool)
        self.needed = None  # the facets of the cells in contact at the last update

    @classmethod
    def of_measure(cls, mesh, ds) -> ContactFacets:
        """The facets of the measure ``ds(tag)``."""
        return cls(mesh, ds.subdomain_data(), [ds.subdomain_id()])

    @classmethod
    def of_form(cls, mesh, form: ufl.Form) -> ContactFacets | None:
        """The facets of the exterior facet integrals of ``form``; None unless each has
        facet tags and an integer subdomain id (an integral over every facet has no
        tags to restrict)."""
        integrals = [i for i in form.integrals() if i.integral_type() == "exterior_facet"]
        ids = [integral.subdomain_id() for integral in integrals]
        if not integrals or not all(isinstance(i, (int, np.integer)) for i in ids):
            return None
        tags = integrals[0].subdomain_data()
        if tags is None or any(i.subdomain_data() is not tags for i in integrals):
            return None
        return cls(mesh, tags, set(ids))

    def update(self, active_cells: np.ndarray) -> bool:
        """Take the facets of ``active_cells`` and their neighbours when the contact has
        left the current ones, or uses few of them; True if the set changed."""
        needed = self.needed = active_cells[self._cells]
        marked = np.zeros(self._vertices.max(initial=-1) + 1, dtype=bool)
        marked[self._vertices[needed].ravel()] = True
        wanted = marked[self._vertices].any(axis=1) if len(self._vertices) else needed
        beyond = (needed & ~self.current).any()
        loose = self.current.sum() > _SHRINK * wanted.sum() + 8
        if beyond or loose:
            self.current = wanted
            return True
        return False

    def restrict(self, form: ufl.Form) -> ufl.Form:
        """``form`` with its exterior facet integrals over the current facets only (the
        same integrands: FFCx finds the compiled form in its cache)."""
        dim = self._mesh.topology.dim - 1
        tags = dmesh.meshtags(
            self._mesh, dim, self.facets[self.current], self._values[self.current]
        )
        integrals = [
            integral.reconstruct(subdomain_data=tags)
            if integral.integral_type() == "exterior_facet"
            else integral
            for integral in form.integrals()
        ]
        return ufl.Form(integrals)

    def compiled_on(self, forms: Forms, chosen: np.ndarray) -> Forms:
        """``forms``, compiled on all the facets, on the facets ``chosen`` (a mask, such as
        :attr:`current` or :attr:`needed`): no compilation."""
        return forms.on_facets(self.facets[chosen], self._values[chosen])


class CouplingEntries(NamedTuple):
    """Entries of a matrix on some of its owned rows, in CSR form: the global ``rows``,
    the row pointers ``indptr`` and the global ``columns`` (PETSc's integer type)."""

    rows: np.ndarray
    indptr: np.ndarray
    columns: np.ndarray


def csr_pointers(lengths) -> np.ndarray:
    """CSR row pointers of rows of ``lengths`` entries (PETSc's integer type)."""
    return np.concatenate(([0], np.cumsum(lengths))).astype(PETSc.IntType)


def pattern_matrix(entries: CouplingEntries, like: PETSc.Mat) -> PETSc.Mat:
    """A zero matrix of the type, sizes and block size of ``like`` holding ``entries``
    (for a blocked type, the whole blocks they fall in): the pattern to widen ``like`` by."""
    comm, sizes = like.getComm(), like.getSizes()
    bs = like.getBlockSize() if "baij" in like.getType() else 1
    first = like.getOwnershipRange()[0]
    counts = np.diff(entries.indptr)
    rows = np.repeat((np.asarray(entries.rows) - first) // bs, counts).astype(np.int64)
    columns = np.asarray(entries.columns, dtype=np.int64) // bs
    width = sizes[1][1] // bs
    keys = np.unique(rows * width + columns)
    blocks_per_row = np.bincount(keys // width, minlength=sizes[0][0] // bs)
    csr = (
        csr_pointers(blocks_per_row),
        (keys % width).astype(PETSc.IntType),
        np.zeros(len(keys) * bs * bs),
    )
    matrix = PETSc.Mat()
    if bs > 1:
        matrix.createBAIJ(sizes, bs, comm=comm)
    else:
        matrix.createAIJ(sizes, comm=comm)
    matrix.setPreallocationCSR(csr)
    return matrix


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
        return [self._rest_vector] + [matrix for _, matrix, _ in self._terms]


def _ranges(indptr: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The positions of the entries of CSR ``rows`` (``indptr`` their pointers) and the
    length of each row."""
    starts, lengths = indptr[rows], indptr[rows + 1] - indptr[rows]
    offsets = np.concatenate(([0], np.cumsum(lengths)[:-1]))
    positions = np.repeat(starts - offsets, lengths) + np.arange(lengths.sum())
    return positions.astype(np.int64), lengths


def _jacobian(form: ufl.Form, unknown, trial, degrees: dict) -> ufl.Form:
    """The derivative of ``form`` in ``unknown``, on facet quadratures of ``degrees``."""
    return with_facet_quadrature(expand_derivatives(ufl.derivative(form, unknown, trial)), degrees)


class AffineCellSplit:
    """The cell terms of an affine-in-the-bulk problem, assembled once, and the facet terms.

    The residual is ``F(x) = K x + F_cell(0) + F_facet(x)`` and the Jacobian
    ``J = K_bc + B``, where ``K`` is the constant Jacobian of the cell terms (``K_bc``:
    with the Dirichlet rows and columns replaced by the identity; ``K`` itself without
    Dirichlet conditions) and ``B`` the facet Jacobian. ``K_bc`` lives on the sparsity
    of J (``J_forms``), of PETSc type ``matrix_type``, and B on the sparsity of the facet
    terms alone (the cells at Gamma_C): summing them is a copy of K_bc and an addition
    over B's entries.

    With ``facet_parts`` (docs/method.md section 8), the facet terms of F are the sum of
    an affine part, whose constant Jacobian joins K_bc, and a part that vanishes with its
    Jacobian wherever ``activity`` is zero (the contact force terms): B is then that
    part's Jacobian alone, on the sparsity of the facets of the cells in contact and a
    ring of neighbours (:class:`ContactFacets`), assembled on those of the cells in
    contact, and each sum sets back only the rows where B is nonzero now or was at the
    last sum.

    Args:
        F, J: The residual and its Jacobian (UFL forms).
        J_forms: J compiled (:class:`Forms`).
        bcs: Dirichlet conditions.
        D, D_bc: A diagonal matrix (vector) added to the problem, and the same with
            zero Dirichlet rows (a lumped mass).
        activity: The facet activity of :class:`~nitsche_dolfinx.solver.SNESSolver`.
        unknown, state: With ``state`` (Functions in which the cell terms are affine),
            F_cell(0) by :class:`CellResidualAtZero`; else by a cell assembly.
        matrix_type: The PETSc type of K, K_bc and B (None: AIJ).
        facet_parts: With ``activity`` and ``unknown``: (affine part, force part) of the
            facet terms of F, whose sum they are.
    """

    def __init__(
        self,
        F: ufl.Form,
        J: ufl.Form,
        J_forms,
        bcs,
        D=None,
        D_bc=None,
        activity=None,
        unknown=None,
        state=(),
        matrix_type=None,
        facet_parts=None,
    ):
        self.bcs = bcs
        F_cell, F_facet = split_cell_integrals(F)
        J_cell, J_facet = split_cell_integrals(J)
        if F_cell is None or J_cell is None:
            raise ValueError("affine_cell_terms needs cell integrals in F and J")
        self.F_cell = Forms(F_cell)
        self.F_facet = Forms(F_facet) if F_facet is not None else None
        self._J_cell, self._D, self._D_bc = Forms(J_cell), D, D_bc
        self._J_constant = self._J_cell  # the constant terms of J (K_bc)
        constant = J_cell
        self._facets = None  # the ContactFacets that B is assembled on (None: all)
        degrees = None
        if facet_parts is not None and J_facet is not None and activity is not None:
            degrees = facet_quadrature_degrees(J_facet)
            trial = J.arguments()[1]
            affine, force = (_jacobian(part, unknown, trial, degrees) for part in facet_parts)
            if not affine.empty():
                constant = J_cell + affine
                self._J_constant = Forms(constant)
            self._facets = ContactFacets.of_form(unknown.function_space.mesh, force)
            J_facet = force
        self.J_facet = Forms(J_facet) if J_facet is not None else None
        self._J_all = self.J_facet  # on all the facets: B's sparsity comes from J_facet
        self._on_needed = None  # (facets, J_facet on them) of the last assembly of B
        self._constants = constant.constants()  # those of K_bc: see constants_changed
        self._constants_key = None
        self._matrix_type = matrix_type  # of B too: blocked insertion is faster
        # K_bc on the whole sparsity of J: PETSc keeps only the entries assembled into
        # a new matrix, so J is assembled once to set them (and zeroed by update_K)
        self.K_bc = J_forms.create_matrix(matrix_type)
        J_forms.assemble_matrix(self.K_bc)
        self.K_bc.assemble()
        # without Dirichlet conditions or facet terms in K_bc, K is K_bc: one matrix less
        separate = bcs or self._J_constant is not self._J_cell
        self.K = self._J_cell.create_matrix(matrix_type) if separate else self.K_bc
        self._at_zero = None
        self._B_rows = None  # the local rows of B with entries and of the entries reset
        self._widened = False  # whether the Jacobian has entries beyond K_bc's
        self.update_K()
        if state:
            self._at_zero = CellResidualAtZero(F_cell, unknown, state, matrix_type)
        self.F0 = compat.create_vector(F_cell.arguments()[0].ufl_function_space())
        self._Kx = self.F0.duplicate()
        self.B = None
        self._B_known = False  # whether B holds a facet Jacobian to compare the next with
        self._former = None  # the nonzero entries of that Jacobian if B was made since
        self._in_A = None  # B's values in the matrix of the last sum (None: another B's)
        self._stale = np.zeros(0, dtype=np.int64)  # rows of A holding values of a former B
        if self.J_facet is not None:
            self._make_B()
            # the rows where B can have entries, on any of the facets
            self._B_facet_rows = np.flatnonzero(np.diff(self._B_indptr) > 0)
        self.activity = None
        self._activity_fresh = False  # the activity of the last facet Jacobian is known
        if activity is not None and self.J_facet is not None:
            # with B's quadrature, the activity is nonzero on each cell where B is
            self.activity = fem.form(with_facet_quadrature(activity, degrees or {}))
            space = activity.arguments()[0].ufl_function_space()
            self._activity = compat.create_vector(space)
            self._activity_dofs = compat.dofmap_array(space)[:, 0]  # a value per cell
        self._inactive = False  # whether B was assembled with the facet terms inactive
        self.assemblies = 0  # of the facet Jacobian

    def update_K(self) -> None:
        """Assemble K and K_bc for the current coefficients (the constant terms: again only
        when a constant in them changes, such as the time step)."""
        pairs = [(self.K_bc, self._J_constant, self.bcs, self._D_bc)]
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
        self._summed_into, self._K_rows = None, None  # A = K_bc + B in full next time
        self._constants_key = self._key()

    def _key(self) -> tuple:
        return tuple(np.asarray(constant.value).tobytes() for constant in self._constants)

    def constants_changed(self) -> bool:
        """Whether a constant of K_bc (the time step, gamma0, Theta, a material constant)
        has another value than at the last :meth:`update_K`."""
        return self._key() != self._constants_key

    def update_cell_residual(self, u: fem.Function) -> None:
        """F_cell(0) for the current coefficients (with the state: by matrix-vector
        products; else assembled with u = 0, u being restored)."""
        if self._at_zero is not None:
            self._at_zero.assemble(self.F0)
            return
        saved = u.x.array.copy()
        u.x.array[:] = 0.0
        with self.F0.localForm() as local:
            local.set(0.0)
        self.F_cell.assemble_vector(self.F0)
        self.F0.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        u.x.array[:] = saved

    def add_cell_residual(self, x: PETSc.Vec | None, b: PETSc.Vec) -> None:
        """b += K x + F_cell(0) on the owned entries (x None: x = 0)."""
        if x is None:
            b.axpy(1.0, self.F0)
            return
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
        self._activity.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        self._activity_fresh = True
        return self._activity.norm(PETSc.NormType.NORM_INFINITY) == 0.0

    def active_cells(self) -> np.ndarray | None:
        """Whether each local cell (owned and ghost) has facet terms that are active at
        the iterate of the last :meth:`facet_jacobian_changed` (a nonzero activity);
        None if that call did not evaluate the activity."""
        if not self._activity_fresh:
            return None
        with self._activity.localForm() as local:
            return local.array_r[self._activity_dofs] > 0.0

    @property
    def inactive(self) -> bool:
        """Whether the facet activity was zero on every cell at the last
        :meth:`facet_jacobian_changed` (False without an activity form)."""
        return self._inactive

    def facet_jacobian_changed(self, skip_inactive: bool = True) -> bool:
        """Assemble the facet Jacobian (unless it is inactive now and was at the last
        assembly, and ``skip_inactive``); True if it differs from the last one."""
        if self.B is None:  # no facet terms: the Jacobian never changes
            first, self._B_known = not self._B_known, True
            return first
        self._activity_fresh = False
        inactive = skip_inactive and self.facet_terms_inactive()
        if inactive and self._inactive and self._B_known:
            return False  # inactive now and at the last assembly: the same Jacobian
        self._inactive = inactive
        self.assemblies += 1
        before = self._B_values
        if self._facets is None or not self._restrict():  # (else B is made, assembled)
            self.B.zeroEntries()
            self._facet_terms().assemble_matrix(self.B, self.bcs, 0.0)
            self.B.assemble()
            self._B_values = self.B.getValuesCSR()[2]
        if self._former is None:  # the same sparsity: the same values
            same = self._B_known and np.array_equal(self._B_values, before)
        else:  # the nonzero entries in the same places, with the same values
            same = self._B_known and all(map(np.array_equal, self._nonzero_entries(), self._former))
        self._former, self._B_known = None, True
        return self.B.getComm().tompi4py().allreduce(not same, op=MPI.LOR)

    def _make_B(self) -> None:
        """Make B on the sparsity of the facet terms now compiled, assembled, with its
        CSR structure and the row of each entry; its values are read after each assembly."""
        if self.B is not None:  # the rows of A holding its values are set again
            self._stale = np.union1d(self._stale, self._rows_in_A())
            self._former = self._nonzero_entries()  # to compare the next B with
            self.B.destroy()
        self._in_A = None
        self.B = self.J_facet.create_matrix(self._matrix_type)
        # on all of J_facet's facets: PETSc keeps only the entries assembled into a new B
        self.J_facet.assemble_matrix(self.B, self.bcs, 0.0)
        self.B.assemble()
        self._B_indptr, self._B_columns, self._B_values = self.B.getValuesCSR()
        lengths = np.diff(self._B_indptr)
        self._B_entry_rows = np.repeat(np.arange(len(lengths)), lengths)
        self._B_in_K = None  # see _rows_of_K

    def _facet_terms(self) -> Forms:
        """The facet Jacobian on the facets of the cells in contact at the iterate (taken
        by :meth:`_restrict`; J_facet before it): the force terms are zero on the others,
        so B gets the values it gets on all of J_facet's facets, to the bit (its sums lack
        only zeros), for a fraction of the work."""
        return self.J_facet if self._on_needed is None else self._on_needed[1]

    def _nonzero_entries(self) -> tuple[np.ndarray, np.ndarray]:
        """B's nonzero entries: their local rows and global columns (together, their
        place whatever B's sparsity), and their values."""
        nonzero = self._B_values != 0.0
        width = np.int64(self.B.getSize()[1])
        keys = self._B_entry_rows[nonzero] * width + self._B_columns[nonzero]
        return keys, self._B_values[nonzero]

    def _rows_in_A(self) -> np.ndarray:
        """The local rows where the matrix of the last sum holds nonzero values of B."""
        if self._in_A is None:
            return np.zeros(0, dtype=np.int64)
        return self._nonzero_rows(self._in_A)

    def _nonzero_rows(self, values: np.ndarray) -> np.ndarray:
        """The local rows of B where ``values`` (of B's entries) are nonzero."""
        return np.unique(self._B_entry_rows[values != 0.0])

    def forget_facet_jacobian(self) -> None:
        """Make the next :meth:`facet_jacobian_changed` assemble B and report a change."""
        self._B_known = False

    def _restrict(self) -> bool:
        """Follow the contact of the iterate: when it has moved beyond the facets of B's
        sparsity or left most of them, make B on the facets near it, assembled at the
        iterate, and return True; when the facets of the cells in contact changed on a
        rank, take them for B's assembly (:meth:`_facet_terms`). Collective: the ranks
        make B and the forms together (dolfinx may make a facet form collectively)."""
        if not self._activity_fresh:
            self.facet_terms_inactive()
        changed = self._facets.update(self.active_cells())
        needed = self._facets.needed
        moved = self._on_needed is None or not np.array_equal(self._on_needed[0], needed)
        flags = np.array([changed, moved], dtype=np.int32)
        self.B.getComm().tompi4py().Allreduce(MPI.IN_PLACE, flags, op=MPI.MAX)
        if flags[1]:
            self._on_needed = (needed, self._facets.compiled_on(self._J_all, needed))
        if flags[0]:
            self.J_facet = self._facets.compiled_on(self._J_all, self._facets.current)
            self._make_B()  # on their sparsity: its work scales with them
            return True
        return False

    def sum_into(self, A: PETSc.Mat, reset: CouplingEntries | None = None) -> None:
        """A = K_bc + B, A on the sparsity of K_bc (which holds B's) or a wider one
        (:meth:`widen`). In full the first time after :meth:`update_K`; then only the
        rows where B differs from the B of the last sum are set again, to K_bc's values
        plus B's (the other rows hold them already). ``reset``: entries where terms are
        added to A after this sum (the coupling between two bodies), set back to zero
        first, their rows set again with the others. Each entry is K_bc's value plus
        B's, so the same to the bit as a sum in full."""
        if self.B is None:
            self.K_bc.copy(A, PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
            return
        values = self._B_values
        if self._summed_into != A.handle:  # (petsc4py wraps A anew at each callback)
            self._stale = np.zeros(0, dtype=np.int64)
            if self._widened:  # A has entries beyond K_bc's: zero there
                A.zeroEntries()
                A.axpy(1.0, self.K_bc, PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
            else:
                self.K_bc.copy(A, PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
            A.axpy(1.0, self.B, PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
            self._summed_into, self._in_A = A.handle, values
            return
        if reset is not None and len(reset.columns):
            zeros = np.zeros(len(reset.columns))
            A.setValuesIJV(reset.indptr, reset.columns, zeros, PETSc.InsertMode.INSERT,
                           reset.rows)  # fmt: skip
        first = self.B.getOwnershipRange()[0]
        rows, indptr, columns, K_values, B_in_K = self._rows_of_K(reset)
        if self._in_A is None:  # B was made again since: its rows and those of the former
            changed = np.union1d(self._nonzero_rows(values), self._stale)
        else:
            changed = np.unique(self._B_entry_rows[values != self._in_A])
        if reset is not None and len(reset.rows):
            changed = np.union1d(changed, np.asarray(reset.rows) - first)
        chosen = np.searchsorted(rows - first, changed)
        entries, lengths = _ranges(indptr, chosen)
        summed = K_values[entries]
        B_entries, B_lengths = _ranges(self._B_indptr, changed)
        place = np.cumsum(lengths) - lengths - indptr[chosen]  # in summed, less the K entry
        summed[B_in_K[B_entries] + np.repeat(place, B_lengths)] += values[B_entries]
        A.setValuesIJV(csr_pointers(lengths), columns[entries], summed,
                       PETSc.InsertMode.INSERT, rows[chosen])  # fmt: skip
        A.assemble()
        self._in_A, self._stale = values, np.zeros(0, dtype=np.int64)

    def _rows_of_K(self, reset: CouplingEntries | None):
        """The rows of K_bc where B can have entries (on any facet) or ``reset`` has, in
        CSR form, with the place of each of B's entries among them: (global rows, row
        pointers, global columns, values, places). The rows are read again after
        :meth:`update_K` or when those of ``reset`` are not among them (the coupling grew
        onto new rows), the places when B is made again."""
        first = self.B.getOwnershipRange()[0]
        rows = self._B_facet_rows
        if reset is not None and len(reset.rows):
            rows = np.union1d(rows, np.asarray(reset.rows) - first)
        width = np.int64(self.B.getSize()[1])
        known = self._K_rows is not None and (
            rows is self._B_rows or np.isin(rows, self._B_rows).all()
        )
        if not known:
            self._B_rows = rows
            global_rows = (first + rows).astype(PETSc.IntType)
            entries = [self.K_bc.getRow(row) for row in global_rows]
            lengths = [len(columns) for columns, _ in entries]
            columns = np.concatenate([c for c, _ in entries] or [[]]).astype(PETSc.IntType)
            values = np.concatenate([v for _, v in entries] or [[]])
            keys = np.repeat(np.arange(len(rows), dtype=np.int64), lengths) * width + columns
            self._K_rows = (global_rows, csr_pointers(lengths), columns, values, keys)
            self._B_in_K = None
        global_rows, indptr, columns, values, keys = self._K_rows
        if self._B_in_K is None:
            # B's sparsity is within K_bc's, the columns of each row sorted: find each of
            # B's entries by its (row, column) key among those of these rows
            B_keys = np.searchsorted(self._B_rows, self._B_entry_rows) * width + self._B_columns
            self._B_in_K = np.searchsorted(keys, B_keys)
            if not np.array_equal(keys[np.minimum(self._B_in_K, len(keys) - 1)], B_keys):
                raise RuntimeError("the facet Jacobian has entries beyond the sparsity of K_bc")
        return global_rows, indptr, columns, values, self._B_in_K

    def widen(self) -> None:
        """Say that the Jacobian A now has entries beyond the sparsity of K_bc (the
        coupling between two bodies, added by the caller): a sum in full zeroes them."""
        self._widened = True

    def petsc_objects(self) -> list:
        objects = [self.K_bc, self.F0, self._Kx]
        if self.K is not self.K_bc:
            objects.append(self.K)
        if self.B is not None:
            objects.append(self.B)
        if self._at_zero is not None:
            objects += self._at_zero.petsc_objects()
        if self.activity is not None:
            objects.append(self._activity)
        return objects
