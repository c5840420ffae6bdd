"""The meshes of the two-body test cases of docs/method.md section 11: two bars, two disks or
two balls, a ball on a slab, a block on a slab, each pair of bodies one mesh with two
disconnected parts, and the tags of their cells and facets.

Two bars, disks or balls are mirror images: the second body is the mirror image of the first
in the plane between them, node for node, so that the pair is symmetric at the discrete
level too. The meshes are made by gmsh on rank 0 (the first body by the generator of the
impact test, :mod:`nitsche_dolfinx.meshing.shapes`; the second as its mirror, entered into a
new gmsh model as discrete entities) and distributed with both contact surfaces spread over
the ranks (:func:`nitsche_dolfinx.meshing.gmsh_pipeline.distribute`). The problems on them
are those of :mod:`nitsche_dolfinx.cases.two_bodies`.
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI

from .gmsh_pipeline import distribute
from .shapes import (
    BALL_CONTACT,
    BALL_FREE,
    BALL_VOLUME,
    DISK_CONTACT,
    DISK_FREE,
    DISK_SURFACE,
    add_ball_halves,
    add_disk_halves,
    build_ball_model,
    build_disk_model,
    check_body_mesh,
    generate,
    set_mesh_size,
)

__all__ = [
    "BALL",
    "BALL_BOTTOM",
    "BLOCK",
    "BLOCK_BOTTOM",
    "LOWER_BODY",
    "LOWER_CONTACT",
    "LOWER_FREE",
    "SLAB",
    "SLAB_BOTTOM",
    "SLAB_TOP",
    "UPPER_BODY",
    "UPPER_CONTACT",
    "UPPER_FREE",
    "ball_on_slab_mesh",
    "block_on_slab_mesh",
    "mirrored_bodies_mesh",
    "two_bars_mesh",
]


#: Cell tags of the two bodies: the first (upper, or right in 1D) and its mirror image.
UPPER_BODY, LOWER_BODY = 1, 2
#: Facet tags of the two contact surfaces (the facing halves of the boundaries).
UPPER_CONTACT, LOWER_CONTACT = 1, 2
#: Facet tags of the rest of each boundary.
UPPER_FREE, LOWER_FREE = 3, 4


def _mirror_into_new_model(
    gmsh, dim: int, gdim: int, groups: dict, plane: float = 0.0, shift: float = 0.0
) -> None:
    """Replace the current gmsh model by one holding its mesh and the mirror image of it
    in the plane x_{gdim-1} = ``plane``, as discrete entities; ``shift``: the first is then
    moved by shift / 2 along x, the image by -shift / 2.

    ``groups`` maps a physical group (dim, tag) of the current model to the pair of tags
    (own, mirrored) it gets in the new one."""
    node_tags, coordinates, _ = gmsh.model.mesh.getNodes()
    coordinates = coordinates.reshape(-1, 3)
    order = np.argsort(node_tags)
    node_tags, coordinates = node_tags[order], coordinates[order]
    offset = int(node_tags.max())
    elements = []  # (dim, physical tag, mirrored tag, types, element tags, element nodes)
    element_offset = 0
    for (group_dim, group), tags in groups.items():
        for entity in gmsh.model.getEntitiesForPhysicalGroup(group_dim, group):
            types, element_tags, element_nodes = gmsh.model.mesh.getElements(group_dim, entity)
            elements.append((group_dim, tags, types, element_tags, element_nodes))
            element_offset = max([element_offset, *(int(t.max()) for t in element_tags)])
    mirrored = coordinates.copy()
    mirrored[:, gdim - 1] = 2 * plane - mirrored[:, gdim - 1]
    coordinates[:, 0] += shift / 2
    mirrored[:, 0] -= shift / 2
    gmsh.model.add("mirrored pair")
    entity_of = {}
    for group_dim, tags, *_ in elements:
        for tag in tags:
            key = (group_dim, tag)
            if key not in entity_of:
                entity_of[key] = gmsh.model.addDiscreteEntity(group_dim)
    body_tags = next(tags for (group_dim, _), tags in groups.items() if group_dim == dim)
    volumes = [entity_of[(dim, tag)] for tag in body_tags]
    gmsh.model.mesh.addNodes(dim, volumes[0], node_tags, coordinates.ravel())
    gmsh.model.mesh.addNodes(dim, volumes[1], node_tags + offset, mirrored.ravel())
    for group_dim, tags, types, element_tags, element_nodes in elements:
        for side, tag in enumerate(tags):
            shift_nodes, shift_elements = offset * side, (element_offset + 1) * side
            gmsh.model.mesh.addElements(
                group_dim,
                entity_of[(group_dim, tag)],
                list(types),
                [t + shift_elements for t in element_tags],
                [n + shift_nodes for n in element_nodes],
            )
    physical = {}
    for (group_dim, tag), entity in entity_of.items():
        physical.setdefault((group_dim, tag), []).append(entity)
    for (group_dim, tag), entities in physical.items():
        gmsh.model.addPhysicalGroup(group_dim, entities, tag)


def two_bars_mesh(nx: int = 100, gap: float = 0.0, comm=MPI.COMM_WORLD):
    """Two bars of length 1: (gap, 1 + gap) and its mirror image (-1, 0), ``nx`` cells
    each. Cells: :data:`UPPER_BODY` (the right bar), :data:`LOWER_BODY`. Facets:
    :data:`UPPER_CONTACT` at x = gap, :data:`LOWER_CONTACT` at x = 0, :data:`UPPER_FREE`
    and :data:`LOWER_FREE` at the outer ends. Returns ``(mesh, cell_tags, facet_tags)``."""
    if int(nx) < 1:
        raise ValueError(f"each bar needs at least one cell, got nx={nx!r}")
    if not np.isfinite(gap) or gap < 0:
        raise ValueError(f"the gap between the bars must be >= 0, got gap={gap!r}")

    def build():
        import gmsh  # optional dependency: the rank that builds the model alone

        gmsh.model.add("bar")
        geo = gmsh.model.geo
        left, right = geo.addPoint(gap, 0, 0), geo.addPoint(1 + gap, 0, 0)
        line = geo.addLine(left, right)
        geo.synchronize()
        gmsh.model.mesh.setTransfiniteCurve(line, int(nx) + 1)
        gmsh.model.addPhysicalGroup(1, [line], UPPER_BODY)
        gmsh.model.addPhysicalGroup(0, [left], UPPER_CONTACT)
        gmsh.model.addPhysicalGroup(0, [right], UPPER_FREE)
        gmsh.model.mesh.generate(1)
        groups = {
            (1, UPPER_BODY): (UPPER_BODY, LOWER_BODY),
            (0, UPPER_CONTACT): (UPPER_CONTACT, LOWER_CONTACT),
            (0, UPPER_FREE): (UPPER_FREE, LOWER_FREE),
        }
        _mirror_into_new_model(gmsh, 1, 1, groups, plane=gap / 2)

    return distribute(build, comm, 1, [UPPER_CONTACT, LOWER_CONTACT])


def mirrored_bodies_mesh(
    dim: int,
    mesh_size: float = 8.0,
    order: int = 2,
    gap: float = 0.0,
    comm=MPI.COMM_WORLD,
    offset: float = 0.0,
):
    """The body of the impact test (the ball, ``dim=3``, or the disk, ``dim=2``; radius 20)
    with its lowest point at height gap/2, and its mirror image below the plane
    x_{dim-1} = 0; ``offset``: the first moved by offset / 2 along x, the image by
    -offset / 2 (an off-centre hit). Facets: :data:`UPPER_CONTACT` (the upper body's lower half),
    :data:`LOWER_CONTACT` (the lower body's upper half), :data:`UPPER_FREE`,
    :data:`LOWER_FREE`; cells :data:`UPPER_BODY`, :data:`LOWER_BODY`. Returns
    ``(mesh, cell_tags, facet_tags)``."""
    if dim not in (2, 3):
        raise ValueError(f"the mirrored bodies are disks (dim=2) or balls (dim=3), got {dim!r}")
    if not np.isfinite(gap) or gap < 0:
        raise ValueError(f"the gap between the bodies must be >= 0, got gap={gap!r}")
    if not np.isfinite(offset) or abs(offset) >= 40.0:
        raise ValueError(f"the offset must be less than a diameter (40), got offset={offset!r}")
    radius = 20.0
    if dim == 3:
        body, contact, free = BALL_VOLUME, BALL_CONTACT, BALL_FREE
        center = (0.0, 0.0, radius + gap / 2)
    else:
        body, contact, free = DISK_SURFACE, DISK_CONTACT, DISK_FREE
        center = (0.0, radius + gap / 2)
    make = build_ball_model if dim == 3 else build_disk_model

    def build():
        import gmsh  # optional dependency: the rank that builds the model alone

        make(mesh_size=mesh_size, order=order, radius=radius, center=center)
        groups = {
            (dim, body): (UPPER_BODY, LOWER_BODY),
            (dim - 1, contact): (UPPER_CONTACT, LOWER_CONTACT),
            (dim - 1, free): (UPPER_FREE, LOWER_FREE),
        }
        _mirror_into_new_model(gmsh, dim, dim, groups, shift=offset)

    return distribute(build, comm, dim, [UPPER_CONTACT, LOWER_CONTACT])


#: Cell tags of the ball-on-slab mesh: the ball and the slab.
BALL, SLAB = 1, 2
#: Facet tags of the ball-on-slab mesh: the ball's lower half, the slab's top and its bottom.
BALL_BOTTOM, SLAB_TOP, SLAB_BOTTOM = 1, 2, 3


def ball_on_slab_mesh(
    dim: int = 3,
    mesh_size: float = 8.0,
    radius: float = 20.0,
    width: float = 80.0,
    thickness: float = 10.0,
    gap: float = 1.0,
    comm=MPI.COMM_WORLD,
):
    """A ball (``dim=3``; a disk in 2D) of ``radius`` whose lowest point is ``gap`` above a
    slab (-width/2, width/2)^(dim-1) x (0, thickness) resting on z = 0; second-order
    geometry. Cells :data:`BALL`, :data:`SLAB`; facets :data:`BALL_BOTTOM` (the lower half
    of the ball's boundary), :data:`SLAB_TOP`, :data:`SLAB_BOTTOM`, the three contact
    surfaces of :func:`~nitsche_dolfinx.cases.two_bodies.ball_on_slab_problem`, spread over
    the ranks. Returns ``(mesh, cell_tags, facet_tags)``."""
    if dim not in (2, 3):
        raise ValueError(f"the ball on a slab is 2D or 3D, got dim={dim!r}")
    check_body_mesh(mesh_size, order=2, radius=radius, dim=dim)
    if not (width > 2 * mesh_size and thickness > mesh_size / 4 and gap >= 0):
        raise ValueError(f"slab {width!r} x {thickness!r} or gap {gap!r} out of range")

    def build():
        import gmsh  # optional dependency: the rank that builds the model alone

        gmsh.model.add("ball on slab")
        _add_ball_and_slab(gmsh.model.occ, dim, radius, width, thickness, gap)
        gmsh.model.occ.synchronize()
        groups = _ball_and_slab_groups(gmsh.model, dim, radius, thickness, gap)
        for group_dim, entities, tag in groups:
            gmsh.model.addPhysicalGroup(group_dim, entities, tag)
        set_mesh_size(gmsh, mesh_size)
        generate(gmsh, dim, 2)

    return distribute(build, comm, dim, [BALL_BOTTOM, SLAB_TOP, SLAB_BOTTOM])


def _add_ball_and_slab(occ, dim: int, radius, width, thickness, gap) -> None:
    """The ball in two halves (see :func:`~nitsche_dolfinx.meshing.shapes.add_ball_halves`), its
    lowest point ``gap`` above the slab, in the OCC kernel (not synchronised)."""
    centre = thickness + gap + radius
    if dim == 3:
        add_ball_halves(occ, (0, 0, centre), radius)
        occ.addBox(-width / 2, -width / 2, 0, width, width, thickness)
    else:
        add_disk_halves(occ, (0, centre), radius)
        occ.addRectangle(-width / 2, 0, 0, width, thickness)


def _ball_and_slab_groups(model, dim: int, radius: float, thickness: float, gap: float):
    """The physical groups ``(dim, entities, tag)`` of the ball and the slab, found by the
    heights of the entities' centres and bounding boxes."""
    occ = model.occ
    ball, slab, bottom, top, base = [], [], [], [], []
    tolerance = 1e-4 * thickness
    centre = thickness + gap + radius
    for _, entity in model.getEntities(dim):
        height = occ.getCenterOfMass(dim, entity)[dim - 1]
        (ball if height > thickness else slab).append(entity)
    for _, entity in model.getEntities(dim - 1):
        height = occ.getCenterOfMass(dim - 1, entity)[dim - 1]
        low, high = occ.getBoundingBox(dim - 1, entity)[dim - 1 :: 3][:2]
        if height > thickness + gap / 2 and height < centre - 1e-6 * radius:
            bottom.append(entity)
        elif abs(low - thickness) < tolerance and abs(high - thickness) < tolerance:
            top.append(entity)
        elif abs(high) < tolerance:  # occ's boxes are a little larger than the entity
            base.append(entity)
    return [
        (dim, ball, BALL), (dim, slab, SLAB), (dim - 1, bottom, BALL_BOTTOM),
        (dim - 1, top, SLAB_TOP), (dim - 1, base, SLAB_BOTTOM),
    ]  # fmt: skip


#: Tags of the block-on-slab mesh: the cells of the block (and of the slab, :data:`SLAB`);
#: the block's bottom (the slab's top and bottom: :data:`SLAB_TOP`, :data:`SLAB_BOTTOM`).
BLOCK, BLOCK_BOTTOM = 1, 1


def _add_rectangle(geo, corner, size, cells) -> tuple[int, int, int]:
    """A rectangle of the gmsh geo kernel meshed by a structured grid of ``cells``
    (nx, ny) triangles: its surface, its bottom line and its top line."""
    (x, y), (w, h) = corner, size
    points = [geo.addPoint(*p, 0) for p in ((x, y), (x + w, y), (x + w, y + h), (x, y + h))]
    lines = [geo.addLine(points[k], points[(k + 1) % 4]) for k in range(4)]
    surface = geo.addPlaneSurface([geo.addCurveLoop(lines)])
    for line, count in zip(lines, (cells[0], cells[1]) * 2):
        geo.mesh.setTransfiniteCurve(line, int(count) + 1)
    geo.mesh.setTransfiniteSurface(surface)
    geo.synchronize()
    return surface, lines[0], lines[2]


def block_on_slab_mesh(
    width: float = 2.0,
    height: float = 1.0,
    nx: int = 8,
    ny: int = 4,
    slab_start: float = -1.5,
    slab_length: float = 6.0,
    thickness: float = 0.5,
    slab_nx: int = 24,
    slab_ny: int = 2,
    gap: float = 1e-6,
    comm=MPI.COMM_WORLD,
):
    """A block (-width/2, width/2) x (gap, gap + height) above a slab (slab_start,
    slab_start + slab_length) x (-thickness, 0), each a structured grid of triangles
    (``nx`` x ``ny`` x 2 and ``slab_nx`` x ``slab_ny`` x 2). Cells :data:`BLOCK`,
    :data:`SLAB`; facets :data:`BLOCK_BOTTOM`, :data:`SLAB_TOP`, :data:`SLAB_BOTTOM`.
    Returns ``(mesh, cell_tags, facet_tags)``."""
    sizes = (width, height, slab_length, thickness)
    if not (all(size > 0 for size in sizes) and gap >= 0):
        raise ValueError(f"block {width!r} x {height!r}, slab {slab_length!r} x "
                         f"{thickness!r} or gap {gap!r} out of range")  # fmt: skip
    if min(nx, ny, slab_nx, slab_ny) < 1:
        raise ValueError(f"each body needs a cell each way, got {nx, ny, slab_nx, slab_ny}")

    def build():
        import gmsh  # optional dependency: the rank that builds the model alone

        gmsh.model.add("block on slab")
        geo = gmsh.model.geo
        block, bottom, _ = _add_rectangle(geo, (-width / 2, gap), (width, height), (nx, ny))
        base, base_bottom, top = _add_rectangle(
            geo, (slab_start, -thickness), (slab_length, thickness), (slab_nx, slab_ny)
        )
        groups = [(2, block, BLOCK), (2, base, SLAB), (1, bottom, BLOCK_BOTTOM),
                  (1, top, SLAB_TOP), (1, base_bottom, SLAB_BOTTOM)]  # fmt: skip
        for dim, entity, tag in groups:
            gmsh.model.addPhysicalGroup(dim, [entity], tag)
        gmsh.model.mesh.generate(2)

    return distribute(build, comm, 2, [BLOCK_BOTTOM, SLAB_TOP])
