"""Meshes with tagged boundaries, and the cell size h_T of the Nitsche parameter.

:func:`tag_facets` tags the boundary facets of any mesh by selectors on their
position or their outward normal (:class:`OnPlane`, :class:`NormalWithin`,
:class:`InBox`, or a function of the coordinates), keeping the tags it had.
"""

from __future__ import annotations

import os

import numpy as np
from dolfinx import fem
from dolfinx import mesh as dmesh
from mpi4py import MPI

from . import compat

__all__ = [
    "InBox",
    "NormalWithin",
    "OnPlane",
    "bar_mesh",
    "block_mesh",
    "cell_diameter",
    "contact_bisection",
    "facet_cells",
    "facet_vertices",
    "load_mesh",
    "save_mesh",
    "tag_facets",
    "BAR_CONTACT",
    "BAR_CLAMPED",
    "BLOCK_CONTACT",
]

_NUM_VERTICES = {
    "interval": 2,
    "triangle": 3,
    "tetrahedron": 4,
    "quadrilateral": 4,
    "hexahedron": 8,
}

#: Facet tags of :func:`bar_mesh`: the wall side x = 0 and the clamped end x = L.
BAR_CONTACT = 1
BAR_CLAMPED = 2
#: Facet tag of :func:`block_mesh`: its bottom y = 0.
BLOCK_CONTACT = 1


def contact_bisection(x: np.ndarray, contact: np.ndarray, num_vertices: int):
    """A cell partitioner for ``dolfinx.mesh.create_mesh`` that spreads the contact
    boundary over the ranks: recursive coordinate bisection of the cells by their
    centroids, each cut across the direction in which the contact nodes of the part
    extend most (the cells' own extent where it holds none), at the median that gives
    each side cells in proportion to its ranks. The default graph partition often
    leaves the whole contact zone on one rank, whose contact work the others then
    wait for (docs/method.md section 8).

    Args:
        x: The nodes, by input index (num_nodes, 3); the rows that the partitioner's
            cells index. Empty on ranks that give no cells.
        contact: The coordinates of the nodes of the contact boundary (n, 3).
        num_vertices: The vertices of a cell.
    """
    import dolfinx.cpp

    def partition(comm, parts, *args):
        # 0.5: (tdim, cells as an adjacency list, ghost mode); 0.9 on: (cell types,
        # cells as an array per cell type)
        cells = next(a for a in args if hasattr(a, "array") or _arrays(a))
        legacy = hasattr(cells, "array")
        if legacy:
            cells = cells.array
        else:
            cells = np.concatenate([np.asarray(c).ravel() for c in cells])
        vertices = np.asarray(cells, dtype=np.int64).reshape(-1, num_vertices)
        owners = np.zeros(len(vertices), dtype=np.int32)
        if len(vertices):
            centroids = x[vertices].mean(axis=1)
            _bisect(centroids, contact, np.arange(len(vertices)), 0, parts, owners)
        if legacy:
            return _with_sharing_ranks(vertices, owners, parts)
        offsets = np.arange(len(vertices) + 1, dtype=np.int32)
        return dolfinx.cpp.graph.AdjacencyList_int32(owners, offsets)

    return partition


def _with_sharing_ranks(vertices: np.ndarray, owners: np.ndarray, parts: int):
    """The destinations of cells given to ``owners`` for dolfinx 0.5, which finds the
    vertices shared between ranks through ghost cells (dropped afterwards with
    GhostMode.none): each cell's owner, then the other ranks owning a cell that has one
    of its vertices."""
    import dolfinx.cpp

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


def _arrays(value) -> bool:
    """Whether ``value`` is a non-empty list of arrays."""
    listed = isinstance(value, (list, tuple)) and len(value) > 0
    return listed and all(hasattr(v, "shape") for v in value)


