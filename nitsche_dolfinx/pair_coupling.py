"""The linear algebra of contact between two bodies (docs/method.md section 11): the
partner-tested residual T^T G and the Jacobian's coupling terms, for
:class:`~nitsche_dolfinx.solver.SNESSolver` (its ``coupling``).

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

__all__ = ["PairCoupling"]


class PairCoupling:
    """What a step's SNES needs beyond its UFL forms for contact pairs: the partners of
    the iterate, the residual T^T G and the Jacobian's coupling terms.

    The matrices of the coupling terms and their products with T are made once and
    filled again at each Jacobian; while the contact terms are inactive everywhere the
    coupling is zero and is not assembled. The nonzero coupling terms are added to the
    Jacobian, whose sparsity holds them: :attr:`growth` names the entries it lacks.

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
        for pair, G in zip(self.pairs, partner_residuals):
            w_partner = pair.partners[w]
            derivatives = [ufl.derivative(F, w_partner, trial), ufl.derivative(G, w_partner, trial)]
            if not symmetric:
                derivatives.append(ufl.derivative(G, w, trial))
            forms = [fem.form(derivative) for derivative in derivatives]
            self._terms.append((forms, [fem_petsc.create_matrix(form) for form in forms], None))
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
        #: A zero matrix with the coupling entries of the last Jacobian that the sparsity
        #: of the Jacobian lacked (None: none); the solver widens its matrices by it.
        self.growth = None

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
        for pair, G in zip(self.pairs, self._G):
            with self._g.localForm() as local:
                local.set(0.0)
            fem_petsc.assemble_vector(self._g, G)
            self._g.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
            pair.pairing.T.multTranspose(self._g, self._Tg)
            self._Tg.array[self._owned_bc] = 0.0
            b.axpy(1.0, self._Tg)

    def _products(self, index: int):
        """Assemble pair ``index``'s derivative matrices and form their products with T
        (into the product matrices of the last call, once they exist)."""
        forms, matrices, products = self._terms[index]
        T = self.pairs[index].pairing.T
        for form, matrix in zip(forms, matrices):
            matrix.zeroEntries()
            fem_petsc.assemble_matrix(matrix, form)
            matrix.assemble()
        F_w, G_ww, *G_w = matrices  # dF/dw~, dG/dw~ and, unless symmetric, dG/dw
        if products is None:
            products = [F_w.matMult(T), G_ww.PtAP(T)]
            if G_w:
                products.append(T.transposeMatMult(G_w[0]))
            else:
                products.append(products[0].transpose(PETSc.Mat()))
            self._terms[index] = (forms, matrices, products)
        else:
            F_w.matMult(T, products[0])
            G_ww.PtAP(T, products[1])
            if G_w:
                T.transposeMatMult(G_w[0], products[2])
            else:
                products[0].transpose(products[2])
        return products

    def _entries(self) -> None:
        """The entries of the coupling terms (the union of the products' sparsities, fixed:
        the owned rows, global columns, in CSR order), where each product's entries go,
        and which are not in a Dirichlet row or column."""
        rows, columns = self._sizes[0][0], self._sizes[1][1]
        keys = []
        for index in range(len(self.pairs)):
            for product in self._products(index):
                indptr, product_columns, _ = product.getValuesCSR()
                product_rows = np.repeat(np.arange(rows, dtype=np.int64), np.diff(indptr))
                keys.append(product_rows * columns + product_columns)
        every = np.unique(np.concatenate(keys))
        self._places = [np.searchsorted(every, key) for key in keys]
        self._rows, self._columns = every // columns, every % columns
        bc = np.concatenate(self._comm.allgather(self._offset + self._owned_bc))
        self._free = ~(np.isin(self._rows, self._owned_bc) | np.isin(self._columns, bc))

    def _coupling(self, inactive: bool) -> tuple[np.ndarray, np.ndarray]:
        """The coupling terms at the current iterate, with zero Dirichlet rows and columns
        (zero, without assembling, when the contact terms are ``inactive`` everywhere):
        which entries are nonzero, and their values."""
        values = np.zeros(len(self._rows))
        if not inactive:
            products = (p for index in range(len(self.pairs)) for p in self._products(index))
            for product, places in zip(products, self._places):
                values[places] += product.getValuesCSR()[2]  # no entry twice in a product
        nonzero = (values != 0.0) & self._free
        return nonzero, values[nonzero]

    def jacobian_changed(self, inactive: bool = False) -> bool:
        """Assemble the coupling terms; True if they differ from the last ones. Sets
        :attr:`growth` (collective)."""
        if self.growth is not None:
            self.growth.destroy()
            self.growth = None
        active, last = self._coupling(inactive), self._active
        same = last is not None and all(np.array_equal(a, b) for a, b in zip(active, last))
        new = active[0] & ~self._known
        # whether every rank's coupling is the same, whether any rank's has new entries
        flags = np.array([int(same), int(new.any())])
        same, grows = self._comm.allreduce(flags, op=MPI.SUM)
        self._active = active
        if grows:
            self._known |= new
            self.growth = self._matrix(new, np.zeros(int(new.sum())))
        return same < self._comm.size

    def _matrix(self, entries: np.ndarray, values: np.ndarray) -> PETSc.Mat:
        """The matrix of the coupling's ``entries`` (a mask) with ``values``."""
        matrix = PETSc.Mat().createAIJ(self._sizes, comm=self._comm)
        matrix.setPreallocationCSR((*self._csr(entries), values))
        return matrix

    def _csr(self, entries: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Row pointers (owned rows) and global columns of the ``entries`` (a mask)."""
        counts = np.bincount(self._rows[entries], minlength=self._sizes[0][0])
        indptr = np.concatenate([[0], np.cumsum(counts)]).astype(PETSc.IntType)
        return indptr, self._columns[entries].astype(PETSc.IntType)

    @property
    def rows(self) -> np.ndarray:
        """The local rows of every coupling entry that the Jacobian holds (those that
        :meth:`add_jacobian` may add to)."""
        return np.unique(self._rows[self._known])

    def add_jacobian(self, A: PETSc.Mat) -> None:
        """A += the coupling terms of the last :meth:`jacobian_changed` (A's sparsity holds
        them, widened by the :attr:`growth` of that call)."""
        nonzero, values = self._active
        indptr, columns = self._csr(nonzero)
        A.setValuesCSR(indptr, columns, values, addv=PETSc.InsertMode.ADD_VALUES)
        A.assemble()

    def petsc_objects(self) -> list:
        objects = [self._g, self._Tg]
        if self.growth is not None:
            objects.append(self.growth)
        for _, matrices, products in self._terms:
            objects.extend(matrices)
            objects.extend(products or [])
        return objects
