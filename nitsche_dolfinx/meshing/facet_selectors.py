"""Facet tags chosen by selectors: :func:`tag_facets` tags the boundary facets of any mesh
by their position or their outward normal (:class:`OnPlane`, :class:`NormalWithin`,
:class:`InBox`, or a function of the coordinates), keeping the tags it had; and the
vertices and cells of facets (:func:`facet_vertices`, :func:`facet_cells`).
"""

from __future__ import annotations

import numpy as np
from dolfinx import mesh as dmesh
from mpi4py import MPI

from ..common import compat

__all__ = [
    "InBox",
    "NormalWithin",
    "OnPlane",
    "facet_cells",
    "facet_vertices",
    "tag_cells",
    "tag_facets",
]


def tag_cells(mesh, boxes: dict, cell_tags=None):
    """Cell tags of the cells whose vertices all lie in a box, for a region of a mesh
    without physical groups of cells (or to add regions to its tags).

    Args:
        mesh: The mesh.
        boxes: ``{tag: InBox}``; a cell chosen by several keeps the last tag.
        cell_tags: Existing cell tags to keep where no box chooses the cell.

    Returns:
        The cell meshtags, the same on any partition (from the cells' coordinates).

    Raises:
        ValueError: A box chooses no cell.
    """
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim, 0)
    cells = np.arange(mesh.topology.index_map(tdim).size_local
                      + mesh.topology.index_map(tdim).num_ghosts, dtype=np.int32)  # fmt: skip
    x = mesh.geometry.x
    cell_vertices = mesh.topology.connectivity(tdim, 0)
    per_cell = cell_vertices.offsets[1] - cell_vertices.offsets[0]
    vertices = x[_vertex_nodes(mesh)[cell_vertices.array.reshape(-1, per_cell)]]
    extent = max(mesh.comm.allreduce(float(np.abs(x).max(initial=0.0)), op=MPI.MAX), 1e-300)
    indices, values = [], []
    if cell_tags is not None:
        indices.append(np.asarray(cell_tags.indices, dtype=np.int32))
        values.append(np.asarray(cell_tags.values, dtype=np.int32))
    for tag, box in boxes.items():
        tolerance = 1e-8 * extent if box.tolerance is None else box.tolerance
        inside = (vertices >= box.lower - tolerance) & (vertices <= box.upper + tolerance)
        chosen = inside.all(axis=(1, 2))
        if mesh.comm.allreduce(int(np.count_nonzero(chosen)), op=MPI.SUM) == 0:
            raise ValueError(f"the box of cell tag {tag!r} holds no cell of the mesh")
        indices.append(cells[chosen])
        values.append(np.full(np.count_nonzero(chosen), tag, dtype=np.int32))
    indices = np.concatenate(indices or [np.zeros(0, np.int32)])
    values = np.concatenate(values or [np.zeros(0, np.int32)])
    unique, last = np.unique(indices[::-1], return_index=True)  # the last tag of each cell
    return dmesh.meshtags(mesh, tdim, unique.astype(np.int32), values[::-1][last])


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
    extent of the mesh (the largest abs(coordinate) on any rank)."""

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
    point in 1D): abs((x - point) . normal) <= tolerance.

    Args:
        point: A point of the plane.
        normal: A normal of the plane (any length but zero).
        tolerance: The distance allowed; default 1e-8 times the largest abs(coordinate) of
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
        """Whether each facet of ``geometry`` lies on the plane (a bool per facet)."""
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
        """Whether the outward normal of each facet of ``geometry`` is within the angle
        (a bool per facet)."""
        cosine = np.clip(geometry.normals @ self.direction, -1.0, 1.0)
        return np.degrees(np.arccos(cosine)) <= self.angle + 1e-9


class InBox:
    """Chooses the boundary facets whose vertices all lie in the box ``lower <= x <=
    upper`` (widened by ``tolerance``, default 1e-8 times the mesh's largest abs(coordinate)).
    """

    def __init__(self, lower, upper, tolerance: float | None = None):
        self.lower, self.upper = _vector(lower, "box corner"), _vector(upper, "box corner")
        if np.any(self.lower > self.upper):
            raise ValueError(f"the box needs lower <= upper, got {lower!r} and {upper!r}")
        self.tolerance = tolerance

    def choose(self, geometry: _FacetGeometry) -> np.ndarray:
        """Whether each facet of ``geometry`` lies in the box (a bool per facet)."""
        tolerance = 1e-8 * geometry.extent if self.tolerance is None else self.tolerance
        vertices = geometry.vertices
        inside = (vertices >= self.lower - tolerance) & (vertices <= self.upper + tolerance)
        return inside.all(axis=(1, 2))
