"""The bodies of the paper's impact tests, meshed with gmsh: the 3D ball and the 2D disk.

Each body is built from two halves (two half-balls, or one disk whose circle is
made of a lower and an upper half), so that the facet tags follow the geometry
exactly: the lower half of the boundary is Gamma_C, the upper half is free.
With ``order=2`` gmsh places the extra nodes on the exact sphere (circle), so
the second-order mesh is curved.

One code path builds the gmsh model (:func:`build_ball_model`,
:func:`build_disk_model`); :func:`ball_mesh` and :func:`disk_mesh` turn it
into a distributed dolfinx mesh, and :func:`write_msh` (used by
``meshes/ball_3d.py`` and ``meshes/disk_2d.py``) writes it to a ``.msh`` file.
"""

from __future__ import annotations

import contextlib
import math
import os
from collections.abc import Callable, Sequence

import numpy as np
from mpi4py import MPI

__all__ = [
    "BALL_CONTACT",
    "BALL_FREE",
    "BALL_VOLUME",
    "DISK_CONTACT",
    "DISK_FREE",
    "DISK_SURFACE",
    "ball_mesh",
    "build_ball_model",
    "build_disk_model",
    "disk_mesh",
    "gmsh_session",
    "check_body_mesh",
    "msh_command",
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


@contextlib.contextmanager
def gmsh_session():
    """Initialise gmsh quietly for the ``with`` block and always finalise it after.

    Yields:
        The ``gmsh`` module.
    """
    import gmsh

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        yield gmsh
    finally:
        gmsh.finalize()


#: The most cells a generated body may have: more is a mistake in mesh_size, not a mesh.
MAX_CELLS = 50_000_000
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


def _set_sizes(gmsh, mesh_size: float) -> None:
    """Make ``mesh_size`` the only size control: points carry none, curvature is ignored."""
    gmsh.option.setNumber("Mesh.MeshSizeMax", mesh_size)
    gmsh.option.setNumber("Mesh.MeshSizeMin", 0.5 * mesh_size)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 1)


def _mesh(gmsh, dim: int, order: int) -> None:
    gmsh.model.mesh.generate(dim)
    if order > 1:
        gmsh.model.mesh.setOrder(order)


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
    import gmsh

    check_body_mesh(mesh_size, order, radius)
    cx, cy, cz = (float(c) for c in center)
    gmsh.model.add("ball")
    occ = gmsh.model.occ
    lower = occ.addSphere(cx, cy, cz, radius, angle1=-math.pi / 2, angle2=0.0)
    upper = occ.addSphere(cx, cy, cz, radius, angle1=0.0, angle2=math.pi / 2)
    occ.fragment([(3, lower)], [(3, upper)])  # one shared equatorial disk
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
    _set_sizes(gmsh, mesh_size)
    _mesh(gmsh, 3, order)


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
    import gmsh

    check_body_mesh(mesh_size, order, radius, dim=2)
    cx, cy = (float(c) for c in center)
    gmsh.model.add("disk")
    occ = gmsh.model.occ
    lower = occ.addCircle(cx, cy, 0.0, radius, angle1=math.pi, angle2=2 * math.pi)
    upper = occ.addCircle(cx, cy, 0.0, radius, angle1=0.0, angle2=math.pi)
    _, (lower_parts, upper_parts) = occ.fragment([(1, lower)], [(1, upper)])  # shared ends
    loop = occ.addCurveLoop([tag for _, tag in lower_parts + upper_parts])
    surface = occ.addPlaneSurface([loop])
    occ.synchronize()
    _add_groups(
        gmsh,
        [
            (2, [surface], DISK_SURFACE, "disk"),
            (1, [tag for _, tag in lower_parts], DISK_CONTACT, "contact"),
            (1, [tag for _, tag in upper_parts], DISK_FREE, "free"),
        ],
    )
    _set_sizes(gmsh, mesh_size)
    _mesh(gmsh, 2, order)


def _add_groups(gmsh, groups) -> None:
    for dim, entities, tag, name in groups:
        gmsh.model.addPhysicalGroup(dim, entities, tag)
        gmsh.model.setPhysicalName(dim, tag, name)


def _to_dolfinx(build: Callable[..., None], gdim: int, comm, contact: int, **kwargs):
    """Build the model on rank 0 and distribute it over ``comm``, the facets tagged
    ``contact`` spread over the ranks (:func:`~nitsche_dolfinx.meshes.contact_bisection`):
    ``(mesh, facet_tags)``."""
    from . import compat
    from .meshes import contact_bisection

    with gmsh_session() as gmsh:
        error = None
        if comm.rank == 0:
            try:
                build(**kwargs)
            except Exception as caught:  # re-raised on every rank below
                error = caught
        error = comm.bcast(error, root=0)
        if error is not None:
            raise error
        partitioner = None
        if comm.size > 1:
            x, nodes = np.zeros((0, 3)), np.zeros((0, 3))
            if comm.rank == 0:  # the nodes by input index: gmsh's tags from 1
                tags, coordinates, _ = gmsh.model.mesh.getNodes()
                x = coordinates.reshape(-1, 3)[np.argsort(tags)]
                nodes = gmsh.model.mesh.getNodesForPhysicalGroup(gdim - 1, contact)[1]
                nodes = nodes.reshape(-1, 3)
            partitioner = contact_bisection(x, nodes, gdim + 1)  # simplices
        mesh, _, facet_tags = compat.gmsh_model_to_mesh(gmsh.model, comm, 0, gdim, partitioner)
    return mesh, facet_tags


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
    (:func:`~nitsche_dolfinx.meshes.contact_bisection`).
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
    return _to_dolfinx(
        build_ball_model,
        3,
        comm,
        BALL_CONTACT,
        mesh_size=mesh_size,
        order=order,
        radius=radius,
        center=center,
    )


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
    (:func:`~nitsche_dolfinx.meshes.contact_bisection`).

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
    return _to_dolfinx(
        build_disk_model,
        2,
        comm,
        DISK_CONTACT,
        mesh_size=mesh_size,
        order=order,
        radius=radius,
        center=center,
    )


def write_msh(path: str, build: Callable[..., None], **kwargs) -> dict[str, int]:
    """Build a model with ``build`` (e.g. :func:`build_ball_model`) and write it as msh 4.1.

    Args:
        path: The ``.msh`` file to write; its folder is created if needed.
        build: :func:`build_ball_model` or :func:`build_disk_model`.
        **kwargs: Passed to ``build`` (``mesh_size``, ``order``, ...).

    Returns:
        ``{"nodes": ..., "cells": ...}``: the number of nodes and of cells of
        the highest dimension.

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
        dim = gmsh.model.getDimension()
        _, tags, _ = gmsh.model.mesh.getElements(dim)
        return {
            "nodes": len(gmsh.model.mesh.getNodes()[0]),
            "cells": sum(len(t) for t in tags),
        }


def msh_command(
    argv: list[str] | None,
    build: Callable[..., None],
    description: str,
    default_out: str,
    cells: str,
) -> None:
    """The command line of a mesh generator script (``meshes/ball_3d.py``): ``--mesh-size``,
    ``--order`` and ``--out``; writes the ``.msh`` file of ``build`` and one line of counts,
    or one line naming a bad value (exit status 2)."""
    import argparse
    import sys

    parser = argparse.ArgumentParser(description=description)
    parser.add_argument(
        "--mesh-size", type=float, default=8.0, help="target cell size (default: 8)"
    )
    parser.add_argument("--order", type=int, default=2, help="geometric order, 1 or 2 (default: 2)")
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
