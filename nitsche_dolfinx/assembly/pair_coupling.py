"""The linear algebra of contact between two bodies (docs/method.md section 11): the
partner-tested residual T^T G and the Jacobian's coupling terms, for
:class:`~nitsche_dolfinx.assembly.affine_system.AffineSystem` (its ``coupling``).

With w~ = T w the partner of the unknown, the Jacobian of a pair is

    J = dF/dw + (dF/dw~) T + T^T (dG/dw) + T^T (dG/dw~) T.

dF/dw is a facet term like a rigid obstacle's; the other three, the coupling, join the
dofs of the two bodies. They vanish at every quadrature point out of contact, so that the
sparsity of the Jacobian holds only the coupling of the pairs that have been in contact
(or next to it): it grows with the contact set (the solver is told, and factorises anew)
and never holds the pairs that never touched. With the whole surfaces coupled, the
factorisation of two P2 balls cost 2.5 times the flops of one ball of as many DOFs; with
the pairs in contact, 0.46 times (docs/method.md section 11).
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc
from ufl.algorithms import expand_derivatives

from ..common import compat
from .facet_jacobian import ContactFacets
from .forms import CouplingEntries, Forms, csr_pointers, split_cell_integrals

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
    terms are inactive everywhere nothing is assembled. A new pairing (a new T, when the
    surfaces have slid) makes the products again. The entries of the products are summed
    at each Jacobian, a symmetric coupling's transpose sent by one exchange between the
    ranks (:class:`_Transpose`). The nonzero coupling terms are added to the Jacobian,
    whose sparsity holds every entry they have had: when it lacks some, :attr:`growth`
    names every entry of the products it lacks, zero or not (those of the facets next to
    the contact too, so that the contact spreading onto them, within the step or the
    next ones, needs no new sparsity and no new symbolic factorisation).

    Args:
        pairs: The :class:`~nitsche_dolfinx.contact.pairs.PairContact` halves of the problem.
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
        self._derivatives = []  # per pair: the derivative forms on all of its facets
        self._facets = []  # per pair: the facets its forms are assembled on
        for pair, G in zip(self.pairs, partner_residuals):
            w_partner = pair.partners[w]
            derivatives = [ufl.derivative(F, w_partner, trial), ufl.derivative(G, w_partner, trial)]
            if not symmetric:
                derivatives.append(ufl.derivative(G, w, trial))
            # (facet integrals only: compiled once, then on other facets without compiling)
            everywhere = [
                Forms(split_cell_integrals(expand_derivatives(d))[1]) for d in derivatives
            ]
            forms = [form.form for form in everywhere]
            self._terms.append((forms, [fem_petsc.create_matrix(form) for form in forms], None))
            self._derivatives.append(everywhere)
            self._facets.append(ContactFacets.of_measure(V.mesh, pair.ds))
        self._transposes = [None] * len(self.pairs)
        self._generations = [pair.pairing.generation for pair in self.pairs]
        self._g = compat.create_vector(V)
        self._Tg = self._g.duplicate()
        index_map, bs = V.dofmap.index_map, V.dofmap.index_map_bs
        owned = np.asarray(bc_dofs, dtype=np.int64)
        self._owned_bc = owned[owned < index_map.size_local * bs]
        self._width = index_map.size_global * bs
        self._offset = index_map.local_range[0] * bs  # the global index of the first row
        self._comm = V.mesh.comm
        self._bc_rows = self._offset + self._owned_bc
        self._bc_columns = np.concatenate(self._comm.allgather(self._bc_rows))
        self._held = np.zeros(0, dtype=np.int64)  # the entries the Jacobian holds (keys)
        self._active = None  # the last coupling: its nonzero entries (keys), their values
        self._structural = np.zeros(0, dtype=np.int64)  # all its entries (keys), zero or not
        #: The coupling entries of the last Jacobian that the sparsity of the Jacobian
        #: lacked (None: none); the solver widens its matrices by them.
        self.growth: CouplingEntries | None = None
        #: Every coupling entry that the Jacobian holds (those :meth:`add_jacobian` may
        #: add to): the solver's sum of the Jacobian sets them back to zero first.
        self.entries = self._entries_of(self._held)

    def pairings(self) -> tuple[int, ...]:
        """The generation of each pair's pairing: a new one changes the pair's normal, and
        with it the affine facet terms of the constant Jacobian."""
        return tuple(pair.pairing.generation for pair in self.pairs)

    def pairing_functions(self) -> set:
        """The Functions a new pairing changes and forms hold: each pair's normal and gap
        vector."""
        return {f for pair in self.pairs for f in (pair.pairing.normal, pair.pairing.gap_vector)}

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
        :func:`~nitsche_dolfinx.common.compat.add_matrix_entries`). With ``active_cells`` (a
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
        """Take each pair's derivative forms on the facets of its :class:`.ContactFacets`
        (their compiled kernels: no compilation) when the contact has reached beyond them
        or left most of them, with matrices and products on their sparsity (collective:
        every rank makes them when any rank's facets change)."""
        changes = [facets.update(active_cells) for facets in self._facets]
        flags = self._comm.allreduce(np.array(changes, dtype=int), op=MPI.SUM)
        for index, (facets, flag) in enumerate(zip(self._facets, flags)):
            if flag:
                self._drop_products(index)
                for matrix in self._terms[index][1]:
                    matrix.destroy()
                forms = [
                    facets.compiled_on(d, facets.current).form for d in self._derivatives[index]
                ]
                matrices = [fem_petsc.create_matrix(form) for form in forms]
                self._terms[index] = (forms, matrices, None)

    def _drop_products(self, index: int) -> None:
        """Forget pair ``index``'s products (their sparsity is no longer that of its
        matrices or of its T)."""
        forms, matrices, products = self._terms[index]
        for product in products or []:
            product.destroy()
        self._terms[index], self._transposes[index] = (forms, matrices, None), None

    def _follow_pairings(self) -> None:
        """Products made anew for the pairs paired again since the last Jacobian."""
        for index, pair in enumerate(self.pairs):
            if pair.pairing.generation != self._generations[index]:
                self._drop_products(index)
                self._generations[index] = pair.pairing.generation

    def _products(self, index: int):
        """Form pair ``index``'s products of its derivative matrices with T (into the
        product matrices of the last call, once they exist): F_w T, T^T G_ww T and,
        unless symmetric, T^T G_w (symmetric: the transpose of F_w T, which
        :meth:`_coupling` sums without forming it; collective when new)."""
        forms, matrices, products = self._terms[index]
        T = self.pairs[index].pairing.T
        F_w, G_ww, *G_w = matrices  # dF/dw~, dG/dw~ and, unless symmetric, dG/dw
        if products is None:
            products = [F_w.matMult(T), G_ww.PtAP(T)]
            if G_w:
                products.append(T.transposeMatMult(G_w[0]))
            else:  # symmetric: the transpose of F_w T, sent to the owners of its rows
                keys = self._keys(*products[0].getValuesCSR()[:2])
                self._transposes[index] = _Transpose(keys, self._width, products[0])
            self._terms[index] = (forms, matrices, products)
        else:
            F_w.matMult(T, products[0])
            G_ww.PtAP(T, products[1])
            if G_w:
                T.transposeMatMult(G_w[0], products[2])
        return products

    def _keys(self, indptr: np.ndarray, columns: np.ndarray) -> np.ndarray:
        """The entries of an owned CSR block as ``row * width + column`` (global)."""
        rows = np.repeat(np.arange(len(indptr) - 1, dtype=np.int64), np.diff(indptr))
        return (self._offset + rows) * self._width + columns

    def _coupling(
        self, inactive: bool, active_cells: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """The coupling terms at the current iterate, with zero Dirichlet rows and columns
        (none, without assembling, when the contact terms are ``inactive`` everywhere):
        the nonzero entries (keys, sorted) and their values."""
        if inactive:
            return np.zeros(0, dtype=np.int64), np.zeros(0)
        self._assemble(active_cells)
        keys, values = [], []
        for index in range(len(self.pairs)):
            for product in self._products(index):
                indptr, columns, entries = product.getValuesCSR()
                keys.append(self._keys(indptr, columns))
                values.append(entries)
            transpose = self._transposes[index]
            if transpose is not None:
                keys.append(transpose.keys)
                values.append(transpose.values())
        every, place = np.unique(np.concatenate(keys), return_inverse=True)
        summed = np.bincount(place.ravel(), weights=np.concatenate(values), minlength=len(every))
        rows, columns = every // self._width, every % self._width
        free = ~(np.isin(rows, self._bc_rows) | np.isin(columns, self._bc_columns))
        nonzero = (summed != 0.0) & free
        self._structural = every[free]  # (the pattern the Jacobian grows by)
        return every[nonzero], summed[nonzero]

    def jacobian_changed(
        self, inactive: bool = False, active_cells: np.ndarray | None = None
    ) -> bool:
        """Assemble the coupling terms (on the facets of the ``active_cells`` and their
        neighbours, if given); True if they differ from the last ones. Sets
        :attr:`growth` (collective)."""
        self._follow_pairings()
        active, last = self._coupling(inactive, active_cells), self._active
        same = last is not None and all(np.array_equal(a, b) for a, b in zip(active, last))
        new = np.setdiff1d(active[0], self._held, assume_unique=True)
        # whether every rank's coupling is the same, whether any rank's has new entries
        flags = np.array([int(same), int(len(new) > 0)])
        same, grows = self._comm.allreduce(flags, op=MPI.SUM)
        self._active = active
        self.growth = None
        if grows:
            if len(new):  # every entry of the products, not only the nonzero ones
                new = np.setdiff1d(self._structural, self._held, assume_unique=True)
            self._held = np.union1d(self._held, new)
            self.growth = self._entries_of(new)
            self.entries = self._entries_of(self._held)
        return same < self._comm.size

    def _entries_of(self, keys: np.ndarray) -> CouplingEntries:
        """The coupling entries ``keys`` (sorted) in CSR form, on the rows that have any."""
        rows = keys // self._width
        present, counts = np.unique(rows, return_counts=True)
        columns = (keys % self._width).astype(PETSc.IntType)
        return CouplingEntries(present.astype(PETSc.IntType), csr_pointers(counts), columns)

    def add_jacobian(self, A: PETSc.Mat) -> None:
        """A += the coupling terms of the last :meth:`jacobian_changed` (A's sparsity holds
        them, widened by the :attr:`growth` of that call)."""
        keys, values = self._active
        rows, indptr, columns = self._entries_of(keys)
        A.setValuesIJV(indptr, columns, values, PETSc.InsertMode.ADD, rows)
        A.assemble()

    def petsc_objects(self) -> list:
        """Its PETSc objects, for the system that holds it to destroy: the work vectors of
        T^T G and the coupling terms' matrices and products (T is the pairing's)."""
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
