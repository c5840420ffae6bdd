"""How the ranks of a run agree on errors, so that a failure on one rank never leaves the
others waiting forever in a collective operation.

- :func:`agree`: every rank reports what went wrong on it (or None), and all of them raise
  the same error if any rank had one (a file one rank cannot write, say);
- :class:`FailureChannel`: a rank that failed on its own asks the others, on a
  communicator used for nothing else, whether they failed too (validation fails on every
  rank alike) or are waiting in some collective operation (they would wait forever: the
  caller then aborts the job).
"""

from __future__ import annotations

import time

from petsc4py import PETSc

__all__ = ["ERROR_AGREEMENT_SECONDS", "FailureChannel", "agree", "one_line"]

#: How long a failing rank waits for the other ranks to fail too (see :class:`FailureChannel`).
ERROR_AGREEMENT_SECONDS = 10.0


def agree(comm, error: str | None, kind: type[Exception]) -> None:
    """Raise ``kind`` on every rank if any rank has an ``error`` (the lowest rank's message).

    Collective: every rank calls it, so a failure on one rank stops all of them at the
    same place instead of leaving the others waiting.
    """
    errors = comm.allgather(error) if comm.size > 1 else [error]
    for rank, message in enumerate(errors):
        if message is not None:
            where = f" (rank {rank})" if comm.size > 1 and errors.count(message) < comm.size else ""
            raise kind(f"{message}{where}")


class FailureChannel:
    """A duplicate of ``comm`` on which ranks that failed find out whether every rank did.

    Made before the work that may fail (collective), freed after it by :meth:`free`, when
    every rank gets there. Its own communicator ensures that :meth:`every_rank_failed`
    never matches a collective operation that the other ranks are waiting in.
    """

    def __init__(self, comm):
        self._comm = comm.Dup() if comm.size > 1 else None

    def every_rank_failed(self, grace: float = ERROR_AGREEMENT_SECONDS) -> bool:
        """Whether every rank calls this within ``grace`` seconds of each other: the failure
        is collective (True), or this rank's own, the others waiting elsewhere (False)."""
        if self._comm is None:
            return True
        request = self._comm.Ibarrier()
        deadline = time.monotonic() + grace
        while not request.Test():
            if time.monotonic() > deadline:
                return False
            time.sleep(0.01)
        return True

    def free(self) -> None:
        """Free the communicator (collective)."""
        if self._comm is not None:
            self._comm.Free()
            self._comm = None


def one_line(error: BaseException) -> str:
    """The message of ``error`` on one line; for PETSc, its code and its most precise line."""
    if isinstance(error, PETSc.Error):
        lines = [line.split("] ", 1)[-1] for line in str(error).strip().splitlines()]
        return f"PETSc {lines[0]}: {lines[-1]}" if len(lines) > 1 else f"PETSc {lines[0]}"
    return " ".join(str(error).split()) or type(error).__name__
