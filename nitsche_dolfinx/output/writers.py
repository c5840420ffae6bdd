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
import xml.etree.ElementTree as ElementTree
from collections.abc import Sequence

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.io import XDMFFile

from ..common import compat
from .fields import NodalMean, OutputMesh
from .history import History, added_columns
from .series import PART_SUFFIX, SeriesXML, continuation, remove_segments

__all__ = [
    "HistoryWriter",
    "SolutionWriter",
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
        beside: With ``resume_at``, when ``path`` does not exist (a run restarted into
            another folder): the history to take the rows up to ``resume_at`` from (the
            one beside the checkpoint); if it does not exist either, the new history
            starts at ``resume_at`` (no previous rows).

    Raises:
        ValueError: On every rank, if the file cannot be written, or cannot be continued
            (missing, a column of the file left out, or no row at ``resume_at``).
    """

    def __init__(
        self, path: str, columns: Sequence[str], comm, resume_at: float | None = None,
        beside: str | None = None,
    ):  # fmt: skip
        self.path = str(path)
        self.columns = list(columns)
        self.rank = comm.rank
        self._file = None
        #: Rows kept from the file when resuming, as dicts of column to number.
        self.previous_rows: list[dict] = []
        error, rows = None, []
        if self.rank == 0:
            try:
                source = self.path
                if resume_at is not None and beside and not os.path.isfile(self.path):
                    source = beside if os.path.isfile(beside) else None
                if resume_at is None or source is None:
                    self._file = open(self.path, "w", newline="")
                    self._file.write(",".join(self.columns) + "\n")
                    self._file.flush()
                else:
                    rows = _rows_up_to(source, self.columns, resume_at, self.path)
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


def _rows_up_to(path: str, columns: list[str], t: float, target: str | None = None) -> list[dict]:
    """Cut the history ``path`` after its row at time ``t`` (atomically; into ``target``
    instead when given); return the rows kept.

    The run may write more columns than the file has
    (:func:`~nitsche_dolfinx.output.history.added_columns`): the file is rewritten with the run's
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
    target = path if target is None else target
    temporary = f"{target}.tmp"
    with open(temporary, "w", newline="") as f:
        f.write("\n".join(kept) + "\n")
        f.flush()
        os.fsync(f.fileno())
    os.replace(temporary, target)
    return rows


def _format(value) -> str:
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    return repr(float(value))


def read_history(path: str) -> History:
    """Read a ``history.csv`` into the :class:`~nitsche_dolfinx.output.history.History` that
    :meth:`Simulation.run <nitsche_dolfinx.simulation.Simulation.run>` returns: its rows
    (integers where the file has them), column by column as arrays (``history["energy"]``)."""
    with open(path, newline="") as f:
        reader = csv.reader(f)
        header = next(reader)
        rows = [dict(zip(header, (_parse_number(x) for x in row))) for row in reader if row]
    return History(rows, columns=header)


class SolutionWriter:
    """XDMF time series of the fields of a run: displacement, velocity, von Mises stress, the
    contact fields on Gamma_C, ... (docs/method.md section 6).

    The fields are interpolated into Lagrange spaces of one degree, the higher of the mesh's
    geometric degree and the degree of the Functions among them (:func:`output_degree`),
    so that a P2 displacement is written node for node. XDMF writes a field of the
    geometry's degree only: when the fields' degree is higher, they are written on an
    :class:`OutputMesh` whose geometry has their degree (a P2 field on an affine mesh:
    the mesh of its quadratic cells, with nodes at the mid-edges).

    A field given as an expression (the von Mises stress, which jumps between cells)
    takes at each node the mean of the values of the cells around it
    (:class:`~nitsche_dolfinx.output.fields.NodalMean`), so that it does not depend on the
    partition of the mesh; an object with a method ``evaluate(target)`` writes itself into
    the Function ``target`` of the output space.

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
        fields: ``{name: (source, shape)}`` with shape ``()`` or ``(gdim,)``; a source is
            a Function, a UFL expression or an object with ``evaluate(target)``.
        append: Continue the series of an existing file written for the same mesh
            (see :func:`~nitsche_dolfinx.output.series.continue_solution`) instead of starting a
            new file.
    """

    def __init__(self, path: str, mesh, fields: dict, append: bool = False):
        self.path = str(path)
        self.mesh, self.comm = mesh, mesh.comm
        #: The degree of the Lagrange spaces of the fields in the file.
        self.degree = output_degree(mesh, fields)
        #: The mesh in the file: ``mesh``, or an :class:`OutputMesh`'s of the fields' degree.
        self.written_mesh = mesh
        output_mesh = None
        if self.degree > compat.geometry_degree(mesh):
            output_mesh = OutputMesh(compat.function_space(mesh, "Lagrange", self.degree))
            self.written_mesh = output_mesh.mesh
        self._output_mesh = output_mesh
        self._outputs = []  # (evaluate, the field on mesh, the Function written)
        for name, (source, shape) in fields.items():
            V = compat.function_space(mesh, "Lagrange", self.degree, shape)
            target = fem.Function(V, name=name)
            written = target if output_mesh is None else output_mesh.function(name, shape)
            self._outputs.append((_evaluator(source, V, self.degree, shape), target, written))
        self.append = bool(append)
        stem, k = os.path.splitext(self.path)[0], 0
        if self.append:
            decision = continuation(self.path) if self.comm.rank == 0 else None
            stem, k = self.comm.bcast(decision, root=0)
        #: The name of the mesh grid the levels of this writer refer to.
        self.mesh_name = f"mesh-restart{k}" if self.append else "mesh"
        #: The HDF5 file this writer puts its data in.
        self.data_path = stem + ".h5"
        self._part = stem + PART_SUFFIX
        self._mesh_written = False
        self._xml = None  # rank 0: the XML of the series (see nitsche_dolfinx.output.series)

        def load():
            self._xml = SeriesXML(self.path if self.append else None)

        _on_rank_0(self.comm, load, self.path)
        if not self.append:  # a new series: the mesh at once, as a file with no level yet
            self._write_level(None)

    def write(self, t: float) -> None:
        """Write all fields at time ``t``; on return they are on disk and named in the XDMF file."""
        for evaluate, target, written in self._outputs:
            evaluate(target)
            if written is not target:
                self._output_mesh.transfer(target, written)
        self._write_level(float(t))

    def _write_level(self, t: float | None) -> None:
        """Open the working copy, write the mesh if not yet written and the fields at ``t``
        (if any), close, and rename the copy over the XDMF file (collective)."""
        new_file = not self.append and not self._mesh_written

        def prepare():
            if new_file:
                remove_segments(os.path.splitext(self.path)[0])
            else:  # dolfinx appends to a copy holding the meshes, not the levels
                with open(self._part, "w") as f:
                    f.write(self._xml.working_copy())

        _on_rank_0(self.comm, prepare, self._part)
        xdmf = XDMFFile(self.comm, self._part, "w" if new_file else "a")
        try:
            if not self._mesh_written:
                mesh = self.written_mesh
                name = mesh.name
                mesh.name = self.mesh_name
                try:
                    xdmf.write_mesh(mesh)
                finally:
                    mesh.name = name
            if t is not None:
                for _, _, written in self._outputs:
                    if self.append:
                        xpath = f"/Xdmf/Domain/Grid[@Name='{self.mesh_name}'][1]"
                        xdmf.write_function(written, t, xpath)
                    else:  # the first grid of the file: dolfinx's default
                        xdmf.write_function(written, t)
        finally:
            xdmf.close()
        self._mesh_written = True
        # the HDF5 file is closed on every rank: name its data, every field of a level in
        # one grid (see nitsche_dolfinx.output.series)
        _on_rank_0(self.comm, self._publish, self.path)

    def _publish(self) -> None:
        self._xml.add(self._part)
        with open(self._part, "w") as f:
            f.write(self._xml.text())
        os.replace(self._part, self.path)

    def close(self) -> None:
        """Nothing left to do: every level is closed as written."""


def output_degree(mesh, fields: dict) -> int:
    """The degree of the fields in the file: the mesh's geometric degree, or the highest
    degree of the Lagrange Functions among ``fields`` if higher."""
    degrees = [
        compat.element_degree(source.function_space)
        for source, _ in fields.values()
        if isinstance(source, fem.Function)
    ]
    return max([compat.geometry_degree(mesh), *degrees])


def _evaluator(source, V, degree: int, shape: tuple[int, ...]):
    """How a field's source is written into a Function of the output space ``V``."""
    if isinstance(source, fem.Function):
        if _same_numbering(source.function_space, V):  # a copy, not an interpolation
            return lambda target: target.x.array.__setitem__(slice(None), source.x.array)
        return lambda target: target.interpolate(source)
    if isinstance(source, ufl.core.expr.Expr):
        return NodalMean(source, V, degree, shape).evaluate
    return source.evaluate


def _same_numbering(S, V) -> bool:
    """Whether the Lagrange spaces ``S`` and ``V`` of one mesh have the same dofs in the
    same order (a Function of one is then a Function of the other, value for value)."""
    return (
        S.mesh is V.mesh
        and compat.element_degree(S) == compat.element_degree(V)
        and S.dofmap.index_map_bs == V.dofmap.index_map_bs
        and S.dofmap.index_map.size_local == V.dofmap.index_map.size_local
        and np.array_equal(compat.dofmap_array(S), compat.dofmap_array(V))
    )


def _on_rank_0(comm, action, path: str) -> None:
    """Run the file operation ``action()`` on rank 0 (collective); an OSError (or an XML
    file that cannot be parsed) becomes the same ValueError, naming ``path``, on every rank."""
    error = None
    if comm.rank == 0:
        try:
            action()
        except OSError as exc:
            error = _os_error(path, exc)
        except ElementTree.ParseError as exc:
            error = f"{path!r} cannot be written: {exc}"
    error = comm.bcast(error, root=0)
    if error is not None:
        raise ValueError(error)


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
