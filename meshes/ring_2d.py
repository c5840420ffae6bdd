"""Generate the 2D elastic ring (annulus) of ``demos/ring_2d.py`` with the gmsh Python API.

The ring has outer radius 1 and inner radius 0.6 and is centred at (0, 1.1), so
its lowest point is 0.1 above the ground y = 0. Physical groups:

- surface 1, "ring": the annulus;
- curve 1, "contact": the lower half of the outer circle (Gamma_C);
- curve 2, "outer_top": the upper half of the outer circle;
- curve 3, "inner": the inner circle.

The file is written in the msh 4.1 ASCII format, which dolfinx reads through
``nitsche_dolfinx.meshing.meshes.load_mesh``. Usage::

    python meshes/ring_2d.py                       # meshes/ring_2d.msh, P1, h = 0.12
    python meshes/ring_2d.py --mesh-size 0.05 --order 2 --out meshes/ring_fine_p2.msh
"""

from __future__ import annotations

import math
import os

from nitsche_dolfinx.meshing import msh_command

#: Tag of the ring's surface.
RING_SURFACE = 1
#: Facet tags: the lower half of the outer circle (Gamma_C), its upper half, the inner circle.
RING_CONTACT = 1
RING_OUTER_TOP = 2
RING_INNER = 3

#: Geometry: radii and centre (the lowest point is CENTRE[1] - OUTER_RADIUS above y = 0).
OUTER_RADIUS = 1.0
INNER_RADIUS = 0.6
CENTRE = (0.0, 1.1)

DEFAULT_OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "ring_2d.msh")


def _circle(geo, centre: int, radius: float, mesh_size: float) -> list[int]:
    """Four quarter arcs of the circle around the point ``centre``, counter-clockwise from
    the leftmost point: [lower left, lower right, upper right, upper left]."""
    cx, cy = CENTRE
    corners = [
        geo.addPoint(cx - radius, cy, 0.0, mesh_size),  # left
        geo.addPoint(cx, cy - radius, 0.0, mesh_size),  # bottom
        geo.addPoint(cx + radius, cy, 0.0, mesh_size),  # right
        geo.addPoint(cx, cy + radius, 0.0, mesh_size),  # top
    ]
    return [geo.addCircleArc(corners[i], centre, corners[(i + 1) % 4]) for i in range(4)]


def build_ring_model(mesh_size: float = 0.12, order: int = 1) -> None:
    """Build and mesh the ring in the current gmsh model (gmsh started): triangles of size
    ``mesh_size`` and geometric ``order``.

    Raises:
        ValueError: If ``mesh_size`` is not a positive number or ``order`` is not 1 or 2.
    """
    if not (math.isfinite(mesh_size) and 0.0 < mesh_size <= OUTER_RADIUS):
        raise ValueError(f"mesh size must lie in (0, {OUTER_RADIUS:g}], got {mesh_size!r}")
    if order not in (1, 2):
        raise ValueError(f"order must be 1 or 2, got {order!r}")
    import gmsh  # optional dependency: the rank that builds the model alone

    gmsh.model.add("ring_2d")
    geo = gmsh.model.geo
    centre = geo.addPoint(*CENTRE, 0.0, mesh_size)
    outer = _circle(geo, centre, OUTER_RADIUS, mesh_size)
    inner = _circle(geo, centre, INNER_RADIUS, mesh_size)
    outer_loop = geo.addCurveLoop(outer)
    inner_loop = geo.addCurveLoop(inner)
    surface = geo.addPlaneSurface([outer_loop, inner_loop])
    geo.synchronize()

    groups = [
        (2, [surface], RING_SURFACE, "ring"),
        (1, outer[:2], RING_CONTACT, "contact"),
        (1, outer[2:], RING_OUTER_TOP, "outer_top"),
        (1, inner, RING_INNER, "inner"),
    ]
    for dim, entities, tag, name in groups:
        gmsh.model.addPhysicalGroup(dim, entities, tag)
        gmsh.model.setPhysicalName(dim, tag, name)
    gmsh.model.mesh.generate(2)
    gmsh.model.mesh.setOrder(order)


def main(argv: list[str] | None = None) -> None:
    """Parse the command line and write the mesh."""
    msh_command(
        argv,
        build_ring_model,
        "Mesh the 2D elastic ring of demos/ring_2d.py with gmsh.",
        DEFAULT_OUT,
        "triangles",
        mesh_size=0.12,
        order=1,
    )


if __name__ == "__main__":
    main()
