"""Contact between two deformable bodies (docs/method.md section 11)."""

import numpy as np
import pytest
from mpi4py import MPI

from nitsche_dolfinx import ContactProblem, HybridScheme, Material, PlaneObstacle, Simulation
from nitsche_dolfinx.cases import (
    LOWER_BODY,
    LOWER_CONTACT,
    UPPER_BODY,
    UPPER_CONTACT,
    add_body_velocity_probes,
    two_bars_problem,
    two_bodies_problem,
)
from nitsche_dolfinx.common import ParameterError
from nitsche_dolfinx.meshing import DISK_CONTACT, bar_mesh, disk_mesh

NX, DT, T = 20, 0.025, 3.0


def _bars(comm=MPI.COMM_WORLD, t_end=T, with_problem=False, **kwargs):
    problem, cells = two_bars_problem(nx=NX, v0=0.5, gamma0=1e-6, comm=comm, **kwargs)
    simulation = Simulation(problem, HybridScheme(), dt=DT, t_end=t_end)
    add_body_velocity_probes(simulation, cells, {UPPER_BODY: "v_right", LOWER_BODY: "v_left"})
    history = simulation.run()
    return (history, problem) if with_problem else history


def _bar_on_a_wall(gamma0, nitsche_theta=1.0):
    """The right bar alone, hitting a rigid wall at x = 0 (the plane of symmetry)."""
    mesh, tags = bar_mesh(NX)
    material = Material(E=1.0, nu=0.0, rho=1.0)
    problem = ContactProblem(mesh, tags, material, 1, gamma0, nitsche_theta)
    problem.add_obstacle(PlaneObstacle([0.0], [1.0]), 1)
    problem.set_initial_conditions(velocity=[-0.5])
    return Simulation(problem, HybridScheme(), dt=DT, t_end=T).run()


def _surface_ranks(problem, tag) -> set:
    """The ranks that own facets of the surface ``tag``."""
    fdim = problem.mesh.topology.dim - 1
    owned = problem.facets(tag) < problem.mesh.topology.index_map(fdim).size_local
    return {rank for rank, has in enumerate(problem.mesh.comm.allgather(owned.any())) if has}


def _assert_surfaces_on_different_ranks(problem):
    """Each contact surface of the pair is on one rank, not the other's: every slave node
    has its partner on another rank."""
    upper, lower = (_surface_ranks(problem, tag) for tag in (UPPER_CONTACT, LOWER_CONTACT))
    assert len(upper) == len(lower) == 1 and upper != lower, (upper, lower)


@pytest.fixture(scope="module")
def bars():
    return _bars()


def test_unbiased_pair_is_the_rigid_plane_problem_with_half_gamma0(bars):
    """Two mirror-image bars at +v and -v with gamma0 are, term by term, one bar on a rigid
    wall with gamma0 / 2 (docs/method.md section 11): the same contact force, twice the
    energies."""
    wall = _bar_on_a_wall(1e-6 / 2)
    assert max(wall["contact_force"]) > 0.4
    np.testing.assert_allclose(
        bars["contact_force"], wall["contact_force"], rtol=0, atol=1e-7 * 0.5
    )
    # two computations of the same energies: 1e-9 of each, and of the total near 0
    atol = 1e-9 * np.abs(bars["energy"]).max()
    for column in ("energy", "energy_theta", "kinetic", "elastic"):
        np.testing.assert_allclose(bars[column], 2 * wall[column], rtol=1e-9, atol=atol)
    np.testing.assert_array_equal(bars["newton_iterations"], wall["newton_iterations"])


@pytest.mark.parametrize("nitsche_theta", [0.0, -1.0])
def test_unbiased_pair_is_the_rigid_plane_problem_for_every_theta(nitsche_theta):
    """The derivation holds term by term for any Theta: the non-symmetric Jacobian
    (dG/dw assembled) gives the wall's Newton iterations too."""
    pair = _bars(nitsche_theta=nitsche_theta)
    wall = _bar_on_a_wall(1e-6 / 2, nitsche_theta)
    np.testing.assert_allclose(pair["contact_force"], wall["contact_force"], rtol=0, atol=5e-8)
    # two computations: 1e-9 of the energy
    np.testing.assert_allclose(pair["energy_theta"], 2 * wall["energy_theta"], rtol=1e-9)
    np.testing.assert_array_equal(pair["newton_iterations"], wall["newton_iterations"])
    assert np.abs(pair["momentum"]).max() < 1e-8 * 0.5


