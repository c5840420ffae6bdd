"""The version differences of meshes: a gmsh model turned into a distributed mesh (with the
cell types every version reads, a partitioner of the package, gmsh started quietly and
SIGINT kept), a mesh whose cells stay on their ranks, and mesh tags written to XDMF.
"""

from __future__ import annotations

import contextlib
import importlib
import inspect
import os
import signal
import threading

import dolfinx.cpp
import dolfinx.io
import dolfinx.mesh
import numpy as np
import ufl

__all__ = [
    "GMSH_CELL_TYPES",
    "cell_partitioner",
    "gmsh_model_to_mesh",
    "mesh_keeping_cells",
    "sigint_kept",
    "start_gmsh",
    "write_meshtags",
]

# dolfinx partitions a mesh with PT-Scotch, whose threads (as many as the machine has
# cores) make the partition, and so the nodes' order and every sum over them, change from
# one mpirun to the next. One thread makes it the same on the same ranks (docs/method.md
# section 8, "Reproducible partitions"); a value the user set is kept. Scotch reads it
# when it partitions, so setting it here, after dolfinx is loaded, is in time.
os.environ.setdefault("SCOTCH_PTHREAD_NUMBER", "1")


def gmsh_model_to_mesh(model, comm, rank: int, gdim: int, partitioner=None):
    """Convert a gmsh model into ``(mesh, cell_tags, facet_tags)``, the cells sent to
    the ranks by ``partitioner`` if given (no ghost cells), else by dolfinx's default.

    ``dolfinx.io.gmshio.model_to_mesh`` returns a tuple up to 0.9;
    ``dolfinx.io.gmsh.model_to_mesh`` returns a named tuple from 0.10. In 0.5 it takes
    no partitioner: its call of ``create_mesh`` is given one for the time of the call.
    """
    module = getattr(dolfinx.io, "gmsh", None)
    if module is None or not hasattr(module, "model_to_mesh"):
        with sigint_kept():
            module = _import_gmshio()
    if partitioner is None:
        result = module.model_to_mesh(model, comm, rank, gdim=gdim)
    elif "partitioner" in inspect.signature(module.model_to_mesh).parameters:
        result = module.model_to_mesh(model, comm, rank, gdim=gdim, partitioner=partitioner)
    else:  # 0.5
        create_mesh = module.create_mesh

        def partitioned(comm, cells, x, domain):
            return create_mesh(comm, cells, x, domain, dolfinx.mesh.GhostMode.none, partitioner)

        module.create_mesh = partitioned
        try:
            result = module.model_to_mesh(model, comm, rank, gdim=gdim)
        finally:
            module.create_mesh = create_mesh
    if hasattr(result, "mesh"):
        return result.mesh, result.cell_tags, result.facet_tags
    return result[0], result[1], result[2]


#: The gmsh element types that every supported dolfinx reads as cells, with the names
#: the messages give them: complete Lagrange lines, triangles, quadrilaterals, tetrahedra
#: and hexahedra of order 1 and 2 (dolfinx 0.5 reads no prisms, pyramids, nor serendipity
#: elements; the package's geometries are of order 1 or 2).
GMSH_CELL_TYPES = {
    1: "lines", 2: "triangles", 3: "quadrilaterals", 4: "tetrahedra", 5: "hexahedra",
    8: "second-order lines", 9: "second-order triangles", 10: "second-order quadrilaterals",
    11: "second-order tetrahedra", 12: "second-order hexahedra",
}  # fmt: skip


def start_gmsh(gmsh) -> None:
    """Initialise gmsh without its terminal output and without reading the user's gmsh
    configuration files (the meshes are the same on every machine); gmsh from 4.9 is
    told to leave SIGINT alone (``interruptible``, see :func:`sigint_kept`)."""
    if "interruptible" in inspect.signature(gmsh.initialize).parameters:
        gmsh.initialize(readConfigFiles=False, interruptible=False)
    else:
        gmsh.initialize(readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)


@contextlib.contextmanager
def sigint_kept():
    """Put back, after the block, the SIGINT handler of its start (in the main thread).

    gmsh takes SIGINT: 4.8 sets it to the default action when it is imported (as
    dolfinx's ``gmshio`` does) and puts back the handler of that time when finalised;
    4.9 on set it when initialised, and 4.13 never puts it back. Ctrl-C would then kill
    Python instead of raising KeyboardInterrupt, and the run's own handler
    (:mod:`nitsche_dolfinx.common.signals`) could be lost.
    """
    main = threading.current_thread() is threading.main_thread()
    handler = signal.getsignal(signal.SIGINT) if main else None
    try:
        yield
    finally:
        if main and handler is not None:
            signal.signal(signal.SIGINT, handler)


