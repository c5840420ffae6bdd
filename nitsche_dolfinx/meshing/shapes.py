"""The bodies of the paper's impact tests, meshed with gmsh: the 3D ball and the 2D disk.

Each body is built from two halves (two half-balls, or one disk whose circle is
made of a lower and an upper half), so that the facet tags follow the geometry
exactly: the lower half of the boundary is Gamma_C, the upper half is free.
With ``order=2`` gmsh places the extra nodes on the exact sphere (circle), so
the second-order mesh is curved.

One code path builds the gmsh model (:func:`build_ball_model`,
:func:`build_disk_model`); :func:`ball_mesh` and :func:`disk_mesh` turn it
into a distributed dolfinx mesh (:func:`nitsche_dolfinx.meshing.gmsh_pipeline.distribute`), and
:func:`write_msh` (used by the scripts ``meshes/*.py``) writes it to a ``.msh`` file.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Callable, Sequence

import numpy as np
from mpi4py import MPI

from .gmsh_pipeline import distribute, gmsh_session
from .meshes import MAX_CELLS

__all__ = [
    "BALL_CONTACT",
    "BALL_FREE",
    "BALL_VOLUME",
    "DISK_CONTACT",
    "DISK_FREE",
    "DISK_SURFACE",
    "add_ball_halves",
    "add_disk_halves",
    "ball_mesh",
    "build_ball_model",
    "build_disk_model",
    "check_body_mesh",
    "disk_mesh",
    "generate",
    "gmsh_session",
    "msh_command",
    "set_mesh_size",
    "write_msh",
]

#: Physical group of the ball's volume (its cell tag).
BALL_VOLUME = 1
#: Facet tag of the lower hemisphere, z < centre z: the contact boundary Gamma_C.
BALL_CONTACT = 1
#: Facet tag of the upper hemisphere, z > centre z: the free boundary.
BALL_FREE = 2

#: Physical group of the disk's surface (its cell tag).
DISK_SURFACE = 1
#: Facet tag of the lower half circle, y < centre y: the contact boundary Gamma_C.
DISK_CONTACT = 1
#: Facet tag of the upper half circle, y > centre y: the free boundary.
DISK_FREE = 2


#: Cells of the ball (3D) and the disk (2D) per (radius / mesh_size)^dim, measured.
_CELLS_PER_SIZE = {3: 31.0, 2: 10.0}


def check_body_mesh(mesh_size: float, order: int, radius: float, dim: int = 3) -> None:
    """Reject sizes and orders gmsh would silently misread, and meshes too large to make."""
    if not (math.isfinite(radius) and radius > 0.0):
        raise ValueError(f"radius must be a positive number, got {radius!r}")
    if not (math.isfinite(mesh_size) and 0.0 < mesh_size <= 2.0 * radius):
        raise ValueError(f"mesh_size must lie in (0, 2 radius = {2 * radius:g}], got {mesh_size!r}")
    cells = _CELLS_PER_SIZE[dim] * (radius / mesh_size) ** dim
    if cells > MAX_CELLS:
        raise ValueError(
            f"mesh_size={mesh_size!r} would make about {cells:.2g} cells, more than {MAX_CELLS:.0e}"
        )
    if order not in (1, 2):
        raise ValueError(f"order must be 1 or 2, got {order!r}")


def set_mesh_size(gmsh, mesh_size: float) -> None:
    """Make ``mesh_size`` the only size control: points carry none, curvature is ignored."""
    gmsh.option.setNumber("Mesh.MeshSizeMax", mesh_size)
    gmsh.option.setNumber("Mesh.MeshSizeMin", 0.5 * mesh_size)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 1)


def generate(gmsh, dim: int, order: int) -> None:
    """Mesh the current model in ``dim`` dimensions with cells of geometric ``order``."""
    gmsh.model.mesh.generate(dim)
    if order > 1:
        gmsh.model.mesh.setOrder(order)


def add_ball_halves(occ, center: Sequence[float], radius: float) -> None:
    """A ball in the OCC kernel as its lower and upper halves, which share the equatorial
    disk (not synchronised)."""
    cx, cy, cz = center
    lower = occ.addSphere(cx, cy, cz, radius, angle1=-math.pi / 2, angle2=0.0)
    upper = occ.addSphere(cx, cy, cz, radius, angle1=0.0, angle2=math.pi / 2)
    occ.fragment([(3, lower)], [(3, upper)])  # one shared equatorial disk


def add_disk_halves(occ, center: Sequence[float], radius: float):
    """A disk in the OCC kernel whose circle is made of a lower and an upper half, which
    meet at y = ``center[1]`` (not synchronised).

    Returns:
        ``(surface, lower curves, upper curves)``: the OCC tags.
    """
    cx, cy = center
    lower = occ.addCircle(cx, cy, 0.0, radius, angle1=math.pi, angle2=2 * math.pi)
    upper = occ.addCircle(cx, cy, 0.0, radius, angle1=0.0, angle2=math.pi)
    _, (lower_parts, upper_parts) = occ.fragment([(1, lower)], [(1, upper)])  # shared ends
    loop = occ.addCurveLoop([tag for _, tag in lower_parts + upper_parts])
    surface = occ.addPlaneSurface([loop])
    return surface, [tag for _, tag in lower_parts], [tag for _, tag in upper_parts]


def build_ball_model(
    mesh_size: float = 8.0,
    order: int = 2,
    radius: float = 20.0,
    center: Sequence[float] = (0.0, 0.0, 20.0),
) -> None:
    """Build and mesh the ball in the current gmsh model (gmsh must be initialised).

    The ball is the union of a lower and an upper half-ball that share the
    equatorial disk, so the sphere is split exactly at z = ``center[2]``.

    Physical groups: volume :data:`BALL_VOLUME`; surfaces :data:`BALL_CONTACT`
    (lower hemisphere) and :data:`BALL_FREE` (upper hemisphere).

    Args:
        mesh_size: Target edge length of the tetrahedra.
        order: Geometric order, 1 (straight) or 2 (curved, nodes on the sphere).
        radius: Radius of the ball.
        center: Centre of the ball.

    Raises:
        ValueError: If ``mesh_size``, ``order`` or ``radius`` is out of range.
    """
    import gmsh  # optional dependency: the rank that builds the model alone

    check_body_mesh(mesh_size, order, radius)
    cx, cy, cz = (float(c) for c in center)
    gmsh.model.add("ball")
    occ = gmsh.model.occ
    add_ball_halves(occ, (cx, cy, cz), radius)
    occ.synchronize()

    contact, free = [], []
    for _, surface in gmsh.model.getEntities(2):
        z = occ.getCenterOfMass(2, surface)[2]
        if z < cz - 1e-6 * radius:
            contact.append(surface)
        elif z > cz + 1e-6 * radius:
            free.append(surface)  # the equatorial disk (z = cz) is interior: no tag
    volumes = [tag for _, tag in gmsh.model.getEntities(3)]
    _add_groups(
        gmsh,
        [
            (3, volumes, BALL_VOLUME, "ball"),
            (2, contact, BALL_CONTACT, "contact"),
            (2, free, BALL_FREE, "free"),
        ],
    )
    set_mesh_size(gmsh, mesh_size)
    generate(gmsh, 3, order)


def build_disk_model(
    mesh_size: float = 8.0,
    order: int = 2,
    radius: float = 20.0,
    center: Sequence[float] = (0.0, 20.0),
) -> None:
    """Build and mesh the disk in the current gmsh model (gmsh must be initialised).

    The circle is made of two half circles that meet at y = ``center[1]``.

    Physical groups: surface :data:`DISK_SURFACE`; curves :data:`DISK_CONTACT`
    (lower half circle) and :data:`DISK_FREE` (upper half circle).

    Args:
        mesh_size: Target edge length of the triangles.
        order: Geometric order, 1 (straight) or 2 (curved, nodes on the circle).
        radius: Radius of the disk.
        center: Centre of the disk.

    Raises:
        ValueError: If ``mesh_size``, ``order`` or ``radius`` is out of range.
    """
    import gmsh  # optional dependency: the rank that builds the model alone

    check_body_mesh(mesh_size, order, radius, dim=2)
    gmsh.model.add("disk")
    occ = gmsh.model.occ
    surface, lower, upper = add_disk_halves(occ, [float(c) for c in center], radius)
    occ.synchronize()
    _add_groups(
        gmsh,
        [
            (2, [surface], DISK_SURFACE, "disk"),
            (1, lower, DISK_CONTACT, "contact"),
            (1, upper, DISK_FREE, "free"),
        ],
    )
    set_mesh_size(gmsh, mesh_size)
    generate(gmsh, 2, order)


def _add_groups(gmsh, groups) -> None:
    for dim, entities, tag, name in groups:
        gmsh.model.addPhysicalGroup(dim, entities, tag)
        gmsh.model.setPhysicalName(dim, tag, name)


def ball_mesh(
    mesh_size: float = 8.0,
    order: int = 2,
    radius: float = 20.0,
    center: Sequence[float] = (0.0, 0.0, 20.0),
    comm=MPI.COMM_WORLD,
):
    """The ball of the 3D impact test as a dolfinx mesh of tetrahedra.

    Meshed on rank 0 by :func:`build_ball_model` and distributed over ``comm``, the
    contact boundary spread over the ranks
    (:func:`~nitsche_dolfinx.meshing.partition.contact_bisection`).
    The defaults are the talk's ball (radius 20, centre (0, 0, 20), h about 8,
    a few hundred second-order tetrahedra).

    Args:
        mesh_size: Target edge length of the tetrahedra.
        order: Geometric order, 1 or 2.
        radius: Radius of the ball.
        center: Centre of the ball.
        comm: The communicator to distribute the mesh over.

    Returns:
        ``(mesh, facet_tags)``, with facets tagged :data:`BALL_CONTACT` on the
        lower hemisphere and :data:`BALL_FREE` on the upper one.

    Raises:
        ValueError: If ``mesh_size``, ``order`` or ``radius`` is out of range.
    """
    mesh, _, facet_tags = distribute(
        lambda: build_ball_model(mesh_size, order, radius, center), comm, 3, [BALL_CONTACT]
    )
    return mesh, facet_tags


def disk_mesh(
    mesh_size: float = 8.0,
    order: int = 2,
    radius: float = 20.0,
    center: Sequence[float] = (0.0, 20.0),
    comm=MPI.COMM_WORLD,
):
    """The disk of the 2D impact test as a dolfinx mesh of triangles (gdim = 2).

    Meshed on rank 0 by :func:`build_disk_model` and distributed over ``comm``, the
    contact boundary spread over the ranks
    (:func:`~nitsche_dolfinx.meshing.partition.contact_bisection`).

    Args:
        mesh_size: Target edge length of the triangles.
        order: Geometric order, 1 or 2.
        radius: Radius of the disk.
        center: Centre of the disk.
        comm: The communicator to distribute the mesh over.

    Returns:
        ``(mesh, facet_tags)``, with facets tagged :data:`DISK_CONTACT` on the
        lower half circle and :data:`DISK_FREE` on the upper one.

    Raises:
        ValueError: If ``mesh_size``, ``order`` or ``radius`` is out of range.
    """
    mesh, _, facet_tags = distribute(
        lambda: build_disk_model(mesh_size, order, radius, center), comm, 2, [DISK_CONTACT]
    )
    return mesh, facet_tags


def write_msh(path: str, build: Callable[..., None], **kwargs) -> dict[str, int]:
    """Build a model with ``build`` (e.g. :func:`build_ball_model`) and write it as msh 4.1.

    Args:
        path: The ``.msh`` file to write; its folder is created if needed.
        build: :func:`build_ball_model`, :func:`build_disk_model`, or another function
            that makes the current gmsh model.
        **kwargs: Passed to ``build`` (``mesh_size``, ``order``, ...).

    Returns:
        ``{"nodes": ..., "cells": ...}``: the number of cells of the highest dimension and
        of their nodes.

    Raises:
        ValueError: If the arguments are out of range.
        OSError: If the file cannot be written.
    """
    with gmsh_session() as gmsh:
        build(**kwargs)
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.option.setNumber("Mesh.Binary", 0)
        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
        try:
            gmsh.write(str(path))
        except Exception as error:  # gmsh raises a bare Exception
            raise OSError(f"cannot write {path!r}: {error}") from None
        _, tags, nodes = gmsh.model.mesh.getElements(gmsh.model.getDimension())
        return {
            "nodes": len(np.unique(np.concatenate(nodes))),
            "cells": sum(len(t) for t in tags),
        }


def msh_command(
    argv: list[str] | None,
    build: Callable[..., None],
    description: str,
    default_out: str,
    cells: str,
    mesh_size: float = 8.0,
    order: int = 2,
) -> None:
    """The command line of a mesh generator script (``meshes/ball_3d.py``): ``--mesh-size``,
    ``--order`` and ``--out`` (defaults ``mesh_size``, ``order`` and ``default_out``);
    writes the ``.msh`` file of ``build`` and one line of counts, or one line naming a bad
    value (exit status 2)."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument(
        "--mesh-size", type=float, default=mesh_size, help=f"cell size (default: {mesh_size:g})"
    )
    parser.add_argument(
        "--order", type=int, default=order, help=f"geometric order, 1 or 2 (default: {order})"
    )
    parser.add_argument(
        "--out", default=default_out, help="the .msh file to write (default: next to the script)"
    )
    args = parser.parse_args(argv)
    try:
        counts = write_msh(args.out, build, mesh_size=args.mesh_size, order=args.order)
    except (ValueError, OSError) as error:
        print(f"{parser.prog}: error: {error}", file=sys.stderr)
        sys.exit(2)
    print(f"{args.out}: {counts['cells']} {cells}, {counts['nodes']} nodes, order {args.order}")