def test_momentum_is_conserved_and_energy_theta_never_increases(bars):
    assert np.abs(bars["momentum"]).max() < 1e-8 * 0.5
    rises = np.diff(bars["energy_theta"])
    assert rises.max() < 1e-9 * bars["energy_theta"][0]  # round-off, processor-dependent


def test_bars_exchange_their_velocities(bars):
    """Contact from t = 0 to about 2 L / c = 2; then the bars fly apart with their
    velocities exchanged (the right one at +v0), the energy kept."""
    touching = bars["t"][bars["contact_force"] > 0]
    assert touching.min() == pytest.approx(DT) and touching.max() == pytest.approx(2.0, abs=2 * DT)
    after = bars["t"] > 2.1
    np.testing.assert_allclose(bars["v_right"][after], 0.5, atol=0.02)
    np.testing.assert_allclose(bars["v_left"][after], -0.5, atol=0.02)
    assert bars["energy"][-1] == pytest.approx(bars["energy"][0], rel=0.02)


def test_pair_refuses_what_it_does_not_do():
    mesh, tags = bar_mesh(4)
    problem = ContactProblem(mesh, tags, Material(E=1.0, nu=0.0), method="penalty")
    with pytest.raises(ParameterError, match="Nitsche contact"):
        problem.add_contact_pair(1, 2)
    problem = ContactProblem(mesh, tags, Material(E=1.0, nu=0.0))
    with pytest.raises(ParameterError, match="variant='sideways'"):
        problem.add_contact_pair(1, 2, variant="sideways")
    with pytest.raises(ParameterError, match="self-contact, which needs a 2D or 3D mesh"):
        problem.add_contact_pair(1, 1)


@pytest.mark.mpi
def test_parallel_pair_matches_serial():
    """The two bars on two ranks, one bar on each."""
    parallel, problem = _bars(MPI.COMM_WORLD, t_end=1.0, with_problem=True)
    if MPI.COMM_WORLD.size == 2:
        _assert_surfaces_on_different_ranks(problem)
    serial = _bars(MPI.COMM_SELF, t_end=1.0)
    for column in ("energy", "energy_theta", "contact_force", "v_left", "v_right", "momentum"):
        # the momentum is zero: compared on the scale of one bar's, rho L v0 = 0.5
        scale = 0.5 if column == "momentum" else np.abs(serial[column]).max()
        assert np.abs(parallel[column] - serial[column]).max() <= 1e-8 * scale, column


def _disks(gamma0=1e-3, t_end=6.0, **kwargs):
    problem, _ = two_bodies_problem(dim=2, mesh_size=8.0, v0=1.0, gap=1.0, gamma0=gamma0, **kwargs)
    return Simulation(problem, HybridScheme(), dt=0.1, t_end=t_end).run()


def _disk_on_a_plane(gamma0, t_end=6.0):
    mesh, tags = disk_mesh(mesh_size=8.0, order=2, center=[0.0, 20.5])
    problem = ContactProblem(mesh, tags, Material.from_lame(20.0, 20.0), 2, gamma0, 1.0)
    problem.add_obstacle(PlaneObstacle([0.0, 0.0], [0.0, 1.0]), DISK_CONTACT)
    problem.set_initial_conditions(velocity=[0.0, -1.0])
    return Simulation(problem, HybridScheme(), dt=0.1, t_end=t_end).run()