def cell_partitioner(owners, num_vertices: int):
    """A cell partitioner for ``dolfinx.mesh.create_mesh`` (and :func:`gmsh_model_to_mesh`)
    that sends each cell to the rank ``owners(vertices, parts)`` gives it (``vertices``:
    the cells' vertices, shape (cells, num_vertices); ``parts``: the number of ranks).

    dolfinx 0.5 calls it with ``(comm, parts, tdim, cells as an AdjacencyList, ghost
    mode)`` and finds the vertices shared between ranks through ghost cells (dropped
    afterwards with ``GhostMode.none``): each cell also goes to the other ranks that own a
    cell with one of its vertices. dolfinx 0.9 on calls it with ``(comm, parts, cell
    types, cells as a list of arrays, one per cell type)`` and wants the owner alone.
    """

    def partition(comm, parts, *args):
        cells = next(a for a in args if hasattr(a, "array") or _arrays(a))
        legacy = hasattr(cells, "array")
        if legacy:
            cells = cells.array
        else:
            cells = np.concatenate([np.asarray(c).ravel() for c in cells])
        vertices = np.asarray(cells, dtype=np.int64).reshape(-1, num_vertices)
        ranks = np.asarray(owners(vertices, parts), dtype=np.int32)
        if legacy:
            return _with_sharing_ranks(vertices, ranks, parts)
        offsets = np.arange(len(vertices) + 1, dtype=np.int32)
        return dolfinx.cpp.graph.AdjacencyList_int32(ranks, offsets)

    return partition


def _arrays(value) -> bool:
    """Whether ``value`` is a non-empty list of arrays."""
    listed = isinstance(value, (list, tuple)) and len(value) > 0
    return listed and all(hasattr(v, "shape") for v in value)


def _with_sharing_ranks(vertices: np.ndarray, owners: np.ndarray, parts: int):
    """The destinations of cells given to ``owners`` for dolfinx 0.5 (see
    :func:`cell_partitioner`): each cell's owner, then the other ranks owning a cell that
    has one of its vertices."""
    holds = np.zeros((vertices.max(initial=-1) + 1, parts), dtype=bool)
    holds[vertices, owners[:, None]] = True
    sharing = holds[vertices].any(axis=1)  # (cells, parts)
    sharing[np.arange(len(owners)), owners] = False
    cells, ranks = np.nonzero(sharing)  # by cell, then by rank
    others = np.bincount(cells, minlength=len(owners))
    offsets = np.concatenate(([0], np.cumsum(1 + others))).astype(np.int32)
    destinations = np.empty(offsets[-1], dtype=np.int32)
    destinations[offsets[:-1]] = owners
    first = np.concatenate(([0], np.cumsum(others)[:-1]))  # of each cell's, in ``cells``
    destinations[offsets[cells] + 1 + np.arange(len(cells)) - first[cells]] = ranks
    return dolfinx.cpp.graph.AdjacencyList_int32(destinations, offsets)


def _import_gmshio():
    try:
        from dolfinx.io import gmshio  # 0.6 - 0.9
    except ImportError:  # 0.5: gmshio is a submodule that must be imported explicitly
        gmshio = importlib.import_module("dolfinx.io.gmshio")
    return gmshio


def write_meshtags(xdmf, tags, mesh) -> None:
    """Write mesh tags to an open XDMFFile (the geometry argument appeared in 0.6)."""
    try:
        xdmf.write_meshtags(tags, mesh.geometry)
    except TypeError:  # 0.5: the geometry is taken from the tags' mesh
        xdmf.write_meshtags(tags)


def mesh_keeping_cells(comm, cells: np.ndarray, x: np.ndarray, cell: str, degree: int, sharing):
    """A mesh with a Lagrange geometry of ``degree``, each of its cells kept on the rank that
    gives it: ``cells`` are this rank's cells as rows of global node indices (in the node
    order of the Lagrange element), ``x`` its consecutive share of the nodes (num_nodes,
    gdim), by global index.

    The partition is a function that sends every cell to its own rank. dolfinx 0.5 (whose
    ``create_mesh`` takes a ghost mode) finds the nodes shared between ranks through the
    ghost cells of that partition, and drops these cells afterwards for ``GhostMode.none``:
    there each cell also goes, as a ghost, to the other ranks that hold one of its nodes,
    given by ``sharing()`` (collective) as ``(offsets, ranks)``, the cell's own rank first.
    dolfinx 0.9 and 0.11 find the shared nodes by their global indices: the rank alone is
    given.
    """
    gdim = x.shape[1]
    ghost_mode = "ghost_mode" in inspect.signature(dolfinx.mesh.create_mesh).parameters
    if ghost_mode:  # 0.5
        offsets, ranks = sharing()
        element = ufl.VectorElement("Lagrange", ufl.Cell(cell, geometric_dimension=gdim), degree)
    else:
        import basix.ufl  # (from 0.7: absent with UFL 2022's elements)

        offsets = np.arange(len(cells) + 1)
        ranks = np.full(len(cells), comm.rank)
        element = basix.ufl.element("Lagrange", cell, degree, shape=(gdim,))
    destinations = dolfinx.cpp.graph.AdjacencyList_int32(
        np.asarray(ranks, dtype=np.int32), np.asarray(offsets, dtype=np.int32)
    )

    def partition(*args):
        return destinations

    cells = np.asarray(cells, dtype=np.int64).reshape(len(cells), -1)
    x = np.ascontiguousarray(x, dtype=np.float64)
    if ghost_mode:
        return dolfinx.mesh.create_mesh(
            comm, cells, x, ufl.Mesh(element), dolfinx.mesh.GhostMode.none, partition
        )
    return dolfinx.mesh.create_mesh(comm, cells, x=x, e=ufl.Mesh(element), partitioner=partition)
