"""Meshes with tagged boundaries, and the cell size h_T of the Nitsche parameter.

:func:`load_mesh` reads a gmsh ``.msh`` file (through
:func:`nitsche_dolfinx.meshing.gmsh_pipeline.read_msh`) or an XDMF file, refusing a bad file in
one line on every rank; :func:`bar_mesh` and :func:`block_mesh` are dolfinx's interval and
rectangle with their tags (the gmsh bodies are in :mod:`~nitsche_dolfinx.meshing.shapes` and
:mod:`~nitsche_dolfinx.meshing.two_bodies`). The facet selectors of
:mod:`~nitsche_dolfinx.meshing.facet_selectors`
are also found here.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ElementTree

import numpy as np
from dolfinx import fem
from dolfinx import mesh as dmesh
from dolfinx.io import XDMFFile
from mpi4py import MPI

from ..common import compat
from ..common.parameters import require
from .facet_selectors import tag_facets
from .gmsh_pipeline import check_file, from_root, read_msh

__all__ = [
    "MAX_CELLS",
    "bar_mesh",
    "block_mesh",
    "cell_diameter",
    "load_mesh",
    "save_mesh",
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

#: Facet tag of the wall side x = 0 of :func:`bar_mesh`.
BAR_CONTACT = 1
#: Facet tag of the clamped end x = length of :func:`bar_mesh`.
BAR_CLAMPED = 2
#: Facet tag of the bottom y = 0 of :func:`block_mesh`.
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


#: The most cells a generated mesh may have: more is a mistake in a size, not a mesh.
MAX_CELLS = 50_000_000


def _check_cells(count: int, name: str, value) -> None:
    """Refuse ``name=value`` that makes ``count`` cells, more than :data:`MAX_CELLS`."""
    require(
        count <= MAX_CELLS, name, value,
        f"would make {count:.3g} cells, more than {MAX_CELLS:.0e}",
    )  # fmt: skip


def bar_mesh(nx: int = 100, length: float = 1.0, comm=MPI.COMM_WORLD):
    """The 1D bar (0, length) with ``nx`` cells; facets tagged :data:`BAR_CONTACT` at x = 0
    and :data:`BAR_CLAMPED` at x = length.

    Returns:
        ``(mesh, facet_tags)``.
    """
    if int(nx) < 1:
        raise ValueError(f"the bar needs at least one cell, got nx={nx!r}")
    _check_cells(int(nx), "nx", nx)
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
    _check_cells(2 * int(nx) * int(ny), "nx" if nx >= ny else "ny", max(nx, ny))
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
    contact_tags=(),
    with_cell_tags: bool = False,
):
    """Read a mesh and its facet tags from a gmsh ``.msh`` file or an XDMF file.

    In a ``.msh`` file, the physical groups of the highest dimension make the cells and
    those of one dimension less the facet tags (their tag is the physical group's
    number); rank 0 reads it and distributes the mesh. An XDMF file must hold the mesh
    called ``mesh_name`` and the facet tags called ``facet_tags_name``. Without
    ``facet_tags_required``, a file without facet tags gives None for them
    (:func:`tag_facets` makes some). A file dolfinx cannot make a mesh of is refused
    before any collective work, on every rank alike.

    Args:
        path: The ``.msh`` or ``.xdmf`` file.
        gdim: Geometric dimension: that of the cells; a different one is refused.
        comm: The communicator to distribute the mesh over.
        mesh_name: Name of the mesh in an XDMF file.
        facet_tags_name: Name of the facet tags in an XDMF file.
        facet_tags_required: Refuse a file without facet tags.
        contact_tags: Facet tags of the contact boundary of a ``.msh`` file: the cells are
            partitioned with each rank given its share of them
            (:func:`~nitsche_dolfinx.meshing.partition.contact_bisection`); none: dolfinx's
            partition.
        with_cell_tags: Also return the cell tags: a ``.msh`` file's physical groups of
            cells (a material per region, bodies); None from an XDMF file.

    Returns:
        ``(mesh, facet_tags)``, or ``(mesh, cell_tags, facet_tags)`` ``with_cell_tags``.

    Raises:
        ValueError: One line naming the file and what is wrong: missing, a folder,
            empty, of an unknown kind, unreadable, without physical groups or facet tags,
            of cells dolfinx does not read, of mixed dimensions.
    """
    path = str(path)
    extension = os.path.splitext(path)[1].lower()
    if extension == ".msh":
        return read_msh(path, comm, gdim, facet_tags_required, tuple(contact_tags), with_cell_tags)
    has_tags = from_root(
        comm, lambda: _check_xdmf(path, extension, mesh_name, facet_tags_name, facet_tags_required)
    )
    tags_name = facet_tags_name if has_tags else None
    mesh, facet_tags = _read_xdmf(path, comm, gdim, mesh_name, tags_name)
    return (mesh, None, facet_tags) if with_cell_tags else (mesh, facet_tags)


def _read_xdmf(path: str, comm, gdim, mesh_name: str, facet_tags_name: str | None):
    """The mesh and facet tags of a checked XDMF file, whose cells fill its space."""
    try:
        mesh, facet_tags = _load_xdmf(path, comm, mesh_name, facet_tags_name)
    except Exception as error:  # HDF5 and dolfinx raise their own kinds, on every rank
        raise ValueError(f"mesh file {path!r} cannot be read: {error}") from error
    dim = mesh.geometry.dim
    if gdim is not None and dim != gdim:
        raise ValueError(
            f"mesh file {path!r} holds {dim}D coordinates, not gdim={gdim!r} (the geometric "
            "dimension of an XDMF mesh is its file's)"
        )
    if mesh.topology.dim != dim:
        raise ValueError(
            f"mesh file {path!r} holds {mesh.topology.dim}D cells in {dim}D: a mesh of a body "
            "has cells of the dimension of its space"
        )
    return mesh, facet_tags


def _check_xdmf(path: str, extension: str, mesh_name, facet_tags_name, required: bool) -> bool:
    """Whether the XDMF file has the facet tags, or a ValueError naming what is wrong with
    it: a missing or empty file, another kind, not XML, no grid of the mesh or the tags, a
    missing HDF5 file."""
    check_file(path)
    if extension != ".xdmf":
        raise ValueError(f"mesh file {path!r}: unknown kind {extension!r} (use .msh or .xdmf)")
    try:
        root = ElementTree.parse(path).getroot()
    except ElementTree.ParseError as error:
        raise ValueError(f"mesh file {path!r} is not an XDMF file (XML): {error}") from None
    grids = [grid.get("Name") for grid in root.iter("Grid")]
    listed = ", ".join(repr(name) for name in grids) or "none"
    if mesh_name not in grids:
        raise ValueError(f"mesh file {path!r} has no grid {mesh_name!r} (its grids: {listed})")
    if required and facet_tags_name not in grids:
        raise ValueError(
            f"mesh file {path!r} has no grid {facet_tags_name!r}, the facet tags (its grids: "
            f"{listed})"
        )
    folder = os.path.dirname(os.path.abspath(path))
    for item in root.iter("DataItem"):
        if item.get("Format") == "HDF" and item.text and ":" in item.text:
            data = os.path.join(folder, item.text.strip().split(":", 1)[0])
            if not os.path.isfile(data):
                raise ValueError(f"mesh file {path!r} refers to {data!r}, which does not exist")
    return facet_tags_name in grids


def _load_xdmf(path, comm, mesh_name, facet_tags_name):
    """The mesh and the facet tags of an XDMF file (None for ``facet_tags_name``: none)."""
    with XDMFFile(comm, path, "r") as xdmf:
        mesh = xdmf.read_mesh(name=mesh_name)
        mesh.topology.create_connectivity(mesh.topology.dim - 1, mesh.topology.dim)
        if facet_tags_name is None:
            return mesh, None
        facet_tags = xdmf.read_meshtags(mesh, facet_tags_name)
    return mesh, facet_tags


def save_mesh(
    path: str, mesh, facet_tags, mesh_name: str = "mesh", facet_tags_name: str = "facet_tags"
) -> None:
    """Write a mesh and its facet tags to an XDMF file that :func:`load_mesh` reads back."""
    mesh.name = mesh_name
    facet_tags.name = facet_tags_name
    with XDMFFile(mesh.comm, str(path), "w") as xdmf:
        xdmf.write_mesh(mesh)
        compat.write_meshtags(xdmf, facet_tags, mesh)
