"""Output of docs/method.md section 6: ``history.csv`` and an XDMF time series for ParaView.

Both stay readable at every moment of a run, also after a SIGKILL (each row is
flushed as written, each time level written whole and closed), and both can be
continued by a restarted run: the history keeps its rows up to the restart time
and goes on from there; the XDMF series is appended to, with the mesh written
again for the levels of the restarted run (see :class:`SolutionWriter`).
"""

from __future__ import annotations

import csv
import os
import re
import shutil
import xml.etree.ElementTree as ElementTree
from collections.abc import Sequence

import numpy as np
from dolfinx import fem
from dolfinx.io import XDMFFile
from petsc4py import PETSc

from . import compat
from .history import added_columns

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
            The kept rows are in :attr:`previous_rows` on every rank. ``columns`` may
            add columns to the file's, which then hold ``nan`` in the kept rows.

    Raises:
        ValueError: On every rank, if the file cannot be written, or cannot be continued
            (missing, a column of the file left out, or no row at ``resume_at``).
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
    """Cut the history ``path`` after its row at time ``t`` (atomically); return the rows kept.

    The run may write more columns than the file has
    (:func:`~nitsche_dolfinx.history.added_columns`): the file is rewritten with the run's
    header, ``nan`` in the new columns of the kept rows."""
    if not os.path.isfile(path):
        raise ValueError(f"cannot continue the history: {path!r} does not exist")
    with open(path, newline="") as f:
        lines = f.read().splitlines()
    header = lines[0].split(",") if lines else []
    try:
        added_columns(header, columns)
    except ValueError as error:
        raise ValueError(f"cannot continue the history {path!r}: {error}") from None
    tolerance = 1e-9 * max(abs(t), 1.0)
    kept, rows = [",".join(columns)], []
    for line in lines[1:]:
        fields = line.split(",")
        if len(fields) != len(header):  # a row cut short by a hard kill: the end of the file
            break
        try:
            row = dict(zip(header, (_parse_number(x) for x in fields)))
        except ValueError:
            break
        if row["t"] > t + tolerance:
            break
        text = dict(zip(header, fields))
        kept.append(",".join(text.get(name, "nan") for name in columns))
        rows.append({name: row.get(name, float("nan")) for name in columns})
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


#: The working copy of an XDMF file while a time level is written (see :class:`SolutionWriter`).
PART_SUFFIX = ".xdmf-part"
_SEGMENT = re.compile(r"-restart(\d+)(\.h5|" + re.escape(PART_SUFFIX) + r")$")


class NodalMean:
    """A UFL expression in ``V`` (Lagrange, of ``degree`` and value ``shape``), its value at
    each node the mean of the values of the cells around the node.

    A field that jumps between cells (a stress) has no value at a node shared by cells;
    dolfinx's interpolation gives it the value of the last cell it visits, which depends
    on the partition of the mesh. Here the expression is interpolated cell by cell into
    the discontinuous space of the same degree, then averaged over the cells of each
    node: the same on any partition and number of ranks, up to round-off.
    """

    def __init__(self, expression, V, degree: int, shape: tuple[int, ...] = ()):
        mesh = V.mesh
        W = compat.function_space(mesh, "DG", degree, shape)
        self._pieces = fem.Function(W)
        self._expression = compat.expression(expression, W)
        cells = mesh.topology.index_map(mesh.topology.dim).size_local  # owned cells
        self._nodes = compat.dofmap_array(V)[:cells].reshape(-1)
        self._cell_nodes = compat.dofmap_array(W)[:cells].reshape(-1)
        self._bs = V.dofmap.index_map_bs
        index_map = V.dofmap.index_map
        self._blocks = index_map.size_local + index_map.num_ghosts
        self._owned = index_map.size_local * self._bs
        counts = fem.Function(V)
        ones = np.ones((self._nodes.size, self._bs))
        self._counts = self._sum(counts, ones)

    def _sum(self, target, values: np.ndarray) -> np.ndarray:
        """Add ``values`` (one row per cell node) into the owned dofs of ``target``, on the
        rank that owns each node; returns the owned entries."""
        array = target.x.array.reshape(-1, self._bs)
        for component in range(self._bs):
            array[:, component] = np.bincount(
                self._nodes, weights=values[:, component], minlength=self._blocks
            )[: len(array)]
        vector = compat.petsc_vector(target)
        vector.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        return target.x.array[: self._owned].copy()

    def evaluate(self, target) -> None:
        """Set ``target`` (a Function on ``V``) to the nodal means of the expression."""
        self._pieces.interpolate(self._expression)
        values = self._pieces.x.array.reshape(-1, self._bs)[self._cell_nodes]
        sums = self._sum(target, values)
        target.x.array[: self._owned] = sums / self._counts
        target.x.scatter_forward()