def test_mirror_disks_are_one_disk_on_a_rigid_plane():
    """Paired along their axis, two mirror-image P2 disks at +v and -v with gamma0 are one
    disk on the plane of symmetry with gamma0 / 2, to Newton's tolerance."""
    pair, one = _disks(), _disk_on_a_plane(1e-3 / 2)
    assert max(one["contact_force"]) > 100
    # Two computations of the same steps (other meshes, the pair's coupling against the
    # plane's terms), each solved to snes_rtol = 1e-10 of its equation's scale S: that
    # fixes a step's accelerations to 2 snes_rtol S ||J^-1|| <= 7.6e-10 of their size
    # (measured on both runs); the velocities and displacements sum them (sum tau |a| is
    # about 2 |v|: the bounce) and E_Theta doubles that: 3e-9, so 1e-8 (the force as
    # the states; measured on three BLAS kernels: 2.5e-12 and 2.8e-13)
    force = one["contact_force"].max()
    np.testing.assert_allclose(
        pair["contact_force"], one["contact_force"], rtol=0, atol=1e-8 * force
    )
    np.testing.assert_allclose(pair["energy_theta"], 2 * one["energy_theta"], rtol=1e-8)
    np.testing.assert_array_equal(pair["newton_iterations"], one["newton_iterations"])


@pytest.mark.parametrize(
    "options",
    [{"along_axis": False}, {"along_axis": False, "follow": False}, {"variant": "biased"}],
    ids=["closest", "closest-fixed", "biased"],
)
def test_other_pairings_conserve_momentum_and_control_energy(options):
    """Closest-point pairing and the biased variant are other discretisations of the same
    contact: momentum conserved, E_Theta never rising (less what the pairings changed,
    when the closest points are followed as the disks approach), and a force history near
    the unbiased axis pairing's."""
    pair, reference = _disks(**options), _disks()
    mass_velocity = np.pi * 20.0**2  # the momentum of one disk, rho |disk| v0
    for component in ("momentum_x", "momentum_y"):  # round-off: 1e-9 of one disk's
        assert np.abs(pair[component]).max() < 1e-9 * mass_velocity
    # a step's rise of E_Theta is <F, u^{n+1} - u^n> <= snes_rtol S |du|, at most 1.47e-8
    # here (measured over both runs), plus twice the round-off of E_Theta (eps/2 times
    # |u|^T |K| |u| + |v|^T |M| |v|: 2.7e-10): 1.52e-8 = 1.21e-11 E_Theta(0); both vary
    # with the processor: 1e-9 E_Theta(0)
    controlled = pair["energy_theta"] - pair["pairing_energy"]
    assert np.diff(controlled).max() < 1e-9 * pair["energy_theta"][0]
    # only the followed closest points move as the disks approach: paired along the axis,
    # a node's partner is its mirror image throughout
    followed = options == {"along_axis": False}
    assert (np.abs(pair["pairing_energy"]).max() > 0) == followed
    difference = np.abs(pair["contact_force"] - reference["contact_force"]).max()
    assert 0 < difference < 0.25 * reference["contact_force"].max()


@pytest.mark.parametrize("along_axis", [False, True], ids=["closest", "axis"])
def test_gap_of_two_circles(along_axis):
    """The gap field of two P2 disks of radius R, g0 apart, is the circles' gap
    (docs/method.md section 11): at a node of one circle at angle theta from the axis,
    sqrt((R + g0)^2 + 2 R (2 R + g0)(1 - cos theta)) - R to the closest point of the other
    (R theta^2 - 7/12 R theta^4 + ... for g0 = 0), g0 + 2 R (1 - cos theta) along the axis
    (R theta^2 - 1/12 R theta^4 + ...)."""
    radius, gap = 20.0, 1.0
    problem, _ = two_bodies_problem(dim=2, mesh_size=8.0, gap=gap, along_axis=along_axis)
    if along_axis:  # the partner is the mirror node, on the exact circle: round-off,
        tolerance = 1e-9 * radius  # against the formula: 1e-9 of the radius
    else:
        # The slave nodes lie on their circle, and the master's P2 arcs of angle alpha lie
        # within R alpha^4 / 512 of theirs (docs/method.md section 11): the distance to them
        # is the formula to within that, 9.2e-4 for the 8 arcs of a half circle at h = 8
        # (measured 9.1e-4); 10% more for the higher orders in alpha and Gauss-Newton's end
        fdim = problem.mesh.topology.dim - 1
        facets = problem.facets(LOWER_CONTACT)
        owned = facets < problem.mesh.topology.index_map(fdim).size_local
        alpha = np.pi / problem.mesh.comm.allreduce(int(owned.sum()), op=MPI.SUM)
        tolerance = 1.1 * radius * alpha**4 / 512
    x = problem.V.tabulate_dof_coordinates()[:, :2]
    checked = 0
    for half in problem.pairs:  # each circle is the slave in turn
        gap_vector = half.pairing.gap_vector.x.array.reshape(-1, 2)
        normal = half.pairing.normal.x.array.reshape(-1, 2)
        nodes = np.flatnonzero(np.linalg.norm(normal, axis=1) > 0)
        g = np.einsum("ij,ij->i", gap_vector[nodes], normal[nodes])
        side = np.sign(x[nodes, 1])  # the upper circle's centre is (0, R + g0/2)
        cos_theta = (radius + gap / 2 - side * x[nodes, 1]) / radius
        if along_axis:
            exact = gap + 2 * radius * (1 - cos_theta)
        else:
            span = 2 * radius * (2 * radius + gap) * (1 - cos_theta)
            exact = np.sqrt((radius + gap) ** 2 + span) - radius
        # the nodes within 45 degrees of the axis (g <= 10.4): further out the distance nears
        # R, and the projection's Gauss-Newton steps, which converge like distance / R, stop
        # short of the closest point
        near = cos_theta >= np.cos(np.pi / 4) - 1e-12
        checked += int(near.sum())
        assert np.abs(g[near] - exact[near]).max(initial=0.0) <= tolerance
    # theta = 0, +-pi/16, ..., +-pi/4 on each circle (ghost nodes count on two ranks)
    assert problem.mesh.comm.allreduce(checked, op=MPI.SUM) >= 2 * 9


