"""Sums, maxima and flags over the ranks of a communicator, without a message on one rank.

A value computed by ``fem.assemble_scalar`` or from the owned entries of a vector is only
this rank's share: the whole is a reduction over the communicator. These reduce several
values in one ``Allreduce`` of a numpy array (no pickling), and skip the call on a single
rank, where a reduction still costs more than the arithmetic of a small step.

:func:`garbage_collected_together` keeps Python's cycle collector to points that every
rank reaches together, because freeing a PETSc object is not a local matter (see there).
"""

from __future__ import annotations

import gc
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np
from mpi4py import MPI

__all__ = [
    "any_rank",
    "collect_garbage_together",
    "garbage_collected_together",
    "max_over_ranks",
    "sum_over_ranks",
]


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


@contextmanager
def garbage_collected_together(comm) -> Iterator[None]:
    """A block (collective) in which Python's cycle collector runs only where every rank
    calls it: on entry, on exit and at :func:`collect_garbage_together`.

    The collector runs on each rank when that rank's own allocations say so. From dolfinx
    0.8 on, a ``la.Vector`` destroys its PETSc vector in ``__del__``, and the last PETSc
    object on a communicator frees PETSc's inner communicator with it. A vector in a
    reference cycle is thus freed on one rank and not yet on the other, and the next PETSc
    object on that communicator then duplicates the communicator (collective) on one rank
    only: the ranks wait for each other for ever (seen with dolfinx 0.11 and Open MPI 5).
    With the collector held to common points, every rank frees the same objects at the same
    point. The ranks that count are the program's (``MPI.COMM_WORLD``), not only
    ``comm``'s: a run on ``COMM_SELF`` in a program on several ranks may free the objects
    of an earlier run on all of them (measured: a serial run after a parallel one on each
    of 2 ranks waited for ever in PETSc's garbage cleanup on the world). In a program on
    one rank nothing changes.
    """
    if MPI.COMM_WORLD.size == 1:
        yield
        return
    enabled = gc.isenabled()
    gc.disable()
    gc.collect()
    try:
        yield
    finally:
        gc.collect()
        if enabled:
            gc.enable()


def collect_garbage_together(comm, generation: int = 2) -> None:
    """Collect the reference cycles of ``generation`` (and younger) on every rank: called
    at the same point of a :func:`garbage_collected_together` block by every rank."""
    if MPI.COMM_WORLD.size > 1:
        gc.collect(generation)