def _bisect(centroids, contact, cells, first: int, parts: int, destinations) -> None:
    """Give ``cells`` to ranks ``first`` to ``first + parts - 1`` (see contact_bisection)."""
    if parts == 1:
        destinations[cells] = first
        return
    points = centroids[cells]
    low, high = points.min(axis=0), points.max(axis=0)
    inside = contact[np.all((contact >= low) & (contact <= high), axis=1)]
    spread = inside if len(inside) > 1 else points
    axis = int(np.argmax(spread.max(axis=0) - spread.min(axis=0)))
    order = cells[np.argsort(points[:, axis], kind="stable")]
    left = parts // 2
    cut = len(cells) * left // parts
    _bisect(centroids, contact, order[:cut], first, left, destinations)
    _bisect(centroids, contact, order[cut:], first + left, parts - left, destinations)


def cell_diameter(mesh) -> fem.Function:
    """h_T, the largest distance between two vertices of each cell, as a DG0 Function.

    Computed from the vertex coordinates, so it also works on second-order
    geometries (where FFCx 0.5 cannot generate ``ufl.CellDiameter``).
    """
    tdim = mesh.topology.dim
    num_cells = mesh.topology.index_map(tdim).size_local + mesh.topology.index_map(tdim).num_ghosts
    nodes = compat.geometry_dofmap(mesh)[:num_cells, : _NUM_VERTICES[compat.cell_name(mesh)]]
    vertices = mesh.geometry.x[nodes]  # (cells, vertices, 3)
    differences = vertices[:, :, None, :] - vertices[:, None, :, :]
    diameters = np.sqrt((differences**2).sum(axis=-1)).max(axis=(1, 2))
    Q = compat.function_space(mesh, "DG", 0)
    h = fem.Function(Q, name="h")
    h.x.array[compat.dofmap_array(Q)[:num_cells, 0]] = diameters
    return h


def tag_facets(mesh, selectors: dict, facet_tags=None):
    """Facet tags of the boundary facets that selectors choose, for a mesh without
    physical groups (or to add parts to its tags).

    Args:
        mesh: The mesh.
        selectors: ``{tag: selector}``. A selector is a function of the coordinates
            ``x`` (shape (3, N)) returning a bool array, true where a point belongs:
            a facet is chosen when all its vertices are; or :class:`OnPlane`,
            :class:`NormalWithin`, :class:`InBox`; or a list of these, all of which
            must choose the facet.
        facet_tags: Existing facet tags to keep (e.g. from a ``.msh`` file). A facet
            keeps one tag: the last selector's that chooses it, else its old one.

    Returns:
        The facet meshtags, the same on any partition (each rank tags its own and
        its ghost facets from their coordinates).

    Raises:
        ValueError: A selector chooses no boundary facet of the mesh.
    """
    fdim = mesh.topology.dim - 1
    facets = _boundary_facets(mesh)
    geometry = _FacetGeometry(mesh, facets)
    indices, values = [], []
    if facet_tags is not None:
        indices.append(np.asarray(facet_tags.indices, dtype=np.int32))
        values.append(np.asarray(facet_tags.values, dtype=np.int32))
    for tag, selector in selectors.items():
        parts = selector if isinstance(selector, (list, tuple)) else [selector]
        chosen = np.ones(len(facets), dtype=bool)
        for part in parts:
            chosen &= _selector(part).choose(geometry)
        if mesh.comm.allreduce(int(np.count_nonzero(chosen)), op=MPI.SUM) == 0:
            raise ValueError(f"the facet selector of tag {tag!r} chooses no boundary facet")
        indices.append(facets[chosen].astype(np.int32))
        values.append(np.full(np.count_nonzero(chosen), tag, dtype=np.int32))
    indices = np.concatenate(indices or [np.zeros(0, np.int32)])
    values = np.concatenate(values or [np.zeros(0, np.int32)])
    # a facet keeps its last tag: unique on the reversed arrays finds the last occurrence
    unique, last = np.unique(indices[::-1], return_index=True)
    return dmesh.meshtags(mesh, fdim, unique.astype(np.int32), values[::-1][last])