CONFIG = """
[mesh]
file = "two_disks.xdmf"
degree = 2

[material]
lmbda = 20.0
mu = 20.0

[nitsche]
gamma0 = 1e-3

[scheme]
dt = 0.1
t_end = 9.0

[[dirichlet]]
tag = 4
value = [0.0, 0.0]

[body_force]
value = [0.0, -0.1]

[[contact_pair]]
tags = [1, 2]
{extra}
"""


def _configuration(tmp_path, extra=""):
    """The upper disk falls (gravity 0.1) from 1 above on the lower one, held at its
    lower half and sagging too: contact at t = 7.4 (measured with the API)."""
    from nitsche_dolfinx.cases import mirrored_bodies_mesh
    from nitsche_dolfinx.meshing import save_mesh

    mesh, _, facets = mirrored_bodies_mesh(2, mesh_size=8.0, order=2, gap=1.0)
    save_mesh(str(tmp_path / "two_disks.xdmf"), mesh, facets)
    path = tmp_path / "config.toml"
    path.write_text(CONFIG.format(extra=extra))
    return str(path)


def test_configuration_sets_up_a_contact_pair(tmp_path):
    from nitsche_dolfinx.config import build_simulation, load_config

    simulation = build_simulation(load_config(_configuration(tmp_path)), progress=False)
    assert len(simulation.problem.pairs) == 2
    history = simulation.run()
    touching = history["t"][history["contact_force"] > 0]
    assert touching.min() == pytest.approx(7.4, abs=1e-9)
    # E_Theta (about 0: kinetic and potential energies of 600 that cancel), less what the
    # pairings that follow the closest points changed, rises in a step by
    # <F, u^{n+1} - u^n> <= snes_rtol S |du|, at most 3.5e-9 here (measured), plus twice
    # its round-off (eps/2 |u|^T |K| |u| + ...: 9.3e-11): 3.7e-9, on the scale of the
    # kinetic energy (484 at most) 7.6e-12; both vary with the processor: 1e-9 of it
    controlled = history["energy_theta"] - history["pairing_energy"]
    assert np.diff(controlled).max() < 1e-9 * history["kinetic"].max()


@pytest.mark.parametrize(
    "extra, named",
    [
        ('variant = "sideways"', "[[contact_pair]] #1 variant = 'sideways'"),
        ("direction = [0.0, 0.0, 1.0]", "[[contact_pair]] #1 contact pair direction must"),
        ("direction = [0.0, 0.0]", "[[contact_pair]] #1 direction = [0.0, 0.0]"),
    ],
)
def test_configuration_refuses_a_bad_pair(tmp_path, extra, named):
    from nitsche_dolfinx.config import ConfigError, build_simulation, load_config

    with pytest.raises(ConfigError) as caught:
        build_simulation(load_config(_configuration(tmp_path, extra)), progress=False)
    assert named in str(caught.value)


