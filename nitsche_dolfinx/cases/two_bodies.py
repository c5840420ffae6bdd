"""The two-body test cases of docs/method.md section 11 as ready problems: two bars, two
disks and two balls moving towards each other, a ball thrown on a slab, a block sliding on a
slab; the bodies' velocities and their probes.

The meshes, and the tags of their bodies and surfaces, are those of
:mod:`nitsche_dolfinx.meshing.two_bodies`.
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI

from ..common import compat
from ..meshing.two_bodies import (
    BALL,
    BALL_BOTTOM,
    BLOCK,
    BLOCK_BOTTOM,
    LOWER_BODY,
    LOWER_CONTACT,
    SLAB,
    SLAB_BOTTOM,
    SLAB_TOP,
    UPPER_BODY,
    UPPER_CONTACT,
    ball_on_slab_mesh,
    block_on_slab_mesh,
    mirrored_bodies_mesh,
    two_bars_mesh,
)
from ..model.problem import ContactProblem
from ..output.probes import BoundaryAverage
from ..physics.material import Material
from ..physics.obstacles import PlaneObstacle

__all__ = [
    "add_body_velocity_probes",
    "ball_on_slab_problem",
    "block_on_slab_problem",
    "body_velocities",
    "settled_displacement",
    "two_bars_problem",
    "two_bodies_problem",
]


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
        :data:`~nitsche_dolfinx.meshing.two_bodies.UPPER_BODY`, those of the left one
        :data:`~nitsche_dolfinx.meshing.two_bodies.LOWER_BODY`.
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
        ``(problem, cell_tags)`` (:data:`~nitsche_dolfinx.meshing.two_bodies.UPPER_BODY`,
        :data:`~nitsche_dolfinx.meshing.two_bodies.LOWER_BODY`).
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