def _boundary_facets(mesh) -> np.ndarray:
    """Local indices of the facets on the boundary of the mesh (owned and ghosts)."""
    fdim = mesh.topology.dim - 1
    mesh.topology.create_connectivity(fdim, mesh.topology.dim)
    return dmesh.locate_entities_boundary(mesh, fdim, lambda x: np.ones(x.shape[1], dtype=bool))


class _FacetGeometry:
    """The vertices of some boundary facets (shape (facets, vertices, 3)), their outward
    unit normals from the vertices (of the straight facet, on curved cells too) and the
    extent of the mesh (the largest |coordinate| on any rank)."""

    def __init__(self, mesh, facets: np.ndarray):
        tdim = mesh.topology.dim
        x = mesh.geometry.x
        nodes = _vertex_nodes(mesh)
        self.vertices = x[nodes[facet_vertices(mesh, facets)]]
        first_cell = facet_cells(mesh, facets)
        cell_vertices = mesh.topology.connectivity(tdim, 0)
        per_cell = cell_vertices.offsets[1] - cell_vertices.offsets[0]
        cell_centres = x[nodes[cell_vertices.array.reshape(-1, per_cell)[first_cell]]].mean(axis=1)
        self.normals = _outward_normals(self.vertices, cell_centres)
        local = float(np.abs(x).max(initial=0.0))
        self.extent = max(mesh.comm.allreduce(local, op=MPI.MAX), 1e-300)


def facet_vertices(mesh, facets: np.ndarray) -> np.ndarray:
    """The vertices of each of ``facets``, shape (facets, vertices per facet); in 1D a
    facet is its vertex."""
    fdim = mesh.topology.dim - 1
    if fdim == 0:
        return np.asarray(facets)[:, None]
    mesh.topology.create_connectivity(fdim, 0)
    connectivity = mesh.topology.connectivity(fdim, 0)
    per_facet = connectivity.offsets[1] - connectivity.offsets[0]
    return connectivity.array.reshape(-1, per_facet)[facets]


def facet_cells(mesh, facets: np.ndarray) -> np.ndarray:
    """The first cell of each of ``facets`` (the cell of a boundary facet)."""
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    connectivity = mesh.topology.connectivity(tdim - 1, tdim)
    return connectivity.array[connectivity.offsets[facets]]


def _vertex_nodes(mesh) -> np.ndarray:
    """The geometry node of each vertex: the first nodes of a cell are its vertices, in
    the order of the topology (as for :func:`cell_diameter`)."""
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim, 0)
    connectivity = mesh.topology.connectivity(tdim, 0)
    per_cell = connectivity.offsets[1] - connectivity.offsets[0]
    cell_vertices = connectivity.array.reshape(-1, per_cell)
    num_vertices = mesh.topology.index_map(0).size_local + mesh.topology.index_map(0).num_ghosts
    nodes = np.zeros(num_vertices, dtype=np.int64)
    nodes[cell_vertices] = compat.geometry_dofmap(mesh)[: len(cell_vertices), :per_cell]
    return nodes


def _outward_normals(vertices: np.ndarray, cell_centres: np.ndarray) -> np.ndarray:
    """Unit normals of straight facets pointing away from their cell: the direction from
    the cell's centre to the facet's, without its components along the facet's edges."""
    normals = vertices.mean(axis=1) - cell_centres
    for k in range(1, vertices.shape[1]):  # Gram-Schmidt against the edges from vertex 0
        edges = vertices[:, k] - vertices[:, 0]
        for previous in range(1, k):
            before = vertices[:, previous] - vertices[:, 0]
            before = before / np.maximum(np.linalg.norm(before, axis=1), 1e-300)[:, None]
            edges = edges - (edges * before).sum(axis=1)[:, None] * before
        length = np.linalg.norm(edges, axis=1)
        tangent = np.where(length[:, None] > 0, edges / np.maximum(length, 1e-300)[:, None], 0.0)
        normals = normals - (normals * tangent).sum(axis=1)[:, None] * tangent
    return normals / np.maximum(np.linalg.norm(normals, axis=1), 1e-300)[:, None]


