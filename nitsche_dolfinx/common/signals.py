"""Clean stops on SIGINT or SIGTERM: the ranks agree to stop after the same step.

While a run is going on, :class:`StopSignals` turns SIGINT and SIGTERM into a request to
stop that the ranks agree on at the end of the step (an ``allreduce``), so that all of them
stop after the same step, write a checkpoint and raise :class:`RunInterrupted`.
"""

from __future__ import annotations

import signal
import threading

from mpi4py import MPI

__all__ = ["RunInterrupted", "StopSignals"]


class RunInterrupted(RuntimeError):
    """The run stopped cleanly on SIGINT or SIGTERM after a complete step.

    Attributes:
        signal_number: The signal (the largest one if ranks received different ones).
        step, t: The last completed step and its time.
        checkpoint: The :class:`~nitsche_dolfinx.output.checkpoint.SavedState`, or None if the run
            had nowhere to write one.
        exit_status: 128 + the signal number (130 for SIGINT, 143 for SIGTERM).
    """

    def __init__(self, signal_number: int, step: int, t: float, checkpoint=None):
        self.signal_number = int(signal_number)
        self.step, self.t = step, t
        self.checkpoint = checkpoint
        self.exit_status = 128 + self.signal_number
        name = _signal_name(self.signal_number)
        message = f"interrupted by {name} after step {step} (t = {t:.6g})"
        if checkpoint is not None:
            message += f"; {checkpoint}"
        super().__init__(message)


def _signal_name(number: int) -> str:
    try:
        return signal.Signals(number).name
    except ValueError:
        return f"signal {number}"


class StopSignals:
    """While active (a ``with`` block), SIGINT and SIGTERM ask the run to stop.

    The handler only records the signal; :meth:`requested` is called between
    steps, on every rank, and returns the same answer everywhere. A second
    SIGINT while a stop is pending raises KeyboardInterrupt at once. The
    previous handlers are restored on leaving the block. Outside the main
    thread (where Python cannot install handlers) nothing is installed.
    """

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self):
        self.received = 0
        self._previous = {}

    def __enter__(self) -> StopSignals:
        if threading.current_thread() is threading.main_thread():
            for number in self.SIGNALS:
                self._previous[number] = signal.signal(number, self._handle)
        return self

    def __exit__(self, *exc) -> None:
        for number, handler in self._previous.items():
            # None: a handler installed from C (not by Python), which cannot be put back
            signal.signal(number, signal.SIG_DFL if handler is None else handler)
        self._previous.clear()

    def _handle(self, number, frame) -> None:
        if self.received and number == signal.SIGINT:
            raise KeyboardInterrupt
        self.received = self.received or number

    def requested(self, comm) -> int:
        """The signal received by any rank (0 if none); collective."""
        if comm.size == 1:
            return self.received
        return comm.allreduce(self.received, op=MPI.MAX)
