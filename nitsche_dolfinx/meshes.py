"""Meshes with tagged boundaries, and the cell size h_T of the Nitsche parameter."""

from __future__ import annotations

import numpy as np
from dolfinx import fem
from dolfinx import mesh as dmesh
from mpi4py import MPI

from . import compat

__all__ = ["bar_mesh", "cell_diameter", "tag_facets", "BAR_CONTACT", "BAR_CLAMPED"]

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


def tag_facets(mesh, markers: dict[int, callable]):
    """Facet tags from geometric markers: ``{tag: lambda x: ...}`` on boundary facets."""
    fdim = mesh.topology.dim - 1
    compat.create_connectivity(mesh, fdim, mesh.topology.dim)
    facets, values = [], []
    for tag, marker in markers.items():
        found = dmesh.locate_entities_boundary(mesh, fdim, marker)
        facets.append(found)
        values.append(np.full(len(found), tag, dtype=np.int32))
    facets = np.concatenate(facets).astype(np.int32)
    values = np.concatenate(values)
    order = np.argsort(facets)
    return dmesh.meshtags(mesh, fdim, facets[order], values[order])


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