class _Predicate:
    """A function of the coordinates, true at every vertex of a chosen facet."""

    def __init__(self, function):
        self.function = function

    def choose(self, geometry: _FacetGeometry) -> np.ndarray:
        count, per_facet = geometry.vertices.shape[:2]
        points = geometry.vertices.reshape(-1, 3).T
        inside = np.asarray(self.function(points), dtype=bool).reshape(-1)
        if inside.shape != (count * per_facet,):
            raise ValueError(
                f"a facet selector must return one bool per point, got shape {inside.shape} "
                f"for {count * per_facet} points"
            )
        return inside.reshape(count, per_facet).all(axis=1)


def _selector(selector):
    if hasattr(selector, "choose"):
        return selector
    if callable(selector):
        return _Predicate(selector)
    raise ValueError(
        f"a facet selector is a function of x, OnPlane, NormalWithin or InBox, got {selector!r}"
    )


def _vector(values, what: str) -> np.ndarray:
    vector = np.zeros(3)
    values = np.asarray(values, dtype=float).reshape(-1)
    if not 1 <= values.size <= 3 or not np.all(np.isfinite(values)):
        raise ValueError(f"{what} must have 1 to 3 finite coordinates, got {values.tolist()}")
    vector[: values.size] = values
    return vector


class OnPlane:
    """Chooses the boundary facets whose vertices all lie on a plane (a line in 2D, a
    point in 1D): |(x - point) . normal| <= tolerance.

    Args:
        point: A point of the plane.
        normal: A normal of the plane (any length but zero).
        tolerance: The distance allowed; default 1e-8 times the largest |coordinate| of
            the mesh.
    """

    def __init__(self, point, normal, tolerance: float | None = None):
        self.point = _vector(point, "plane point")
        normal = _vector(normal, "plane normal")
        if not np.linalg.norm(normal) > 0:
            raise ValueError("the plane normal must not be zero")
        self.normal = normal / np.linalg.norm(normal)
        self.tolerance = tolerance

    def choose(self, geometry: _FacetGeometry) -> np.ndarray:
        tolerance = 1e-8 * geometry.extent if self.tolerance is None else self.tolerance
        distance = np.abs((geometry.vertices - self.point) @ self.normal)
        return (distance <= tolerance).all(axis=1)


class NormalWithin:
    """Chooses the boundary facets whose outward unit normal makes an angle of at most
    ``angle`` degrees with ``direction`` (the normal of the straight facet through its
    vertices, also on curved cells).

    Args:
        direction: The direction (any length but zero).
        angle: The largest angle, in degrees, in [0, 180].
    """

    def __init__(self, direction, angle: float = 1.0):
        direction = _vector(direction, "normal direction")
        if not np.linalg.norm(direction) > 0:
            raise ValueError("the normal direction must not be zero")
        if not 0.0 <= float(angle) <= 180.0:
            raise ValueError(f"the angle must lie in [0, 180] degrees, got {angle!r}")
        self.direction = direction / np.linalg.norm(direction)
        self.angle = float(angle)

    def choose(self, geometry: _FacetGeometry) -> np.ndarray:
        cosine = np.clip(geometry.normals @ self.direction, -1.0, 1.0)
        return np.degrees(np.arccos(cosine)) <= self.angle + 1e-9


