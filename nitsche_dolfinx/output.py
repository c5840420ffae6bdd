"""Output of docs/method.md section 6: ``history.csv`` and an XDMF time series for ParaView.

Both stay readable at every moment of a run (each row and each time level is
flushed as written), and both can be continued by a restarted run: the history
keeps its rows up to the restart time and goes on from there; the XDMF series
is appended to (dolfinx's ``XDMFFile`` mode ``"a"``).
"""

from __future__ import annotations

import csv
import os
import xml.etree.ElementTree as ElementTree
from collections.abc import Sequence

import numpy as np
from dolfinx import fem
from dolfinx.io import XDMFFile

from . import compat

__all__ = [
    "HistoryWriter",
    "SolutionWriter",
    "continue_solution",
    "ensure_directory",
    "read_history",
]


class HistoryWriter:
    """Write one CSV row per time level on rank 0, flushed at once so a crash loses nothing.

    Args:
        path: The CSV file.
        columns: Column names, written as the header line.
        comm: The communicator; only its rank 0 writes.
        resume_at: Continue an existing file instead: keep its rows up to this time
            (which must be its last row but for rows after it, dropped) and append.
            The kept rows are in :attr:`previous_rows` on every rank.

    Raises:
        ValueError: On every rank, if the file cannot be written, or cannot be continued
            (missing, other columns, or no row at ``resume_at``).
    """

    def __init__(self, path: str, columns: Sequence[str], comm, resume_at: float | None = None):
        self.path = str(path)
        self.columns = list(columns)
        self.rank = comm.rank
        self._file = None
        #: Rows kept from the file when resuming, as dicts of column to number.
        self.previous_rows: list[dict] = []
        error, rows = None, []
        if self.rank == 0:
            try:
                if resume_at is None:
                    self._file = open(self.path, "w", newline="")
                    self._file.write(",".join(self.columns) + "\n")
                    self._file.flush()
                else:
                    rows = _rows_up_to(self.path, self.columns, resume_at)
                    self._file = open(self.path, "a", newline="")
            except (OSError, ValueError) as exc:
                error = str(exc) if isinstance(exc, ValueError) else _os_error(self.path, exc)
        error, rows = comm.bcast((error, rows), root=0)
        if error is not None:
            raise ValueError(error)
        self.previous_rows = rows

    def write(self, values: dict) -> None:
        """Append one row; ``values`` maps every column to a number."""
        if self._file is None:
            return
        self._file.write(",".join(_format(values[name]) for name in self.columns) + "\n")
        self._file.flush()

    def close(self) -> None:
        """Close the file (what was written stays readable at every moment anyway)."""
        if self._file is not None:
            self._file.close()
            self._file = None


def _os_error(path: str, error: OSError) -> str:
    return f"{path!r} cannot be written: {error.strerror or error}"


def _parse_number(text: str):
    try:
        return int(text)
    except ValueError:
        return float(text)


def _rows_up_to(path: str, columns: list[str], t: float) -> list[dict]:
    """Cut the history ``path`` after its row at time ``t`` (atomically); return the rows kept."""
    if not os.path.isfile(path):
        raise ValueError(f"cannot continue the history: {path!r} does not exist")
    with open(path, newline="") as f:
        lines = f.read().splitlines()
    header = lines[0].split(",") if lines else []
    if header != columns:
        raise ValueError(
            f"cannot continue the history {path!r}: its columns are {','.join(header)}, "
            f"this run writes {','.join(columns)}"
        )
    tolerance = 1e-9 * max(abs(t), 1.0)
    kept, rows = [lines[0]], []
    for line in lines[1:]:
        fields = line.split(",")
        if len(fields) != len(columns):  # a row cut short by a hard kill: the end of the file
            break
        try:
            row = dict(zip(columns, (_parse_number(x) for x in fields)))
        except ValueError:
            break
        if row["t"] > t + tolerance:
            break
        kept.append(line)
        rows.append(row)
    if not rows or abs(rows[-1]["t"] - t) > tolerance:
        last = f"ends at t = {rows[-1]['t']:.6g}" if rows else "has no rows"
        raise ValueError(
            f"cannot continue the history {path!r}: it {last}, before the restart time t = {t:.6g}"
        )
    temporary = f"{path}.tmp"
    with open(temporary, "w", newline="") as f:
        f.write("\n".join(kept) + "\n")
        f.flush()
        os.fsync(f.fileno())
    os.replace(temporary, path)
    return rows


