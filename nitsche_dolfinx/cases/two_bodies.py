"""The two-body test cases of docs/method.md section 11: two bars, two disks and two balls
moving towards each other, as meshes with both bodies and as ready problems.

Each pair of bodies is one mesh with two disconnected parts; the second body is the
mirror image of the first in the plane between them, node for node, so that the pair is
symmetric at the discrete level too. The meshes are made by gmsh on rank 0 (the first
body by the generator of the impact test, :mod:`nitsche_dolfinx.meshing.shapes`; the second as
its mirror, entered into a new gmsh model as discrete entities) and distributed with both
contact surfaces spread over the ranks (:func:`nitsche_dolfinx.meshing.gmsh_pipeline.distribute`).
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI

from ..common import compat
from ..meshing.gmsh_pipeline import distribute
from ..meshing.shapes import (
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
from ..model.problem import ContactProblem
from ..output.diagnostics import BoundaryAverage
from ..physics.material import Material
from ..physics.obstacles import PlaneObstacle

__all__ = [
    "LOWER_BODY",
    "LOWER_CONTACT",
    "UPPER_BODY",
    "UPPER_CONTACT",
    "BLOCK",
    "BLOCK_BOTTOM",
    "ball_on_slab_mesh",
    "ball_on_slab_problem",
    "block_on_slab_mesh",
    "block_on_slab_problem",
    "settled_displacement",
    "mirrored_bodies_mesh",
    "add_body_velocity_probes",
    "body_velocities",
    "two_bars_mesh",
    "two_bars_problem",
    "two_bodies_problem",
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


def body_velocities(problem: ContactProblem, cell_tags, velocities: dict):
    """A Function of ``problem.V``: on the cells of each tag, its constant velocity."""
    V = problem.V
    dofmap = compat.dofmap_array(V)
    velocity = fem.Function(V)
    values = velocity.x.array.reshape(-1, V.dofmap.index_map_bs)
    for tag, value in velocities.items():
        values[np.unique(dofmap[cell_tags.find(tag)])] = value
    velocity.x.scatter_forward()
    return velocity


def two_bars_problem(
    nx: int = 100,
    v0: float = 0.5,
    gap: float = 0.0,
    degree: int = 1,
    gamma0: float = 1e-6,
    nitsche_theta: float = 1.0,
    variant: str = "unbiased",
    comm=MPI.COMM_WORLD,
    gamma0_scaling: str = "absolute",
    mass: str = "consistent",
):
    """Two bars of length 1, E = rho = 1, the right one moving at -v0 and the left one at
    +v0 (docs/method.md section 11): they touch at t = gap / (2 v0), stay in contact for
    2 L / c = 2, and separate with their velocities exchanged. ``mass``: that of
    :class:`~nitsche_dolfinx.model.problem.ContactProblem` (the verlet scheme takes "lumped").

    Returns:
        ``(problem, cell_tags)``: the cells of the right bar are tagged
        :data:`UPPER_BODY`, those of the left one :data:`LOWER_BODY`.
    """
    mesh, cell_tags, tags = two_bars_mesh(nx, gap, comm)
    problem = ContactProblem(
        mesh, tags, Material(E=1.0, nu=0.0, rho=1.0), degree, gamma0, nitsche_theta,
        gamma0_scaling=gamma0_scaling, mass=mass,
    )  # fmt: skip
    problem.add_contact_pair(UPPER_CONTACT, LOWER_CONTACT, variant)
    velocity = body_velocities(problem, cell_tags, {UPPER_BODY: [-v0], LOWER_BODY: [v0]})
    problem.set_initial_conditions(velocity=velocity)
    return problem, cell_tags


def two_bodies_problem(
    dim: int = 2,
    mesh_size: float = 8.0,
    v0: float = 1.0,
    gap: float = 0.0,
    degree: int = 2,
    gamma0: float = 1e-3,
    nitsche_theta: float = 1.0,
    variant: str = "unbiased",
    geometry_order: int = 2,
    along_axis: bool = True,
    comm=MPI.COMM_WORLD,
    gamma0_scaling: str = "absolute",
    mass: str = "consistent",
    offset: float = 0.0,
    follow: bool | None = None,
    law: str = "linear",
):
    """Two disks (``dim=2``, plane strain) or two balls (``dim=3``) of the impact test
    (radius 20, lambda = mu = 20, rho = 1), mirror images of each other, moving towards
    each other along the last axis at speeds v0, without gravity. ``along_axis``: the
    surfaces are paired along that axis (then the pair is exactly one body on a rigid
    plane with gamma0 / 2, docs/method.md section 11); else with closest points.
    ``mass``: that of :class:`~nitsche_dolfinx.model.problem.ContactProblem`. ``offset``: the
    bodies' centres that far apart along x (an off-centre hit; 0: head-on). ``follow``:
    that of :meth:`~nitsche_dolfinx.model.problem.ContactProblem.add_contact_pair`. ``law``: the
    material's (:class:`~nitsche_dolfinx.physics.material.Material`; a hyperelastic one makes the
    pair one between hyperelastic bodies, docs/method.md section 15).

    Returns:
        ``(problem, cell_tags)`` (:data:`UPPER_BODY`, :data:`LOWER_BODY`).
    """
    mesh, cell_tags, tags = mirrored_bodies_mesh(dim, mesh_size, geometry_order, gap, comm, offset)
    problem = ContactProblem(
        mesh, tags, Material.from_lame(20.0, 20.0, rho=1.0, law=law), degree, gamma0,
        nitsche_theta, gamma0_scaling=gamma0_scaling, mass=mass,
    )  # fmt: skip
    down = np.zeros(dim)
    down[-1] = -1.0
    direction = down if along_axis else None
    problem.add_contact_pair(UPPER_CONTACT, LOWER_CONTACT, variant, direction, follow)

    towards = np.zeros(dim)
    towards[-1] = v0
    velocities = {UPPER_BODY: -towards, LOWER_BODY: towards}
    problem.set_initial_conditions(velocity=body_velocities(problem, cell_tags, velocities))
    return problem, cell_tags


def add_body_velocity_probes(simulation, cell_tags, names: dict, component: int = -1) -> None:
    """History columns ``names[tag]``: the mean velocity component of each body."""
    problem = simulation.problem
    dx = ufl.Measure("dx", domain=problem.mesh, subdomain_data=cell_tags)
    velocity = simulation.v[problem.gdim - 1 if component == -1 else component]
    for tag, name in names.items():
        simulation.add_probe(name, BoundaryAverage(problem.mesh, velocity, dx(tag)))


#: Tags of the ball-on-slab mesh: cells of the ball and of the slab; the ball's lower half,
#: the slab's top and its bottom.
BALL, SLAB = 1, 2
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
    surfaces of :func:`ball_on_slab_problem`, spread over the ranks. Returns
    ``(mesh, cell_tags, facet_tags)``."""
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