class SolutionWriter:
    """XDMF time series of displacement, velocity and von Mises stress.

    The fields are interpolated into Lagrange spaces of the mesh's geometric
    degree, the only functions XDMF writes on every dolfinx version.

    A field given as an expression (the von Mises stress, which jumps between cells)
    takes at each node the mean of the values of the cells around it
    (:class:`NodalMean`), so that it does not depend on the partition of the mesh.

    Every time level is written whole and closed, so that the files stay readable
    when the run is killed (even by SIGKILL), with every level written before:

    - the files are opened for the level and closed after it (dolfinx's ``XDMFFile``
      in mode ``"a"``), so that the HDF5 file is consistent on disk between levels;
    - dolfinx writes the XML into a working copy ``<stem>.xdmf-part``, renamed over
      the ``.xdmf`` file once the HDF5 file is closed: the ``.xdmf`` file only ever
      names data that are complete on disk (a level cut short by a kill is not named).

    A continued series (``append``, after a restart) writes the mesh again, as the grid
    ``mesh-restart<k>``, and its levels refer to that mesh: the nodes of a mesh are
    numbered by its partition, which differs from one ``mpirun`` to the next and with
    the number of ranks. Its data go on in the HDF5 file of the last level, or, if a
    kill cut a write short there (its working copy is left), in a new file
    ``<stem>-restart<k>.h5``, since that file may hold part of a level that dolfinx
    could not write again. The levels before the restart are not touched.

    Args:
        path: The ``.xdmf`` file (its ``.h5`` goes next to it).
        mesh: The mesh.
        fields: ``{name: (expression_or_function, shape)}`` with shape ``()`` or ``(gdim,)``.
        append: Continue the series of an existing file written for the same mesh
            (see :func:`continue_solution`) instead of starting a new file.
    """

    def __init__(self, path: str, mesh, fields: dict, append: bool = False):
        self.path = str(path)
        self.mesh, self.comm = mesh, mesh.comm
        degree = compat.geometry_degree(mesh)
        self._outputs = []
        for name, (source, shape) in fields.items():
            V = compat.function_space(mesh, "Lagrange", degree, shape)
            target = fem.Function(V, name=name)
            if isinstance(source, fem.Function):
                interpolant = source
            else:
                interpolant = NodalMean(source, V, degree, shape)
            self._outputs.append((target, interpolant))
        self.append = bool(append)
        stem, k = os.path.splitext(self.path)[0], 0
        if self.append:
            decision = _continuation(self.path) if self.comm.rank == 0 else None
            stem, k = self.comm.bcast(decision, root=0)
        #: The name of the mesh grid the levels of this writer refer to.
        self.mesh_name = f"mesh-restart{k}" if self.append else "mesh"
        #: The HDF5 file this writer puts its data in.
        self.data_path = stem + ".h5"
        self._part = stem + PART_SUFFIX
        self._mesh_written = False
        if not self.append:  # a new series: the mesh at once, as a file with no level yet
            self._write_level(None)

    def write(self, t: float) -> None:
        """Write all fields at time ``t``; on return they are on disk and named in the XDMF file."""
        for target, interpolant in self._outputs:
            if isinstance(interpolant, NodalMean):
                interpolant.evaluate(target)
            else:
                target.interpolate(interpolant)
        self._write_level(float(t))

    def _write_level(self, t: float | None) -> None:
        """Open the working copy, write the mesh if not yet written and the fields at ``t``
        (if any), close, and rename the copy over the XDMF file (collective)."""
        new_file = not self.append and not self._mesh_written

        def prepare():
            if new_file:
                _remove_segments(os.path.splitext(self.path)[0])
            else:  # dolfinx rewrites the XML in place: work on a copy
                shutil.copyfile(self.path, self._part)

        _on_rank_0(self.comm, prepare, self._part)
        xdmf = XDMFFile(self.comm, self._part, "w" if new_file else "a")
        try:
            if not self._mesh_written:
                name = self.mesh.name
                self.mesh.name = self.mesh_name
                try:
                    xdmf.write_mesh(self.mesh)
                finally:
                    self.mesh.name = name
            if t is not None:
                for target, _ in self._outputs:
                    if self.append:
                        xpath = f"/Xdmf/Domain/Grid[@Name='{self.mesh_name}'][1]"
                        xdmf.write_function(target, t, xpath)
                    else:  # the first grid of the file: dolfinx's default
                        xdmf.write_function(target, t)
        finally:
            xdmf.close()
        self._mesh_written = True
        # the HDF5 file is closed on every rank: name its data
        _on_rank_0(self.comm, lambda: os.replace(self._part, self.path), self.path)

    def close(self) -> None:
        """Nothing left to do: every level is closed as written."""


