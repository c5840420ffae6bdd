"""The linear algebra of contact between two bodies (docs/method.md section 11): the
partner-tested residual T^T G and the Jacobian's coupling terms, for
:class:`~nitsche_dolfinx.systems.AffineSystem` (its ``coupling``).

With w~ = T w the partner of the unknown, the Jacobian of a pair is

    J = dF/dw + (dF/dw~) T + T^T (dG/dw) + T^T (dG/dw~) T.

dF/dw is a facet term like a rigid obstacle's; the other three, the coupling, join the
dofs of the two bodies. They vanish at every quadrature point out of contact, so that the
sparsity of the Jacobian holds only the coupling of the pairs that have been in contact:
it grows with the contact set (the solver is told, and factorises anew) and never holds
the pairs that never touched. With the whole surfaces coupled, the factorisation of two
P2 balls cost 2.5 times the flops of one ball of as many DOFs; with the pairs in contact,
0.46 times (docs/method.md section 11).
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc

from . import compat
from .assembly import CouplingEntries, csr_pointers
from .facet_jacobian import ContactFacets

__all__ = ["PairCoupling"]


def add_partner_terms(pairs, forms, b: PETSc.Vec, work, owned_bc, scale: float = 1.0) -> None:
    """b += scale * the sum over ``pairs`` of T^T G, G the compiled partner-tested form of
    the pair (``forms``), zero at the owned Dirichlet dofs ``owned_bc``; ``work``: two
    vectors of b's layout."""
    g, Tg = work
    for pair, G in zip(pairs, forms):
        with g.localForm() as local:
            local.set(0.0)
        fem_petsc.assemble_vector(g, G)
        g.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        pair.pairing.T.multTranspose(g, Tg)
        Tg.array[owned_bc] = 0.0
        b.axpy(scale, Tg)