class InBox:
    """Chooses the boundary facets whose vertices all lie in the box ``lower <= x <=
    upper`` (widened by ``tolerance``, default 1e-8 times the mesh's largest |coordinate|).
    """

    def __init__(self, lower, upper, tolerance: float | None = None):
        self.lower, self.upper = _vector(lower, "box corner"), _vector(upper, "box corner")
        if np.any(self.lower > self.upper):
            raise ValueError(f"the box needs lower <= upper, got {lower!r} and {upper!r}")
        self.tolerance = tolerance

    def choose(self, geometry: _FacetGeometry) -> np.ndarray:
        tolerance = 1e-8 * geometry.extent if self.tolerance is None else self.tolerance
        vertices = geometry.vertices
        inside = (vertices >= self.lower - tolerance) & (vertices <= self.upper + tolerance)
        return inside.all(axis=(1, 2))


def bar_mesh(nx: int = 100, length: float = 1.0, comm=MPI.COMM_WORLD):
    """The 1D bar (0, length) with ``nx`` cells; facets tagged :data:`BAR_CONTACT` at x = 0
    and :data:`BAR_CLAMPED` at x = length.

    Returns:
        ``(mesh, facet_tags)``.
    """
    if int(nx) < 1:
        raise ValueError(f"the bar needs at least one cell, got nx={nx!r}")
    mesh = dmesh.create_interval(comm, int(nx), [0.0, float(length)])
    tags = tag_facets(
        mesh,
        {
            BAR_CONTACT: lambda x: np.isclose(x[0], 0.0),
            BAR_CLAMPED: lambda x: np.isclose(x[0], length),
        },
    )
    return mesh, tags


def block_mesh(
    width: float = 2.0, height: float = 1.0, nx: int = 8, ny: int = 4, comm=MPI.COMM_WORLD
):
    """The rectangle (-width/2, width/2) x (0, height) in triangles; its bottom y = 0 is
    tagged :data:`BLOCK_CONTACT`.

    Returns:
        ``(mesh, facet_tags)``.
    """
    if not (width > 0 and height > 0):
        raise ValueError(f"the block needs a positive size, got {width!r} x {height!r}")
    if int(nx) < 1 or int(ny) < 1:
        raise ValueError(f"the block needs at least one cell each way, got nx={nx!r}, ny={ny!r}")
    corners = [np.array([-width / 2, 0.0]), np.array([width / 2, height])]
    mesh = dmesh.create_rectangle(comm, corners, [int(nx), int(ny)], dmesh.CellType.triangle)
    tags = tag_facets(mesh, {BLOCK_CONTACT: lambda x: np.isclose(x[1], 0.0)})
    return mesh, tags


def load_mesh(
    path: str,
    gdim: int | None = None,
    comm=MPI.COMM_WORLD,
    mesh_name: str = "mesh",
    facet_tags_name: str = "facet_tags",
    facet_tags_required: bool = True,
):
    """Read a mesh and its facet tags from a gmsh ``.msh`` file or an XDMF file.

    In a ``.msh`` file, the physical groups of dimension tdim - 1 become the facet
    tags (their tag is the physical group's number). An XDMF file must hold the mesh
    called ``mesh_name`` and the facet tags called ``facet_tags_name``. Rank 0
    reads a ``.msh`` file and distributes the mesh. Without ``facet_tags_required``, a
    file without facet tags gives None for them (:func:`tag_facets` makes some).

    Args:
        path: The ``.msh`` or ``.xdmf`` file.
        gdim: Geometric dimension; from the file when omitted (a ``.msh`` file
            whose z coordinates are all zero is 2D). An XDMF file has its own: a
            different ``gdim`` is refused.
        comm: The communicator to distribute the mesh over.
        mesh_name: Name of the mesh in an XDMF file.
        facet_tags_name: Name of the facet tags in an XDMF file.

    Returns:
        ``(mesh, facet_tags)``.

    Raises:
        ValueError: The file is missing, of an unknown kind, or cannot be read, or has no
            facet tags and ``facet_tags_required``.
    """
    path = str(path)
    if os.path.isdir(path):
        raise ValueError(f"mesh file {path!r} is a folder, not a mesh file")
    if not os.path.isfile(path):
        raise ValueError(f"mesh file {path!r} does not exist")
    extension = os.path.splitext(path)[1].lower()
    try:
        if extension == ".msh":
            return _load_msh(path, gdim, comm, facet_tags_required)
        if extension == ".xdmf":
            tags_name = (
                facet_tags_name if facet_tags_required or _has_grid(path, facet_tags_name) else None
            )
            mesh, facet_tags = _load_xdmf(path, comm, mesh_name, tags_name)
            if gdim is not None and mesh.geometry.dim != gdim:
                raise ValueError(
                    f"mesh file {path!r} holds {mesh.geometry.dim}D coordinates, not "
                    f"gdim={gdim!r} (the geometric dimension of an XDMF mesh is its file's)"
                )
            return mesh, facet_tags
    except ValueError:
        raise
    except Exception as error:  # gmsh, HDF5 and dolfinx each raise their own kinds
        raise ValueError(f"mesh file {path!r} cannot be read: {error}") from error
    raise ValueError(f"mesh file {path!r}: unknown kind {extension!r} (use .msh or .xdmf)")


