"""Sums, maxima and flags over the ranks of a communicator, without a message on one rank.

A value computed by ``fem.assemble_scalar`` or from the owned entries of a vector is only
this rank's share: the whole is a reduction over the communicator. These reduce several
values in one ``Allreduce`` of a numpy array (no pickling), and skip the call on a single
rank, where a reduction still costs more than the arithmetic of a small step.
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI

__all__ = ["any_rank", "max_over_ranks", "sum_over_ranks"]


def _reduced(comm, values, op) -> np.ndarray:
    array = np.array(values, dtype=float).reshape(-1)
    if comm.size > 1:
        comm.Allreduce(MPI.IN_PLACE, array, op=op)
    return array


def sum_over_ranks(comm, values) -> np.ndarray:
    """The sums over the ranks of ``values`` (an array, or a list of numbers), elementwise."""
    return _reduced(comm, values, MPI.SUM)


def max_over_ranks(comm, values) -> np.ndarray:
    """The maxima over the ranks of ``values``, elementwise."""
    return _reduced(comm, values, MPI.MAX)


def any_rank(comm, flag: bool) -> bool:
    """Whether ``flag`` is true on any rank."""
    if comm.size == 1:
        return bool(flag)
    return bool(comm.allreduce(bool(flag), op=MPI.LOR))
