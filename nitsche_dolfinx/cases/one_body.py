"""The test cases of docs/method.md section 5, ready to run: for the demos, tests and benchmarks.

The bar (:func:`bar_problem`, :func:`bar_simulation`) with the methods the talk compares
on it (:data:`BAR_METHODS`) and one level of its convergence study
(:func:`bar_convergence_level`); the impact of a ball or a disk (:func:`impact_problem`);
a block sliding with Coulomb friction (:func:`block_problem`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np
from mpi4py import MPI

from ..meshing.meshes import BAR_CLAMPED, BAR_CONTACT, BLOCK_CONTACT, bar_mesh, block_mesh
from ..meshing.shapes import BALL_CONTACT, DISK_CONTACT, ball_mesh, disk_mesh
from ..model.problem import ContactProblem
from ..output.probes import BoundaryAverage
from ..physics.material import Material
from ..physics.obstacles import PlaneObstacle
from ..physics.valueforms import PolynomialField
from ..simulation import Simulation
from ..steppers.schemes import TimeScheme, make_scheme
from .exact import BAR_ENERGY, BarSpaceTimeErrors, bar_contact_values

__all__ = [
    "BAR_COLUMNS",
    "BAR_METHODS",
    "BarMethod",
    "IMPACT_SCHEMES",
    "add_bar_probes",
    "bar_convergence_level",
    "bar_problem",
    "bar_simulation",
    "add_block_probes",
    "block_problem",
    "impact_problem",
]

#: Columns of the bar demo's ``history.csv`` (docs/method.md section 6).
BAR_COLUMNS = (
    "t",
    "u_contact",
    "v_contact",
    "sigma_contact",
    "energy",
    "energy_theta",
    "newton_iterations",
)


def bar_problem(
    nx: int = 100,
    degree: int = 1,
    gamma0: float = 1e-6,
    nitsche_theta: float = 1.0,
    comm=MPI.COMM_WORLD,
    method: str = "nitsche",
    mass: str = "consistent",
    gamma0_scaling: str = "absolute",
) -> ContactProblem:
    """The 1D bar with multiple impacts: (0, 1), E = rho = 1, clamped at x = 1, wall at x = 0,
    u0 = 1/2 - x/2, v0 = 0; ``method`` is that of :class:`ContactProblem`."""
    mesh, tags = bar_mesh(nx, comm=comm)
    problem = ContactProblem(
        mesh,
        tags,
        Material(E=1.0, nu=0.0, rho=1.0),
        degree=degree,
        gamma0=gamma0,
        nitsche_theta=nitsche_theta,
        method=method,
        mass=mass,
        gamma0_scaling=gamma0_scaling,
    )
    problem.add_dirichlet(BAR_CLAMPED, 0.0)
    problem.add_obstacle(PlaneObstacle(point=[0.0], normal=[1.0]), BAR_CONTACT)
    problem.set_initial_conditions(displacement=lambda x: 0.5 - x[0] / 2)
    return problem


def bar_simulation(
    scheme,
    method: str = "nitsche",
    mass: str = "consistent",
    dt: float = 0.015,
    t_end: float = 6.0,
    comm=MPI.COMM_WORLD,
    max_step_cuts: int = 5,
    **problem_parameters,
):
    """The bar ready to run with ``method`` (one of
    :data:`~nitsche_dolfinx.common.parameters.CONTACT_METHODS`; the mixed method takes
    Crank-Nicolson only), its probes added."""
    problem = bar_problem(comm=comm, method=method, mass=mass, **problem_parameters)
    simulation = Simulation(problem, scheme, dt=dt, t_end=t_end, max_step_cuts=max_step_cuts)
    add_bar_probes(simulation)
    return simulation


def add_bar_probes(simulation) -> None:
    """History columns at x = 0: ``u_contact``, ``v_contact`` and ``sigma_contact`` (lambda_h)."""
    problem = simulation.problem
    ds = problem.ds(BAR_CONTACT)
    mesh = problem.mesh
    simulation.add_probe("u_contact", BoundaryAverage(mesh, simulation.u[0], ds))
    simulation.add_probe("v_contact", BoundaryAverage(mesh, simulation.v[0], ds))
    pressure = simulation.contact_pressure()  # lambda_h, or the mixed method's multiplier
    simulation.add_probe("sigma_contact", BoundaryAverage(mesh, pressure, ds))


@dataclass(frozen=True)
class BarMethod:
    """A contact method of the talk's comparisons on the bar: the method of
    :class:`ContactProblem` (nitsche, penalty, mixed), the time scheme and the mass."""

    label: str  # in legends and tables
    method: str
    scheme: str
    mass: str = "consistent"

    @property
    def name(self) -> str:
        """A name for folders and tables: ``<method>_<scheme>``, or ``modified_mass``."""
        return "modified_mass" if self.mass == "redistributed" else f"{self.method}_{self.scheme}"

    def with_scheme(self, scheme: TimeScheme) -> BarMethod:
        """This method with another scheme (its label says which)."""
        if scheme.name == self.scheme:
            return self
        label = f"{self.method.capitalize()} + {scheme.describe()}"
        return replace(self, label=label, scheme=scheme.name)


#: The methods the talk compares on the bar (``demos/compare_methods_1d.py``,
#: ``demos/convergence_1d.py``); the mixed ones are Alart-Curnier Lagrange multipliers, the
#: modified mass is the redistributed mass of Khenous, Laborde & Renard.
BAR_METHODS = {
    "hybrid": BarMethod("Nitsche hybrid", "nitsche", "hybrid"),
    "cn": BarMethod("Nitsche + CN", "nitsche", "cn"),
    "mixed": BarMethod("Mixed + CN", "mixed", "cn"),
    "modified_mass": BarMethod("Modified mass + CN", "mixed", "cn", "redistributed"),
    "penalty": BarMethod("Penalty + hybrid", "penalty", "hybrid"),
}


def bar_convergence_level(
    method: BarMethod,
    nx: int,
    dt: float,
    t_end: float,
    gamma0: float,
    degree: int = 1,
    out: str | None = None,
    output_every: int = 0,
    scheme: TimeScheme | None = None,
    **parameters,
) -> dict:
    """One level of the bar's convergence study: ``method`` with ``nx`` cells (h = 1/nx),
    the step ``dt`` and T = ``t_end``, and its errors against the exact solution.

    Besides the history's probes, the normal stress of the discrete displacement at the
    wall, sigma_n(u_h)(t, 0), is recorded as ``stress_contact``. With ``out``, the
    history (and every ``output_every`` steps the fields) are written there.

    Args:
        scheme: The scheme (default: that of ``method``).
        parameters: More of :func:`bar_problem`'s (``nitsche_theta``, ...) and
            ``max_step_cuts``.

    Returns:
        ``N``, ``h``, ``tau``, ``error_l2_l2`` and ``error_l2_h1``
        ((sum_n tau ||e^n||^2)^(1/2) in L2 and the H1 seminorm,
        :class:`~nitsche_dolfinx.cases.exact.BarSpaceTimeErrors`), ``error_pressure`` and
        ``error_stress`` (lambda_h and sigma_n(u_h) at x = 0 in l2(tau)),
        ``error_energy`` (max_n abs(E^n - 1/8)), ``newton_iterations`` (per step) and
        ``wall_seconds``.
    """
    start = time.perf_counter()
    simulation = bar_simulation(
        scheme or make_scheme(method.scheme), method=method.method, mass=method.mass,
        dt=dt, t_end=t_end, nx=nx, degree=degree, gamma0=gamma0, **parameters,
    )  # fmt: skip
    problem = simulation.problem
    stress = problem.contacts[0].sigma_n(simulation.u)
    ds = problem.ds(BAR_CONTACT)
    simulation.add_probe("stress_contact", BoundaryAverage(problem.mesh, stress, ds))
    errors = BarSpaceTimeErrors(simulation)
    errors(simulation)  # t = 0
    history = simulation.run(out=out, callback=errors, output_every=output_every)
    _, _, sigma = bar_contact_values(history["t"])
    return {
        "N": nx,
        "h": 1.0 / nx,
        "tau": dt,
        "error_l2_l2": np.sqrt(errors.l2_squared),
        "error_l2_h1": np.sqrt(errors.h1_squared),
        "error_pressure": np.sqrt(dt * np.sum((history["sigma_contact"] - sigma) ** 2)),
        "error_stress": np.sqrt(dt * np.sum((history["stress_contact"] - sigma) ** 2)),
        "error_energy": np.max(np.abs(history["energy"] - BAR_ENERGY)),
        "newton_iterations": history.mean_newton_iterations(),
        "wall_seconds": time.perf_counter() - start,
    }


#: The schemes of the talk's energy figure of the impact, with its parameters (keywords of
#: :func:`~nitsche_dolfinx.steppers.schemes.make_scheme`): backward Euler, and the Newmark scheme
#: the
#: talk proves stable (beta = 1/2, gamma = 1; 1/4, 1/2 would be Crank-Nicolson again).
IMPACT_SCHEMES = {
    "hybrid": {},
    "cn": {},
    "theta": {"theta": 1.0},
    "newmark": {"beta": 0.5, "gamma": 1.0},
}


def impact_problem(
    dim: int = 3,
    mesh_size: float = 8.0,
    degree: int = 2,
    gamma0: float = 1e-3,
    nitsche_theta: float = 1.0,
    geometry_order: int = 2,
    contact: bool = True,
    comm=MPI.COMM_WORLD,
    friction: float | None = None,
    tangential_velocity: float = 0.0,
    gamma0_scaling: str = "absolute",
    mesh: tuple | None = None,
    method: str = "nitsche",
    mass: str = "consistent",
    law: str = "linear",
) -> ContactProblem:
    """The impact test of the talk: the ball (``dim=3``) or the disk (``dim=2``, plane strain).

    Radius 20, resting on its centre 20 above the rigid plane z = 0 (y = 0 in 2D),
    lifted by u0 = 5 e_z, v0 = 0, f = -0.1 e_z, rho = 1, lambda = mu = 20, no
    Dirichlet condition, Gamma_C the lower half of the boundary. It falls for
    t = sqrt(2 * 5 / 0.1) = 10 and hits the plane with speed 1. ``contact=False``
    leaves out the obstacle: plain linear elastodynamics on the same mesh.
    ``friction`` (mu_f) adds Coulomb friction, and ``tangential_velocity`` an initial
    velocity along x: the body is thrown obliquely. ``mesh``: ``(mesh, facet_tags)`` of
    another body to drop (a part of the disk or ball, say), Gamma_C tagged
    ``DISK_CONTACT`` or ``BALL_CONTACT``; ``mesh_size`` and ``geometry_order`` are then
    unused. ``method`` and ``mass``: those of :class:`ContactProblem`; ``law``: the
    material's (:class:`~nitsche_dolfinx.physics.material.Material`), hyperelastic at finite
    strains.
    """
    if dim not in (2, 3):
        raise ValueError(f"the impact test is 2D (disk) or 3D (ball), got dim={dim!r}")
    make_mesh, contact_tag = (ball_mesh, BALL_CONTACT) if dim == 3 else (disk_mesh, DISK_CONTACT)
    if mesh is None:
        mesh = make_mesh(mesh_size=mesh_size, order=geometry_order, comm=comm)
    mesh, tags = mesh
    problem = ContactProblem(
        mesh,
        tags,
        Material.from_lame(20.0, 20.0, rho=1.0, law=law),
        degree=degree,
        gamma0=gamma0,
        nitsche_theta=nitsche_theta,
        friction=friction,
        mass=mass,
        gamma0_scaling=gamma0_scaling,
        method=method,
    )
    up = [0.0] * dim
    up[-1] = 1.0
    if contact:
        problem.add_obstacle(PlaneObstacle(point=[0.0] * dim, normal=up), contact_tag)
    problem.add_body_force([-0.1 * c for c in up])
    along = [0.0] * dim
    along[0] = float(tangential_velocity)
    problem.set_initial_conditions(displacement=[5.0 * c for c in up], velocity=along)
    return problem


def block_problem(
    friction: float | None = 0.2,
    v0: float = 1.0,
    gravity: float = 1.0,
    slope: float = 0.0,
    E: float = 1e4,
    rho: float = 1.0,
    width: float = 2.0,
    height: float = 1.0,
    nx: int = 8,
    ny: int = 4,
    degree: int = 2,
    gamma0: float | None = None,
    nitsche_theta: float = 1.0,
    comm=MPI.COMM_WORLD,
    gamma0_scaling: str = "absolute",
    mass: str = "consistent",
) -> ContactProblem:
    """A block resting on the rigid plane y = 0 under gravity, thrown along it (plane strain).

    The block (-width/2, width/2) x (0, height), with nu = 0, starts in its static
    equilibrium on a frictionless plane, u0 = -(rho g / E) (H y - y^2 / 2) e_y (exact in
    P2; P1 starts with a small vibration), with the velocity v0 e_x. The volume force is
    rho g (slope, -1): gravity g normal to the plane and ``slope`` times it along x, an
    incline of angle atan(slope) seen in the frame of the plane. A rigid block then slides with the
    deceleration g (mu_f - slope) and stops at t = v0 / (g (mu_f - slope)) when
    mu_f > slope; with v0 = 0 it sticks when slope <= mu_f and slides with the acceleration
    g (slope - mu_f) otherwise. A stiff block (large E) is nearly rigid.

    Args:
        friction: Coulomb coefficient mu_f (None: frictionless).
        gamma0: Nitsche parameter; default 1e-3 / E (the scale of the ball test), or 1e-3
            with ``gamma0_scaling="E"``.
        mass: That of :class:`~nitsche_dolfinx.model.problem.ContactProblem`.
    """
    mesh, tags = block_mesh(width, height, nx, ny, comm=comm)
    material = Material(E=E, nu=0.0, rho=rho)
    problem = ContactProblem(
        mesh,
        tags,
        material,
        degree=degree,
        gamma0=(1e-3 / E if gamma0_scaling == "absolute" else 1e-3) if gamma0 is None else gamma0,
        nitsche_theta=nitsche_theta,
        friction=friction,
        gamma0_scaling=gamma0_scaling,
        mass=mass,
    )
    problem.add_obstacle(PlaneObstacle(point=[0.0, 0.0], normal=[0.0, 1.0]), BLOCK_CONTACT)
    problem.add_body_force([rho * gravity * slope, -rho * gravity])
    # u_y = -sag (H y - y^2 / 2) as the polynomial form of a TOML configuration
    # (valueforms.PolynomialField), so that demos/friction_block_2d.toml is this to the bit
    sag = rho * gravity / E
    displacement = PolynomialField(
        2,
        gradient=[[0.0, 0.0], [0.0, -sag * height]],
        hessian=[np.zeros((2, 2)), np.diag([0, sag])],
    )
    problem.set_initial_conditions(displacement=displacement, velocity=[v0, 0.0])
    return problem


def add_block_probes(simulation) -> None:
    """History column ``mean_velocity``: the block's mean velocity along the plane (its
    momentum over its mass, the density being uniform)."""
    problem = simulation.problem
    mean = BoundaryAverage(problem.mesh, simulation.v[0], problem.dx)
    simulation.add_probe("mean_velocity", mean)