def _load_msh(path, gdim, comm, facet_tags_required: bool):
    if gdim is None:
        found = None
        if comm.rank == 0:
            try:
                found = _msh_dimension(path)
            except Exception as error:  # gmsh raises a bare Exception
                found = f"mesh file {path!r} cannot be read: {error}"
        found = comm.bcast(found, root=0)  # an error on rank 0 stops every rank
        if isinstance(found, str):
            raise ValueError(found)
        gdim = found
    mesh, _, facet_tags = compat.read_gmsh_file(path, comm, 0, gdim)
    # dolfinx 0.5 gives empty tags where later versions give None
    if facet_tags is None or comm.allreduce(len(facet_tags.values), op=MPI.SUM) == 0:
        if facet_tags_required:
            raise ValueError(f"mesh file {path!r} has no physical groups on its boundary")
        return mesh, None
    return mesh, facet_tags


def _msh_dimension(path: str) -> int:
    """The geometric dimension of a .msh file: 3 if any node has z != 0 or the mesh has
    volume elements, else 2 if any node has y != 0, else 1."""
    import gmsh

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(path)
        if gmsh.model.getEntities(3):
            return 3
        _, coordinates, _ = gmsh.model.mesh.getNodes()
        xyz = np.asarray(coordinates).reshape(-1, 3)
        if np.any(xyz[:, 2] != 0):
            return 3
        return 2 if gmsh.model.getEntities(2) or np.any(xyz[:, 1] != 0) else 1
    finally:
        gmsh.finalize()


def _load_xdmf(path, comm, mesh_name, facet_tags_name):
    """The mesh and the facet tags of an XDMF file (None for ``facet_tags_name``: none)."""
    from dolfinx.io import XDMFFile

    with XDMFFile(comm, path, "r") as xdmf:
        mesh = xdmf.read_mesh(name=mesh_name)
        mesh.topology.create_connectivity(mesh.topology.dim - 1, mesh.topology.dim)
        if facet_tags_name is None:
            return mesh, None
        facet_tags = xdmf.read_meshtags(mesh, facet_tags_name)
    return mesh, facet_tags


def _has_grid(path: str, name: str) -> bool:
    """Whether the XDMF file names a grid ``name``."""
    import xml.etree.ElementTree as ElementTree

    return any(grid.get("Name") == name for grid in ElementTree.parse(path).getroot().iter("Grid"))


def save_mesh(
    path: str, mesh, facet_tags, mesh_name: str = "mesh", facet_tags_name: str = "facet_tags"
) -> None:
    """Write a mesh and its facet tags to an XDMF file that :func:`load_mesh` reads back."""
    from dolfinx.io import XDMFFile

    mesh.name = mesh_name
    facet_tags.name = facet_tags_name
    with XDMFFile(mesh.comm, str(path), "w") as xdmf:
        xdmf.write_mesh(mesh)
        compat.write_meshtags(xdmf, facet_tags, mesh)
