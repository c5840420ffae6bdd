"""The progress of a run on rank 0: one bar on a terminal, one line per step elsewhere.

On a terminal with tqdm installed, a run shows a single line that it keeps rewriting:
the share of [0, T] done, t, the step, its Newton iterations and the energy. In a log
file or a pipe (or without tqdm), each time level gets one plain line instead::

    step    12  t =     0.0600  newton =  2  E =  1.2345678901e+00  contact force = 0.0000e+00

Under an MPI launcher the lines are the default: Open MPI gives every rank a
pseudo-terminal for its standard output even when mpirun writes to a file or a pipe, so
a rank cannot tell. ``NITSCHE_DOLFINX_PROGRESS=bar`` (e.g. ``mpirun -n 2 -x
NITSCHE_DOLFINX_PROGRESS=bar ...`` in a terminal) asks for the bar, ``=lines`` for the lines.

Messages during the run (a cut step, a restart) go through :meth:`Progress.write`, above
the bar.
"""

from __future__ import annotations

import os
import sys

__all__ = ["Progress"]

#: The bar: share of the time interval, the bar, t of T, times, then step, Newton, energy.
BAR_FORMAT = "{percentage:3.0f}%|{bar}| t = {n:.4g}/{total:.4g} [{elapsed}<{remaining}{postfix}]"


def _tqdm():
    """tqdm if installed (an optional dependency: without it, a line per step)."""
    try:
        from tqdm import tqdm
    except ImportError:
        return None
    return tqdm


class Progress:
    """The progress display of one run.

    Args:
        enabled: Whether to show anything (only rank 0 ever does).
        comm: The communicator of the run.
        t_start: The time the run starts from (after a restart, its time).
        t_end: The final time.
        stream: Where to show it (standard output by default); a bar when it is a
            terminal and tqdm is installed.
    """

    def __init__(self, enabled: bool, comm, t_start: float, t_end: float, stream=None):
        self.enabled = bool(enabled) and comm.rank == 0
        self.stream = stream if stream is not None else sys.stdout
        self._bar = None
        tqdm = _tqdm() if self.enabled and _wants_bar(self.stream, comm) else None
        if tqdm is not None:
            self._bar = tqdm(
                total=float(t_end),
                initial=float(t_start),
                file=self.stream,
                bar_format=BAR_FORMAT,
                dynamic_ncols=True,
                leave=True,
            )

    @property
    def bar(self) -> bool:
        """Whether the progress is a bar (else lines)."""
        return self._bar is not None

    def record(self, step: int, t: float, values: dict) -> None:
        """Show the time level ``t`` reached by ``step`` with its history ``values``."""
        if not self.enabled:
            return
        newton, energy = values["newton_iterations"], values["energy"]
        if self._bar is None:
            print(
                f"step {step:5d}  t = {t:9.4f}  newton = {newton:2d}  E = {energy: .10e}"
                f"  contact force = {values['contact_force']:.4e}",
                file=self.stream,
                flush=True,
            )
            return
        self._bar.n = min(float(t), self._bar.total)
        self._bar.set_postfix_str(f"step {step}, Newton {newton}, E = {energy:.6e}", refresh=False)
        self._bar.refresh()

    def write(self, text: str, file=None) -> None:
        """Print ``text`` (rank 0, when enabled) above the bar."""
        if not self.enabled:
            return
        self.message(text, file)

    def message(self, text: str, file=None) -> None:
        """Print ``text`` on rank 0 above the bar, even when the progress is not shown."""
        if self._bar is not None:
            self._bar.clear()
        print(text, file=file or self.stream, flush=True)
        if self._bar is not None:
            self._bar.refresh()

    def close(self) -> None:
        """End the bar (its last state stays on the terminal)."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None


#: Variables that MPI launchers set in the processes they start (Open MPI, MPICH, PMIx).
_LAUNCHER_VARIABLES = ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK")


def _wants_bar(stream, comm) -> bool:
    """A bar on a terminal, not under an MPI launcher, unless NITSCHE_DOLFINX_PROGRESS says."""
    asked = os.environ.get("NITSCHE_DOLFINX_PROGRESS", "").strip().lower()
    if asked in ("bar", "lines"):
        return asked == "bar"
    launched = comm.size > 1 or any(name in os.environ for name in _LAUNCHER_VARIABLES)
    return not launched and _is_terminal(stream)


def _is_terminal(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # closed or without isatty
        return False