class PairCoupling:
    """What a step's SNES needs beyond its UFL forms for contact pairs: the partners of
    the iterate, the residual T^T G and the Jacobian's coupling terms.

    The coupling terms vanish wherever the contact terms do: their matrices and products
    with T live on the facets of each slave surface near the contact (those of the cells
    in contact and a ring of neighbours, :class:`.ContactFacets`), made again when the
    contact zone moves beyond them, and filled again at each Jacobian; while the contact
    terms are inactive everywhere nothing is assembled. The entries of the coupling are
    those of the products on all of the surfaces, fixed; each product's go to their
    places among them, a symmetric coupling's transpose by one exchange between the
    ranks (:class:`_Transpose`). The nonzero coupling terms are added to the Jacobian,
    whose sparsity holds them: :attr:`growth` names the entries it lacks.

    Args:
        pairs: The :class:`~nitsche_dolfinx.pairs.PairContact` halves of the problem.
        F: The step's residual form (with every pair's slave terms).
        partner_residuals: For each pair, its partner-tested form G (test v for T v).
        w: The unknown.
        bc_dofs: Local (unblocked) indices of the Dirichlet dofs of ``w``.
        symmetric: The Jacobian is symmetric (Theta = 1): T^T (dG/dw) is then the transpose
            of (dF/dw~) T, and dG/dw is not assembled.
    """

    def __init__(
        self, pairs, F, partner_residuals, w: fem.Function, bc_dofs: np.ndarray,
        symmetric: bool = False,
    ):  # fmt: skip
        V = w.function_space
        trial = ufl.TrialFunction(V)
        self.pairs, self.w = list(pairs), w
        self._G = [fem.form(G) for G in partner_residuals]
        self._terms = []  # per pair: the derivative forms, their matrices, the products
        self._derivatives = []  # per pair: the UFL derivative forms
        self._facets = []  # per pair: the facets its forms are assembled on
        for pair, G in zip(self.pairs, partner_residuals):
            w_partner = pair.partners[w]
            derivatives = [ufl.derivative(F, w_partner, trial), ufl.derivative(G, w_partner, trial)]
            if not symmetric:
                derivatives.append(ufl.derivative(G, w, trial))
            forms = [fem.form(derivative) for derivative in derivatives]
            self._terms.append((forms, [fem_petsc.create_matrix(form) for form in forms], None))
            self._derivatives.append(derivatives)
            self._facets.append(ContactFacets.of_measure(V.mesh, pair.ds))
        self._g = compat.create_vector(V)
        self._Tg = self._g.duplicate()
        index_map, bs = V.dofmap.index_map, V.dofmap.index_map_bs
        owned = np.asarray(bc_dofs, dtype=np.int64)
        self._owned_bc = owned[owned < index_map.size_local * bs]
        self._sizes = ((index_map.size_local * bs, index_map.size_global * bs),) * 2
        self._offset = index_map.local_range[0] * bs  # the global index of the first row
        self._comm = V.mesh.comm
        self._entries()
        self._known = np.zeros(len(self._rows), dtype=bool)  # entries the Jacobian holds
        self._active = None  # the last coupling: (which entries are nonzero, their values)
        #: The coupling entries of the last Jacobian that the sparsity of the Jacobian
        #: lacked (None: none); the solver widens its matrices by them.
        self.growth: CouplingEntries | None = None
        #: Every coupling entry that the Jacobian holds (those :meth:`add_jacobian` may
        #: add to): the solver's sum of the Jacobian sets them back to zero first.
        self.entries = self._entries_of(self._known)

    def update(self, x: PETSc.Vec | None = None) -> None:
        """The partner of the iterate ``x`` (before each residual); without ``x``, the
        partners of every Function of the state (when they changed: before a solve)."""
        if x is not None:
            x.copy(compat.petsc_vector(self.w))
            self.w.x.scatter_forward()
        for pair in self.pairs:
            if x is None:  # the state's (the iterate's is recomputed at each residual)
                pair.update([f for f in pair.partners if f is not self.w])
            else:
                pair.update([self.w])

    def add_residual(self, b: PETSc.Vec) -> None:
        """b += sum of T^T G over the pairs (zero at the Dirichlet dofs)."""
        add_partner_terms(self.pairs, self._G, b, (self._g, self._Tg), self._owned_bc)

    def _assemble(self, active_cells: np.ndarray | None = None) -> None:
        """Assemble the derivative matrices of every pair: first each rank's share of all
        of them, then their parallel assembly (a pair's slave surface may lie on one rank:
        the others would wait for it, pair by pair; see
        :func:`~nitsche_dolfinx.compat.add_matrix_entries`). With ``active_cells`` (a
        bool per local cell: contact terms active), on the facets of the cells in contact
        and their neighbours only (:class:`.ContactFacets`): elsewhere the coupling terms
        vanish."""
        if active_cells is not None:
            self._restrict(active_cells)
        matrices = [matrix for _, pair_matrices, _ in self._terms for matrix in pair_matrices]
        forms = [form for pair_forms, _, _ in self._terms for form in pair_forms]
        for form, matrix in zip(forms, matrices):
            matrix.zeroEntries()
            compat.add_matrix_entries(matrix, form)
        for matrix in matrices:
            matrix.assemble()

    def _restrict(self, active_cells: np.ndarray) -> None:
        """Compile each pair's derivative forms again on the facets of its
        :class:`.ContactFacets` when the contact has reached beyond them or left most of
        them, with matrices and products on their sparsity (collective: every rank
        compiles when any rank's facets change)."""
        changes = [facets.update(active_cells) for facets in self._facets]
        flags = self._comm.allreduce(np.array(changes, dtype=int), op=MPI.SUM)
        for index, (facets, flag) in enumerate(zip(self._facets, flags)):
            if flag:
                _, matrices, products = self._terms[index]
                for matrix in matrices + (products or []):
                    matrix.destroy()
                forms = [fem.form(facets.restrict(d)) for d in self._derivatives[index]]
                matrices = [fem_petsc.create_matrix(form) for form in forms]
                self._terms[index], self._transposes[index] = (forms, matrices, None), None

    def _products(self, index: int):
        """Form pair ``index``'s products of its derivative matrices with T (into the
        product matrices of the last call, once they exist): F_w T, T^T G_ww T and,
        unless symmetric, T^T G_w (symmetric: the transpose of F_w T, which
        :meth:`_coupling` sums without forming it). New products are located among
        the coupling's entries (collective)."""
        forms, matrices, products = self._terms[index]
        T = self.pairs[index].pairing.T
        F_w, G_ww, *G_w = matrices  # dF/dw~, dG/dw~ and, unless symmetric, dG/dw
        if products is None:
            products = [F_w.matMult(T), G_ww.PtAP(T)]
            if G_w:
                products.append(T.transposeMatMult(G_w[0]))
            self._terms[index] = (forms, matrices, products)
            self._locate(index)
        else:
            F_w.matMult(T, products[0])
            G_ww.PtAP(T, products[1])
            if G_w:
                T.transposeMatMult(G_w[0], products[2])
        return products

    def _keys(self, product: PETSc.Mat) -> np.ndarray:
        """The entries of ``product`` as ``row * width + column`` (global indices)."""
        indptr, columns, _ = product.getValuesCSR()
        rows = np.repeat(np.arange(self._sizes[0][0], dtype=np.int64), np.diff(indptr))
        return (self._offset + rows) * self._sizes[1][1] + columns

    def _locate(self, index: int) -> None:
        """Where the entries of pair ``index``'s products go among the coupling's entries
        (and, symmetric, the transpose of F_w T: :class:`_Transpose`; collective)."""
        products, width = self._terms[index][2], self._sizes[1][1]
        keys = [self._keys(product) for product in products]
        transpose = self._transposes[index]
        if transpose is None and len(products) == 2:  # new products, symmetric
            transpose = self._transposes[index] = _Transpose(keys[0], width, products[0])
        if self._every is None:  # (the first products: the coupling's entries are theirs)
            return
        keys += [transpose.keys] if transpose is not None else []
        places = [np.searchsorted(self._every, key) for key in keys]
        for key, place in zip(keys, places):  # the first products' entries hold them
            if len(key) and not np.array_equal(
                self._every[np.minimum(place, len(self._every) - 1)], key
            ):
                raise RuntimeError("contact pair: a coupling entry beyond the first products'")
        self._places[index] = places

    def _entries(self) -> None:
        """The entries of the coupling terms (the union of the sparsities of the first
        products, on all of each surface: the owned rows, global columns, in CSR order;
        later products, on fewer facets, have fewer), where each product's entries go,
        and which are not in a Dirichlet row or column."""
        count, width = len(self.pairs), self._sizes[1][1]
        self._every, self._transposes, self._places = None, [None] * count, [None] * count
        self._assemble()
        keys = []
        for index in range(count):
            products = self._products(index)
            transpose = self._transposes[index]
            keys += [self._keys(product) for product in products]
            keys += [transpose.keys] if transpose is not None else []
        self._every = np.unique(np.concatenate(keys))
        for index in range(count):
            self._locate(index)
        every = self._every - self._offset * width
        self._rows, self._columns = every // width, every % width
        bc = np.concatenate(self._comm.allgather(self._offset + self._owned_bc))
        self._free = ~(np.isin(self._rows, self._owned_bc) | np.isin(self._columns, bc))

    def _coupling(
        self, inactive: bool, active_cells: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """The coupling terms at the current iterate, with zero Dirichlet rows and columns
        (zero, without assembling, when the contact terms are ``inactive`` everywhere):
        which entries are nonzero, and their values."""
        values = np.zeros(len(self._rows))
        if not inactive:
            self._assemble(active_cells)
            for index in range(len(self.pairs)):
                products, transpose = self._products(index), self._transposes[index]
                parts = [product.getValuesCSR()[2] for product in products]
                parts += [transpose.values()] if transpose is not None else []
                for part, places in zip(parts, self._places[index]):
                    values[places] += part  # no entry twice in a product or its transpose
        nonzero = (values != 0.0) & self._free
        return nonzero, values[nonzero]

    def jacobian_changed(
        self, inactive: bool = False, active_cells: np.ndarray | None = None
    ) -> bool:
        """Assemble the coupling terms (on the facets of the ``active_cells`` and their
        neighbours, if given); True if they differ from the last ones. Sets
        :attr:`growth` (collective)."""
        active, last = self._coupling(inactive, active_cells), self._active
        same = last is not None and all(np.array_equal(a, b) for a, b in zip(active, last))
        new = active[0] & ~self._known
        # whether every rank's coupling is the same, whether any rank's has new entries
        flags = np.array([int(same), int(new.any())])
        same, grows = self._comm.allreduce(flags, op=MPI.SUM)
        self._active = active
        self.growth = None
        if grows:
            self._known |= new
            self.growth = self._entries_of(new)
            self.entries = self._entries_of(self._known)
        return same < self._comm.size

    def _entries_of(self, mask: np.ndarray) -> CouplingEntries:
        """The coupling entries of ``mask`` on the rows that have any."""
        rows = self._rows[mask]
        present, counts = np.unique(rows, return_counts=True)
        indptr = csr_pointers(counts)
        columns = self._columns[mask].astype(PETSc.IntType)
        return CouplingEntries((self._offset + present).astype(PETSc.IntType), indptr, columns)

    def add_jacobian(self, A: PETSc.Mat) -> None:
        """A += the coupling terms of the last :meth:`jacobian_changed` (A's sparsity holds
        them, widened by the :attr:`growth` of that call)."""
        nonzero, values = self._active
        rows, indptr, columns = self._entries_of(nonzero)
        A.setValuesIJV(indptr, columns, values, PETSc.InsertMode.ADD, rows)
        A.assemble()

    def petsc_objects(self) -> list:
        objects = [self._g, self._Tg]
        for _, matrices, products in self._terms:
            objects.extend(matrices)
            objects.extend(products or [])
        return objects


class _Transpose:
    """The entries of the transpose of a product matrix with a fixed sparsity, sent to the
    ranks that own their rows (PETSc's parallel transpose communicates the whole matrix
    at each call; here each rank sends the values of its entries only, in an order agreed
    once). Collective.

    Args:
        keys: The product's entries as ``row * width + column`` (global indices, CSR
            order of :meth:`PETSc.Mat.getValuesCSR`).
        width: The global number of columns.
        product: The product matrix, whose values :meth:`values` sends.
    """

    def __init__(self, keys: np.ndarray, width: int, product: PETSc.Mat):
        self._product, self._comm = product, product.getComm().tompi4py()
        starts = np.asarray(product.getOwnershipRanges())
        rows, columns = keys // width, keys % width
        transposed = columns * width + rows
        owners = np.searchsorted(starts, columns, side="right") - 1
        self._order = np.argsort(owners, kind="stable")
        self._send = np.bincount(owners, minlength=self._comm.size)
        self._receive = np.asarray(self._comm.alltoall(self._send.tolist()))
        #: The entries this rank receives, as ``row * width + column``, rows owned here.
        self.keys = self._exchange(transposed[self._order], MPI.INT64_T, np.int64)

    def _exchange(self, data: np.ndarray, kind, dtype) -> np.ndarray:
        received = np.empty(int(self._receive.sum()), dtype=dtype)
        send = [data, (self._send, np.concatenate([[0], np.cumsum(self._send)[:-1]])), kind]
        displacements = np.concatenate([[0], np.cumsum(self._receive)[:-1]])
        self._comm.Alltoallv(send, [received, (self._receive, displacements), kind])
        return received

    def values(self) -> np.ndarray:
        """The values of the transposed entries this rank owns, in the order of :attr:`keys`."""
        values = np.ascontiguousarray(self._product.getValuesCSR()[2][self._order])
        return self._exchange(values, MPI.DOUBLE, np.float64)