def _on_rank_0(comm, action, path: str) -> None:
    """Run the file operation ``action()`` on rank 0 (collective); an OSError becomes the
    same ValueError, naming ``path``, on every rank."""
    error = None
    if comm.rank == 0:
        try:
            action()
        except OSError as exc:
            error = _os_error(path, exc)
    error = comm.bcast(error, root=0)
    if error is not None:
        raise ValueError(error)


def _series_files(path: str) -> tuple[set[int], bool]:
    """The numbers k of the files ``<stem>-restart<k>.*`` of the series ``path``, and whether
    a working copy of its XML is left (a write that a kill cut short)."""
    stem = os.path.splitext(path)[0]
    folder, base = os.path.dirname(stem) or ".", os.path.basename(stem)
    numbers, interrupted = set(), False
    for entry in os.listdir(folder):
        if not entry.startswith(base):
            continue
        rest = entry[len(base) :]
        found = _SEGMENT.fullmatch(rest)
        if found:
            numbers.add(int(found.group(1)))
        interrupted |= rest.endswith(PART_SUFFIX) and (rest == PART_SUFFIX or bool(found))
    return numbers, interrupted


def _continuation(path: str) -> tuple[str, int]:
    """Where a restart continues the series ``path``: ``(stem of its data file, k)``.

    The mesh goes again into the grid ``mesh-restart<k>``, k the least number that no grid
    and no file of the series uses. The data go on in the HDF5 file of the last level,
    unless a kill cut a write short (its working copy of the XML is left): that file may
    then hold data of a level it never finished, which dolfinx before 0.10 cannot write
    again, and the data go to a new file ``<stem>-restart<k>.h5``.
    """
    stem = os.path.splitext(path)[0]
    numbers, interrupted = _series_files(path)
    root = ElementTree.parse(path).getroot()
    for grid in root.iter("Grid"):
        found = re.fullmatch(r"mesh-restart(\d+)", grid.get("Name", ""))
        if found:
            numbers.add(int(found.group(1)))
    k = 1
    while k in numbers:
        k += 1
    data = [item.text.strip().split(":", 1)[0] for item in root.iter("DataItem")]
    if interrupted or not data:
        return f"{stem}-restart{k}", k
    return os.path.join(os.path.dirname(path), os.path.splitext(data[-1])[0]), k


def _remove_segments(stem: str) -> None:
    """Remove the data of the restarts of an earlier series ``<stem>.xdmf`` and the working
    copies of its XML, before a new series of that name starts."""
    folder = os.path.dirname(stem) or "."
    base = os.path.basename(stem)
    for entry in os.listdir(folder):
        rest = entry[len(base) :] if entry.startswith(base) else None
        if rest is not None and (rest == PART_SUFFIX or _SEGMENT.fullmatch(rest)):
            os.remove(os.path.join(folder, entry))


def _output_times(path: str) -> list[float] | None:
    """The time values of an XDMF file, or None if it, or an HDF5 file it names, is missing
    or unreadable."""
    if not os.path.isfile(path):
        return None
    folder = os.path.dirname(path)
    try:
        root = ElementTree.parse(path).getroot()
        for item in root.iter("DataItem"):
            if item.get("Format") == "HDF":
                data = (item.text or "").strip().split(":", 1)[0]
                if not os.path.isfile(os.path.join(folder, data)):
                    return None
        return [float(node.get("Value")) for node in root.iter("Time")]
    except (OSError, ValueError, TypeError, ElementTree.ParseError):
        return None


def continue_solution(path: str, t: float, step: int, comm) -> tuple[str, bool]:
    """Where a run restarted at time ``t`` (step ``step``) writes its fields.

    Returns ``(path, True)`` to append to ``path`` when it holds a readable series
    that ends at or before ``t``: the normal case, since a run stopped by a solver
    failure or a signal saves its last step. If it holds fields after ``t`` (the run
    was killed after its last periodic checkpoint) or cannot be read, the fields go
    to a new file ``<name>-from-step<step>.xdmf`` instead: ``(that path, False)``;
    the levels after ``t`` stay in ``path`` as the killed run wrote them.
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
    if comm.rank == 0 and os.path.exists(path) and not os.path.isdir(path):
        error = f"output folder {path!r} is a file, not a folder"
    elif comm.rank == 0:
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