def ball_on_slab_problem(
    dim: int = 3,
    mesh_size: float = 8.0,
    v0: float = 1.0,
    gravity: float = 0.1,
    gamma0: float = 1e-3,
    comm=MPI.COMM_WORLD,
    nitsche_theta: float = 1.0,
    gamma0_scaling: str = "absolute",
    mass: str = "consistent",
):
    """The ball of the impact test thrown down at v0 (and gravity) on a slab of the same
    material (lambda = mu = 20, rho = 1) resting on the rigid ground: body-body contact
    between the ball's lower half and the slab's top
    (:meth:`~nitsche_dolfinx.model.problem.ContactProblem.add_contact_pair`, paired along the
    vertical), body-obstacle contact of the slab's bottom with the ground (``mass``: that of
    :class:`~nitsche_dolfinx.model.problem.ContactProblem`).
    Returns ``(problem, cell_tags)``."""
    mesh, cells, facets = ball_on_slab_mesh(dim, mesh_size, comm=comm)
    problem = ContactProblem(
        mesh, facets, Material.from_lame(20.0, 20.0, rho=1.0), 2, gamma0, nitsche_theta,
        gamma0_scaling=gamma0_scaling, mass=mass,
    )  # fmt: skip
    down = np.zeros(dim)
    down[-1] = -1.0
    problem.add_contact_pair(BALL_BOTTOM, SLAB_TOP, "unbiased", down)
    problem.add_obstacle(PlaneObstacle([0.0] * dim, -down), SLAB_BOTTOM)
    problem.add_body_force(gravity * down)
    velocities = {BALL: v0 * down, SLAB: np.zeros(dim)}
    problem.set_initial_conditions(velocity=body_velocities(problem, cells, velocities))
    return problem, cells


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


