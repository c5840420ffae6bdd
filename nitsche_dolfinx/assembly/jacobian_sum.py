"""The step's Jacobian A = K_bc + B, set again only on the rows where B changed, and widened
for the coupling of a contact pair (docs/method.md sections 8 and 11).

K_bc is the constant part (the cell terms, the affine facet terms and the identity on the
Dirichlet rows), B the facet part (:class:`~nitsche_dolfinx.assembly.facet_jacobian.FacetJacobian`).
Every entry of A is K_bc's value plus B's, so a sum on some rows is the same to the bit as a
sum in full: a run restarted from a checkpoint factorises bit for bit the matrices of the
uninterrupted run.
"""

from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from ..common.collective import any_rank
from .forms import CouplingEntries, csr_pointers

__all__ = ["SUM_IN_FULL_BELOW", "JacobianSum", "pattern_matrix", "widen"]

#: A Jacobian with fewer nonzero entries than this (over all ranks) is summed in full at
#: each change: a copy and an addition cost less there than finding the rows to set again.
SUM_IN_FULL_BELOW = 50_000


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


def widen(entries: CouplingEntries, matrices) -> None:
    """Add ``entries`` to the sparsity of each of ``matrices`` (assembled: PETSc rebuilds
    them, keeping their values)."""
    pattern = pattern_matrix(entries, matrices[0])
    for matrix in matrices:
        matrix.axpy(1.0, pattern, PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
    pattern.destroy()


def _ranges(indptr: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The positions of the entries of CSR ``rows`` (``indptr`` their pointers) and the
    length of each row."""
    starts, lengths = indptr[rows], indptr[rows + 1] - indptr[rows]
    offsets = np.concatenate(([0], np.cumsum(lengths)[:-1]))
    positions = np.repeat(starts - offsets, lengths) + np.arange(lengths.sum())
    return positions.astype(np.int64), lengths


class JacobianSum:
    """A = K_bc + B into the matrices of a solver, on the sparsity of K_bc (which holds B's)
    or a wider one (:meth:`widen`).

    Args:
        K_bc: The constant part (assembled again by its owner, who then calls
            :meth:`constant_changed`).
        facet: The :class:`~nitsche_dolfinx.assembly.facet_jacobian.FacetJacobian`, or None (no
            facet terms: A is K_bc).
    """

    def __init__(self, K_bc: PETSc.Mat, facet=None):
        self.K_bc = K_bc
        self.facet = facet
        self.widened = False  # whether A has entries beyond K_bc's
        self._summed_into = None  # the handle of the matrix of the last sum (None: none)
        self._in_A = None  # (B's generation, its entry rows, its values) in that matrix
        self._stale = np.zeros(0, dtype=np.int64)  # rows of A holding a former B's values
        self._K_rows = None  # K_bc's rows where B (or the reset entries) can have entries
        self._B_rows = None  # those rows, local
        self._B_in_K = None  # (B's generation, the place of each of its entries there)
        self._renewed = np.zeros(0, dtype=np.int64)  # rows where K_bc changed since that sum
        nonzeros = K_bc.getInfo(PETSc.Mat.InfoType.GLOBAL_SUM)["nz_used"]
        self._in_full = nonzeros < SUM_IN_FULL_BELOW  # the same on every rank

    def constant_changed(self, rows: np.ndarray | None = None) -> None:
        """K_bc was assembled again: the next sum is in full, its rows read again. Given
        the local ``rows`` out of which K_bc did not change (the rows of a contact pair's
        affine facet terms), the next sum sets them again with the rows where B changed,
        if they are rows where B can have entries on every rank (else in full;
        collective)."""
        self._K_rows = None
        partial = rows is not None and self.facet is not None
        if partial:
            outside = not np.isin(rows, self.facet.facet_rows).all()
            partial = not any_rank(self.K_bc.getComm().tompi4py(), outside)
        if partial:
            self._renewed = np.union1d(self._renewed, rows)
        else:
            self._summed_into = None

    def sum_into(self, A: PETSc.Mat, reset: CouplingEntries | None = None) -> None:
        """A = K_bc + B: in full the first time after :meth:`constant_changed` (and always
        below :data:`SUM_IN_FULL_BELOW` entries); then only the rows where B differs from
        the B of the last sum are set again, to K_bc's values plus B's (the other rows hold
        them already). ``reset``: entries where terms are added to A after this sum (the
        coupling between two bodies), set back to zero first, their rows set again with the
        others (a sum in full sets them to zero)."""
        facet = self.facet
        if facet is None:
            self.K_bc.copy(A, PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
            return
        if self._in_full or self._summed_into != A.handle:  # (A: wrapped anew each callback)
            self._stale = np.zeros(0, dtype=np.int64)
            self._renewed = np.zeros(0, dtype=np.int64)
            if self.widened:  # A has entries beyond K_bc's: zero there
                A.zeroEntries()
                A.axpy(1.0, self.K_bc, PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
            else:
                self.K_bc.copy(A, PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
            A.axpy(1.0, facet.B, PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
            self._summed_into = A.handle
            self._in_A = (facet.generation, facet.entry_rows, facet.values)
            return
        if reset is not None and len(reset.columns):
            zeros = np.zeros(len(reset.columns))
            A.setValuesIJV(reset.indptr, reset.columns, zeros, PETSc.InsertMode.INSERT,
                           reset.rows)  # fmt: skip
        changed = np.union1d(self._changed_rows(reset), self._renewed)
        self._rows_set_again(A, changed, reset)
        self._in_A = (facet.generation, facet.entry_rows, facet.values)
        self._stale = np.zeros(0, dtype=np.int64)
        self._renewed = np.zeros(0, dtype=np.int64)

    def _changed_rows(self, reset: CouplingEntries | None) -> np.ndarray:
        """The local rows where A must be set again: where B's values differ from those in
        A; if B was made again since, its nonzero rows and those of the B in A."""
        facet, (generation, entry_rows, in_A) = self.facet, self._in_A
        values = facet.values
        if generation != facet.generation:
            stale = np.unique(entry_rows[in_A != 0.0])
            changed = np.union1d(np.unique(facet.entry_rows[values != 0.0]), stale)
        else:
            changed = np.unique(facet.entry_rows[values != in_A])
        if reset is not None and len(reset.rows):
            first = facet.B.getOwnershipRange()[0]
            changed = np.union1d(changed, np.asarray(reset.rows) - first)
        return changed

    def _rows_set_again(self, A: PETSc.Mat, changed: np.ndarray, reset) -> None:
        """Set the local rows ``changed`` of A to K_bc's values plus B's."""
        facet = self.facet
        first = facet.B.getOwnershipRange()[0]
        rows, indptr, columns, K_values, B_in_K = self._rows_of_K(reset)
        chosen = np.searchsorted(rows - first, changed)
        entries, lengths = _ranges(indptr, chosen)
        summed = K_values[entries]
        B_entries, B_lengths = _ranges(facet.indptr, changed)
        place = np.cumsum(lengths) - lengths - indptr[chosen]  # in summed, less the K entry
        summed[B_in_K[B_entries] + np.repeat(place, B_lengths)] += facet.values[B_entries]
        A.setValuesIJV(csr_pointers(lengths), columns[entries], summed,
                       PETSc.InsertMode.INSERT, rows[chosen])  # fmt: skip
        A.assemble()

    def _rows_of_K(self, reset: CouplingEntries | None):
        """The rows of K_bc where B can have entries (on any facet) or ``reset`` has, in
        CSR form, with the place of each of B's entries among them: (global rows, row
        pointers, global columns, values, places). The rows are read again after
        :meth:`constant_changed` or when those of ``reset`` are not among them (the
        coupling grew onto new rows), the places when B is made again."""
        facet = self.facet
        first = facet.B.getOwnershipRange()[0]
        rows = facet.facet_rows
        if reset is not None and len(reset.rows):
            rows = np.union1d(rows, np.asarray(reset.rows) - first)
        width = np.int64(facet.B.getSize()[1])
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
        if self._B_in_K is None or self._B_in_K[0] != facet.generation:
            # B's sparsity is within K_bc's, the columns of each row sorted: find each of
            # B's entries by its (row, column) key among those of these rows
            B_keys = np.searchsorted(self._B_rows, facet.entry_rows) * width + facet.columns
            places = np.searchsorted(keys, B_keys)
            if not np.array_equal(keys[np.minimum(places, len(keys) - 1)], B_keys):
                raise RuntimeError("the facet Jacobian has entries beyond the sparsity of K_bc")
            self._B_in_K = (facet.generation, places)
        return global_rows, indptr, columns, values, self._B_in_K[1]

    def widen(self, entries: CouplingEntries, matrices) -> None:
        """Add ``entries`` to the sparsity of ``matrices`` (the solver's Jacobian and its
        lagged copy, :func:`widen`); a sum in full then zeroes them first."""
        widen(entries, matrices)
        self.widened = True