@pytest.mark.mpi
@pytest.mark.parametrize("along_axis", [True, False], ids=["axis", "closest"])
def test_parallel_disks_match_serial(along_axis):
    """The two disks on two ranks, each rank with a part of both contact surfaces (the
    contact-aware partition cuts across them): partners on both sides of the cut."""
    runs = []
    for comm in (MPI.COMM_WORLD, MPI.COMM_SELF):
        problem, _ = two_bodies_problem(
            dim=2, mesh_size=8.0, gap=1.0, along_axis=along_axis, comm=comm
        )
        if comm.size == 2:
            for tag in (UPPER_CONTACT, LOWER_CONTACT):
                assert _surface_ranks(problem, tag) == {0, 1}, tag
        runs.append(Simulation(problem, HybridScheme(), dt=0.1, t_end=4.0).run())
    parallel, serial = runs
    assert serial["contact_force"].max() > 0
    for column in ("energy", "energy_theta", "contact_force", "penetration_max"):
        scale = np.abs(serial[column]).max()
        assert np.abs(parallel[column] - serial[column]).max() <= 1e-8 * scale, column
    np.testing.assert_array_equal(parallel["newton_iterations"], serial["newton_iterations"])


@pytest.mark.mpi
@pytest.mark.parametrize("variant", ["unbiased", "biased"])
def test_pair_jacobian_is_the_derivative_of_its_residual(variant):
    """In contact, the Jacobian of a pair (summed again on the rows the contact terms and
    the coupling touch) times a direction equals the central difference of the residual
    along it, at iterates whose contact sets differ: the residual is piecewise affine, so
    only round-off separates them where no quadrature point changes status in between."""
    from petsc4py import PETSc

    from nitsche_dolfinx.common import compat

    problem, _ = two_bodies_problem(
        dim=2, mesh_size=8.0, v0=1.0, gap=1.0, gamma0=1e-3, variant=variant
    )
    simulation = Simulation(problem, HybridScheme(), dt=0.1, t_end=4.0, linear_solver="lu")
    while simulation.t < 2.0:  # in contact from t = 0.5
        simulation.step()
    assert simulation.state()["contact_force"] > 0
    snes = simulation.solver.snes
    A = snes.getJacobian()[0]
    w = compat.petsc_vector(simulation.solver.u)
    direction, plus, minus, product = (w.duplicate() for _ in range(4))
    rng = np.random.default_rng(MPI.COMM_WORLD.rank)
    for scale in (1.0, 1.05, 0.95, 1.0):  # other contact sets: other rows, other coupling
        x = w.copy()
        x.scale(scale)
        snes.computeJacobian(x, A)
        direction.array[:] = rng.standard_normal(direction.array.size)
        epsilon = 1e-7 * x.norm() / direction.norm()
        for sign, F in ((1.0, plus), (-1.0, minus)):
            shifted = x.copy()
            shifted.axpy(sign * epsilon, direction)
            snes.computeFunction(shifted, F)
        plus.axpy(-1.0, minus)
        plus.scale(1.0 / (2 * epsilon))
        A.mult(direction, product)
        product.axpy(-1.0, plus)
        assert product.norm(PETSc.NormType.NORM_INFINITY) <= 1e-5 * plus.norm(
            PETSc.NormType.NORM_INFINITY
        ), scale


@pytest.mark.mpi
@pytest.mark.parametrize("preset", ["lu-lagged", "cg-jacobi", "cg-gamg", "gmres-gamg"])
def test_every_linear_solver_preset_runs_a_pair(preset):
    """The Jacobian of a pair grows with the contact set; every preset's solver follows it
    (algebraic multigrid is set up anew) to the states of the direct solver (1e-8)."""
    runs = {}
    for name in ("lu", preset):
        problem, _ = two_bodies_problem(dim=2, mesh_size=8.0, v0=1.0, gap=1.0, gamma0=1e-3)
        runs[name] = Simulation(
            problem, HybridScheme(), dt=0.1, t_end=4.0, linear_solver=name
        ).run()
    force = runs["lu"]["contact_force"]
    assert force.max() > 100
    assert np.abs(runs[preset]["contact_force"] - force).max() <= 1e-8 * force.max()
