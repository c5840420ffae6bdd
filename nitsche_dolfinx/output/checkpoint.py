"""Checkpoints and restarts: the state of a time level saved, and found again on any partition.

A checkpoint is a folder (``OUT/checkpoint`` for :meth:`Simulation.run
<nitsche_dolfinx.simulation.Simulation.run>`) holding

- ``state-<step>.rank<r>.npz``, one per rank: the coordinates of the nodes the
  rank owns and the values there of every function the stepper's next step
  depends on (displacement, velocity, acceleration; the mixed method's multiplier
  with the coordinates of its own nodes);
- ``checkpoint.json``, written by rank 0 once every rank has written its file:
  the step, t, the number of ranks and dofs, dt, the scheme, the Nitsche
  parameters and the history columns of the run.

Every file is written under a temporary name and renamed, and the previous
state's files are removed only after ``checkpoint.json`` names the new ones,
so an interruption at any moment leaves the last complete checkpoint
readable.

The values are found again by the coordinates of their nodes (:func:`match_points`),
not by their place in the arrays: the partition of a mesh among the ranks is not
the same from one ``mpirun`` to the next (measured with dolfinx 0.5 on the disk),
so a checkpoint reloads on any partition of the same mesh, and on any number
of ranks. Every rank reads all the files (fine for the meshes of this project;
the memory of one rank bounds the size). Another mesh, space, scheme, method or
Nitsche variant is refused with a message naming the difference; the time step
and gamma0 may change (:data:`CHANGEABLE`), and so may the solver options.

A run stopped by SIGINT or SIGTERM (:mod:`~nitsche_dolfinx.common.signals`) or by a failed step
writes a checkpoint of its last complete step through :func:`save_state`.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field

import numpy as np
from mpi4py import MPI

from ..common import compat
from ..common.agreement import agree
from .history import added_columns

__all__ = [
    "CHECKPOINT_FILE",
    "CheckpointError",
    "SavedState",
    "has_checkpoint",
    "load_state",
    "match_points",
    "read_checkpoint",
    "save_state",
    "write_checkpoint",
]

#: What a restart may change: the time step (a new grid of steps from the restart time,
#: see :mod:`~nitsche_dolfinx.steppers.timelevels`) and the Nitsche parameter.
CHANGEABLE = ("dt", "gamma0", "gamma0_scaling")

#: The metadata file of a checkpoint folder; its presence makes the folder a checkpoint.
CHECKPOINT_FILE = "checkpoint.json"
_FORMAT = "nitsche-dolfinx checkpoint"
_VERSION = 1


class CheckpointError(ValueError):
    """A checkpoint cannot be written, read, or does not fit the simulation."""


@dataclass(frozen=True)
class SavedState:
    """Where and which state a checkpoint holds; ``changes`` maps what a restart changed
    (a key of :data:`CHANGEABLE`) to its saved and its new value."""

    folder: str
    step: int
    t: float
    changes: dict = field(default_factory=dict)

    def __str__(self) -> str:
        return f"the state at step {self.step} (t = {self.t:.6g}) is saved in {self.folder}"


# -- writing and reading -----------------------------------------------------------------


def _rank_file(state: str, rank: int) -> str:
    return f"{state}.rank{rank:04d}.npz"


def _write_atomically(path: str, write) -> None:
    """``write(file)`` into ``path`` through a temporary name, synced, then renamed."""
    temporary = f"{path}.tmp"
    with open(temporary, "wb") as f:
        write(f)
        f.flush()
        os.fsync(f.fileno())
    os.replace(temporary, path)


def has_checkpoint(folder: str) -> bool:
    """Whether ``folder`` holds a complete checkpoint (its metadata file names it)."""
    return os.path.isfile(os.path.join(str(folder), CHECKPOINT_FILE))


def write_checkpoint(
    folder: str, comm, step: int, t: float, arrays: dict[str, np.ndarray], metadata: dict
) -> SavedState:
    """Write one checkpoint: each rank its ``arrays``, then rank 0 the metadata (collective).

    Args:
        folder: The checkpoint folder (created if needed).
        comm: The communicator of the simulation.
        step, t: The time level saved.
        arrays: This rank's arrays, by name.
        metadata: What a restart must match (JSON-serialisable), stored with step and t.

    Returns:
        The saved state.

    Raises:
        CheckpointError: On every rank, if any rank could not write.
    """
    folder = str(folder)
    error = None
    if comm.rank == 0:
        try:
            os.makedirs(folder, exist_ok=True)
        except OSError as exc:
            error = f"checkpoint folder {folder!r} cannot be created: {exc.strerror or exc}"
    agree(comm, comm.bcast(error, root=0), CheckpointError)
    state = f"state-{step:08d}"
    path = os.path.join(folder, _rank_file(state, comm.rank))
    error = None
    try:
        _write_atomically(path, lambda f: np.savez(f, **arrays))
    except OSError as exc:
        error = f"checkpoint file {path!r} cannot be written: {exc.strerror or exc}"
    # every rank's file is complete before the metadata names it
    agree(comm, error, CheckpointError)
    previous = None
    if comm.rank == 0:
        meta_path = os.path.join(folder, CHECKPOINT_FILE)
        previous = _read_metadata(meta_path, missing_ok=True)
        content = {
            "format": _FORMAT,
            "version": _VERSION,
            "state": state,
            "step": int(step),
            "t": float(t),
            "ranks": comm.size,
            **metadata,
        }
        try:
            text = json.dumps(content, indent=1).encode()
            _write_atomically(meta_path, lambda f: f.write(text))
        except (OSError, TypeError) as exc:
            error = f"checkpoint metadata {meta_path!r} cannot be written: {exc}"
    agree(comm, comm.bcast(error, root=0), CheckpointError)
    previous = comm.bcast(previous.get("state") if isinstance(previous, dict) else None, root=0)
    if previous is not None and previous != state:  # the new state is named: drop the old one
        old = os.path.join(folder, _rank_file(previous, comm.rank))
        if os.path.exists(old):
            os.remove(old)
    return SavedState(folder, int(step), float(t))


def _read_metadata(path: str, missing_ok: bool = False):
    """The metadata dict, None if missing and ``missing_ok``, else an error message string."""
    if not os.path.isfile(path):
        folder = os.path.dirname(path)
        return None if missing_ok else f"no checkpoint in {folder!r} ({CHECKPOINT_FILE} is missing)"
    try:
        with open(path) as f:
            content = json.load(f)
    except (OSError, ValueError) as exc:
        return f"checkpoint metadata {path!r} cannot be read: {exc}"
    if not isinstance(content, dict) or content.get("format") != _FORMAT:
        return f"{path!r} is not a nitsche-dolfinx checkpoint"
    if content.get("version") != _VERSION:
        return f"{path!r} has checkpoint version {content.get('version')!r}, expected {_VERSION}"
    return content


def read_checkpoint(folder: str, comm) -> tuple[dict, dict[str, np.ndarray]]:
    """Read a checkpoint: its metadata and the arrays of all the ranks that wrote it (collective).

    Returns:
        The metadata and the arrays, each the concatenation of every writing rank's
        array (in rank order), identical on every rank.

    Raises:
        CheckpointError: On every rank, naming what is missing or unreadable.
    """
    folder = str(folder)
    content = None
    if comm.rank == 0:
        content = _read_metadata(os.path.join(folder, CHECKPOINT_FILE))
    content = comm.bcast(content, root=0)
    agree(comm, content if isinstance(content, str) else None, CheckpointError)
    parts, error = [], None
    for rank in range(int(content["ranks"])):
        path = os.path.join(folder, _rank_file(content["state"], rank))
        try:
            with np.load(path) as data:
                parts.append({name: data[name] for name in data.files})
        except (OSError, ValueError) as exc:
            error = f"checkpoint file {path!r} cannot be read: {exc}"
            break
    agree(comm, error, CheckpointError)
    names = parts[0].keys() if parts else ()
    return content, {name: np.concatenate([part[name] for part in parts]) for name in names}


def match_points(saved: np.ndarray, points: np.ndarray, tolerance: float) -> np.ndarray:
    """For each row of ``points``, the index of the row of ``saved`` within ``tolerance``
    (max norm), or -1.

    The rows are snapped to a grid of spacing ``tolerance`` and compared by cell; a
    pair that a cell boundary separates is found on a second grid shifted by half a
    cell. The same node computed from two cells differs by round-off only, and two
    nodes of a mesh are far more than ``tolerance`` apart.
    """
    saved = np.asarray(saved, dtype=float).reshape(len(saved), -1)
    points = np.asarray(points, dtype=float).reshape(len(points), -1)
    index = np.full(len(points), -1, dtype=np.int64)
    for shift in (0.0, 0.5):
        todo = np.flatnonzero(index < 0)
        if todo.size == 0 or len(saved) == 0:
            break
        keys = np.floor(np.concatenate([saved, points[todo]]) / tolerance + shift)
        _, inverse = np.unique(keys.astype(np.int64), axis=0, return_inverse=True)
        inverse = np.asarray(inverse).reshape(-1)
        owner = np.full(inverse.max() + 1, -1, dtype=np.int64)
        owner[inverse[: len(saved)]] = np.arange(len(saved))
        index[todo] = owner[inverse[len(saved) :]]
    found = index >= 0
    distance = np.abs(saved[index[found]] - points[found]).max(axis=1, initial=0.0)
    index[np.flatnonzero(found)[distance > tolerance]] = -1
    return index


def _points_key(name: str, function, first_space) -> str:
    """The array of node coordinates of ``function``: shared by the functions on the
    first space, its own for a function on another space."""
    return "points" if function.function_space is first_space else f"{name}.points"


def save_state(stepper, folder: str, columns=None) -> SavedState:
    """Save the stepper's current time level in the checkpoint folder ``folder``
    (collective); ``columns``, the history columns of the run, are recorded so that a
    restart writing other columns is refused."""
    functions = stepper.checkpoint_functions()
    first_space = next(iter(functions.values())).function_space
    arrays = {}
    for name, f in functions.items():
        V = f.function_space
        owned, bs = V.dofmap.index_map.size_local, V.dofmap.index_map_bs
        arrays[name] = f.x.array.reshape(-1, bs)[:owned]
        key = _points_key(name, f, first_space)
        if key not in arrays:
            arrays[key] = compat.node_coordinates(V)[:owned]
    metadata = {
        **stepper.describe(),
        **stepper.levels(),
        "newton_iterations": int(stepper.newton_iterations),
        "columns": list(columns) if columns is not None else None,
    }
    return write_checkpoint(folder, stepper.comm, stepper.step_index, stepper.t, arrays, metadata)


def load_state(stepper, folder: str, columns=None) -> SavedState:
    """Restore the time level saved in ``folder`` by :func:`save_state` (collective).

    The values are matched to the dofs by the coordinates of their nodes, so any
    partition of the same mesh, on any number of ranks, reloads them.

    Raises:
        CheckpointError: On every rank, if the checkpoint is missing or unreadable, or
            was written for another mesh, space, scheme, time step, Nitsche parameters
            or set of history columns, or lies past t_end.
    """
    metadata, arrays = read_checkpoint(folder, stepper.comm)
    changes = {}
    for key, value in stepper.describe().items():
        if metadata.get(key) == value:
            continue
        if key in CHANGEABLE:
            changes[key] = (metadata.get(key), value)
            continue
        raise CheckpointError(
            f"checkpoint {folder!r} does not fit this run: its {key} is "
            f"{metadata.get(key)!r}, this run's is {value!r}"
        )
    saved_columns = metadata.get("columns")
    if columns is not None and saved_columns is not None and saved_columns != list(columns):
        try:
            added_columns(saved_columns, columns)
        except ValueError as error:
            raise CheckpointError(f"checkpoint {folder!r} does not fit this run: {error}") from None
        changes["history columns"] = (",".join(saved_columns), ",".join(columns))
    if metadata["t"] > stepper.t_end:
        raise CheckpointError(
            f"checkpoint {folder!r} is at t = {metadata['t']:.6g}, past t_end = {stepper.t_end:g}"
        )
    functions = stepper.checkpoint_functions()
    first_space = next(iter(functions.values())).function_space
    for name, function in functions.items():
        if name not in arrays:  # a Function a checkpoint of an older version did not keep
            continue
        key = _points_key(name, function, first_space)
        index = _matching_nodes(stepper.comm, folder, arrays[key], function.function_space)
        bs = function.function_space.dofmap.index_map_bs
        function.x.array.reshape(-1, bs)[:] = arrays[name][index]
    stepper.restore(float(metadata["t"]), int(metadata["step"]), metadata)
    return SavedState(str(folder), stepper.step_index, stepper.t, changes)


def _matching_nodes(comm, folder, saved_points, V) -> np.ndarray:
    """For each node of V on this rank, the row of the saved nodes at the same place."""
    points = compat.node_coordinates(V)
    extent = comm.allreduce(float(np.abs(points).max(initial=0.0)), op=MPI.MAX)
    index = match_points(saved_points, points, 1e-8 * max(extent, 1.0))
    missing = int(np.count_nonzero(index < 0))
    agree(
        comm,
        f"checkpoint {folder!r} does not fit this run: {missing} of its nodes are not "
        "nodes of this mesh (another mesh?)"
        if missing
        else None,
        CheckpointError,
    )
    return index