def settled_displacement(gravity_over_E: float, height: float, thickness: float, gap: float):
    """The initial displacement of :func:`block_on_slab_problem` in the expression language
    (docs/method.md section 13): each body in the equilibrium of its own weight (nu = 0),
    the slab held at y = -thickness, the block resting on its sagging top,
    u_y = s (y^2 - H_s^2) / 2 in the slab and -s (H y' - y'^2 / 2) - s H_s^2 / 2 in the
    block (y' = y - gap its height), s = rho g / E."""
    s, below = repr(gravity_over_E), repr(gravity_over_E * thickness**2 / 2)
    up = f"(y - {gap!r})"
    block = f"-{s} * ({height!r} * {up} - {up}^2 / 2) - {below}"
    slab = f"{s} * (y^2 - {thickness**2!r}) / 2"
    return [0.0, f"{block} if y > {gap / 2!r} else {slab}"]


def block_on_slab_problem(
    friction: float | None = 0.2,
    v0: float = 1.0,
    gravity: float = 1.0,
    E: float = 1e4,
    rho: float = 1.0,
    degree: int = 1,
    gamma0: float | None = None,
    nitsche_theta: float = 1.0,
    variant: str = "biased",
    follow: bool = True,
    comm=MPI.COMM_WORLD,
    gamma0_scaling: str = "absolute",
    mass: str = "consistent",
    **mesh,
):
    """The block of :func:`~nitsche_dolfinx.cases.one_body.block_problem` (nu = 0, plane strain)
    thrown at v0 along a slab of the same material held at its bottom, with Coulomb
    friction ``friction`` between the block's bottom (the slave with ``"biased"``) and
    the slab's top: a contact pair, closest points, paired again as the block slides
    with ``follow``; gravity g. Each body starts in the equilibrium of its own weight
    (:func:`settled_displacement`), the block ``gap`` above the slab, so that no force
    acts between them at t = 0: a rigid block stops after v0^2 / (2 mu_f g).
    ``mesh``: the keys of :func:`block_on_slab_mesh`. ``gamma0``: default 1e-3 / E (or
    1e-3 with ``gamma0_scaling="E"``). Returns ``(problem, cell_tags)``."""
    shape = {**dict(height=1.0, thickness=0.5, gap=1e-6), **mesh}
    domain, cell_tags, facets = block_on_slab_mesh(comm=comm, **shape)
    if gamma0 is None:
        gamma0 = 1e-3 / E if gamma0_scaling == "absolute" else 1e-3
    problem = ContactProblem(
        domain, facets, Material(E=E, nu=0.0, rho=rho), degree, gamma0, nitsche_theta,
        friction, gamma0_scaling=gamma0_scaling, mass=mass,
    )  # fmt: skip
    problem.add_contact_pair(BLOCK_BOTTOM, SLAB_TOP, variant, None, follow)
    problem.add_dirichlet(SLAB_BOTTOM, [0.0, 0.0])
    problem.add_body_force([0.0, -rho * gravity])
    displacement = settled_displacement(
        rho * gravity / E, shape["height"], shape["thickness"], shape["gap"]
    )
    velocity = body_velocities(problem, cell_tags, {BLOCK: [v0, 0.0], SLAB: [0.0, 0.0]})
    problem.set_initial_conditions(displacement=displacement, velocity=velocity)
    return problem, cell_tags
