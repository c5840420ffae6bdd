"""Meshes with tagged boundaries, and the cell size h_T of the Nitsche parameter."""

from __future__ import annotations

import os

import numpy as np
from dolfinx import fem
from dolfinx import mesh as dmesh
from mpi4py import MPI

from . import compat

__all__ = [
    "bar_mesh",
    "block_mesh",
    "cell_diameter",
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
    mesh.topology.create_connectivity(fdim, mesh.topology.dim)
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
):
    """Read a mesh and its facet tags from a gmsh ``.msh`` file or an XDMF file.

    In a ``.msh`` file, the physical groups of dimension tdim - 1 become the facet
    tags (their tag is the physical group's number). An XDMF file must hold the mesh
    called ``mesh_name`` and the facet tags called ``facet_tags_name``. Rank 0
    reads a ``.msh`` file and distributes the mesh.

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
        ValueError: The file is missing, of an unknown kind, or cannot be read.
    """
    path = str(path)
    if os.path.isdir(path):
        raise ValueError(f"mesh file {path!r} is a folder, not a mesh file")
    if not os.path.isfile(path):
        raise ValueError(f"mesh file {path!r} does not exist")
    extension = os.path.splitext(path)[1].lower()
    try:
        if extension == ".msh":
            return _load_msh(path, gdim, comm)
        if extension == ".xdmf":
            mesh, facet_tags = _load_xdmf(path, comm, mesh_name, facet_tags_name)
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


def _load_msh(path, gdim, comm):
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
    if facet_tags is None:
        raise ValueError(f"mesh file {path!r} has no physical groups on its boundary")
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
    from dolfinx.io import XDMFFile

    with XDMFFile(comm, path, "r") as xdmf:
        mesh = xdmf.read_mesh(name=mesh_name)
        mesh.topology.create_connectivity(mesh.topology.dim - 1, mesh.topology.dim)
        facet_tags = xdmf.read_meshtags(mesh, facet_tags_name)
    return mesh, facet_tags


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