def _format(value) -> str:
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    return repr(float(value))


def read_history(path: str) -> dict[str, np.ndarray]:
    """Read a ``history.csv`` into a dict of column name to float array."""
    with open(path, newline="") as f:
        reader = csv.reader(f)
        header = next(reader)
        rows = [[float(x) for x in row] for row in reader if row]
    data = np.array(rows, dtype=float).reshape(-1, len(header))
    return {name: data[:, i] for i, name in enumerate(header)}


class SolutionWriter:
    """XDMF time series of displacement, velocity and von Mises stress.

    The fields are interpolated into Lagrange spaces of the mesh's geometric
    degree, the only functions XDMF writes on every dolfinx version.

    Args:
        path: The ``.xdmf`` file (its ``.h5`` goes next to it).
        mesh: The mesh.
        fields: ``{name: (expression_or_function, shape)}`` with shape ``()`` or ``(gdim,)``.
        append: Continue the series of an existing file written for the same mesh
            (see :func:`continue_solution`) instead of starting a new file.
    """

    def __init__(self, path: str, mesh, fields: dict, append: bool = False):
        self.path = str(path)
        degree = compat.geometry_degree(mesh)
        self._outputs = []
        for name, (source, shape) in fields.items():
            V = compat.function_space(mesh, "Lagrange", degree, shape)
            target = fem.Function(V, name=name)
            if isinstance(source, fem.Function):
                interpolant = source
            else:
                interpolant = compat.expression(source, V)
            self._outputs.append((target, interpolant))
        # mode "a" loads the XML and appends new time levels to the collections of the
        # same names; the mesh written by the first run is referenced, not rewritten
        self._xdmf = XDMFFile(mesh.comm, self.path, "a" if append else "w")
        if not append:
            self._xdmf.write_mesh(mesh)

    def write(self, t: float) -> None:
        """Write all fields at time ``t`` and flush to disk."""
        for target, interpolant in self._outputs:
            target.interpolate(interpolant)
            self._xdmf.write_function(target, float(t))
        if hasattr(self._xdmf, "flush"):
            self._xdmf.flush()

    def close(self) -> None:
        """Close the XDMF file."""
        self._xdmf.close()


def _output_times(path: str) -> list[float] | None:
    """The time values of an XDMF file, or None if it (or its ``.h5``) is missing or unreadable."""
    if not (os.path.isfile(path) and os.path.isfile(os.path.splitext(path)[0] + ".h5")):
        return None
    try:
        root = ElementTree.parse(path).getroot()
        return [float(node.get("Value")) for node in root.iter("Time")]
    except (OSError, ValueError, TypeError, ElementTree.ParseError):
        return None


def continue_solution(path: str, t: float, step: int, comm) -> tuple[str, bool]:
    """Where a run restarted at time ``t`` (step ``step``) writes its fields.

    Returns ``(path, True)`` to append to ``path`` when it holds a readable series
    that ends at or before ``t``: the normal case, since a run stopped by a solver
    failure or a signal saves its last step. If it holds fields after ``t`` (the run
    was killed after its last periodic checkpoint) or cannot be read, the fields go
    to a new file ``<name>-from-step<step>.xdmf`` instead: ``(that path, False)``
    (rewriting time levels of an HDF5 file fails before dolfinx 0.10).
    """
    decision = None
    if comm.rank == 0:
        times = _output_times(path)
        tolerance = 1e-9 * max(abs(t), 1.0)
        if times is None and not os.path.exists(path):
            decision = (path, False)
        elif times is not None and all(time <= t + tolerance for time in times):
            decision = (path, True)
        else:
            stem, extension = os.path.splitext(path)
            decision = (f"{stem}-from-step{step}{extension}", False)
    return comm.bcast(decision, root=0)


def ensure_directory(path: str, comm) -> str:
    """Create the output folder (rank 0) and check that it can be written."""
    error = None
    if comm.rank == 0:
        try:
            os.makedirs(path, exist_ok=True)
            probe = os.path.join(path, ".write-test")
            with open(probe, "w"):
                pass
            os.remove(probe)
        except OSError as exc:
            error = f"output folder {path!r} cannot be written: {exc.strerror or exc}"
    error = comm.bcast(error, root=0)
    if error:
        raise ValueError(error)
    return path
