"""Output of SPEC section 6: ``history.csv`` and an XDMF time series for ParaView."""

from __future__ import annotations

import csv
import os
from collections.abc import Sequence

import numpy as np
from dolfinx import fem
from dolfinx.io import XDMFFile

from . import compat

__all__ = ["HistoryWriter", "SolutionWriter", "read_history"]


class HistoryWriter:
    """Write one CSV row per time level on rank 0, flushed at once so a crash loses nothing.

    Args:
        path: The CSV file.
        columns: Column names, written as the header line.
        comm: The communicator; only its rank 0 writes.
    """

    def __init__(self, path: str, columns: Sequence[str], comm):
        self.path = str(path)
        self.columns = list(columns)
        self.rank = comm.rank
        self._file = None
        if self.rank == 0:
            self._file = open(self.path, "w", newline="")
            self._file.write(",".join(self.columns) + "\n")
            self._file.flush()

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
    """

    def __init__(self, path: str, mesh, fields: dict):
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
        self._xdmf = XDMFFile(mesh.comm, self.path, "w")
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
