"""Symmetry conditions (one component of the displacement prescribed) against a known truth:
half of a mirror-symmetric disk, held by u_x = 0 on its cut, has the full disk's history,
its energies, contact force and area halved (to Newton's tolerance, 2e-8; measured 2e-12),
with every scheme and method, serially and on 2 ranks, through a restart and with contact
between bodies."""

import numpy as np
import pytest
from disks import RADIUS, SYMMETRY, symmetric_disks
from mpi4py import MPI

from nitsche_dolfinx import (
    CrankNicolson,
    HybridScheme,
    NewmarkScheme,
    Simulation,
    ThetaScheme,
)
from nitsche_dolfinx.cases import impact_problem
from nitsche_dolfinx.meshing import DISK_CONTACT
from nitsche_dolfinx.output import HISTORY_COLUMNS

#: Columns that are sums over the body: the full disk's are twice the half's.
HALVED = ("energy", "energy_theta", "kinetic", "elastic", "potential", "contact_force")


def impact_run(scheme, half: bool, t_end=12.0, dt=0.25, comm=MPI.COMM_WORLD, **options):
    """The disk (or its half, held by u_x = 0 on its cut) of the impact test, dropped; t_end
    12 takes it 2 units of time into the contact. Returns the history."""
    mesh, _, tags = symmetric_disks(half, comm=comm)
    problem = impact_problem(dim=2, mesh=(mesh, tags), comm=comm, **options)
    if half:
        problem.add_dirichlet(SYMMETRY, 0.0, component=0)
    simulation = Simulation(problem, scheme, dt=dt, t_end=t_end)
    history = simulation.run(columns=[*HISTORY_COLUMNS, "momentum_x", "momentum_y"])
    for name in ("contact_force", "contact_area"):  # one obstacle: its totals are the sums
        assert np.array_equal(history[f"{name}_1"], history[name])
    return history


def assert_halved(full, half, tolerance=2e-8, momentum=True):
    """The half disk's sums are half the full disk's, its largest penetration and Newton
    iterations the same; the full disk has no momentum along x (``momentum``: and half of
    the momentum along y).

    The half and the full disk are two computations of the same steps (other meshes,
    numberings, Dirichlet rows), each solved by Newton to snes_rtol = 1e-10 of its
    equation's scale S: that fixes a step's accelerations to 2 snes_rtol S ||J^-1||, at
    most 2.0e-9 of their size (3.3e-9 with penalty; measured on these disks, tau = 0.25);
    the velocities sum them (sum tau |a| is about 2 |v|: the fall, then the bounce) and
    the energies double that: 1.3e-8, so 2e-8 (measured on three BLAS kernels: 2e-12).
    """
    assert full["contact_force"].max() > 1.0  # in contact
    for name in HALVED:
        scale = np.abs(full[name]).max()
        assert np.abs(full[name] - 2 * half[name]).max() <= tolerance * scale, name
    assert np.abs(full["contact_area"] - 2 * half["contact_area"]).max() <= tolerance * RADIUS
    assert np.abs(full["penetration_max"] - half["penetration_max"]).max() <= tolerance * RADIUS
    assert np.array_equal(full["newton_iterations"], half["newton_iterations"])
    if not momentum:
        return
    momentum = np.abs(full["momentum_y"]).max()
    assert np.abs(full["momentum_y"] - 2 * half["momentum_y"]).max() <= tolerance * momentum
    # the full disk's mesh and steps are mirror images of themselves, Newton's iterates too:
    # only round-off breaks the symmetry, about cond(J) eps = 2e-15 of the state a step
    # (cond(J) = 9), 1e-13 in 48 steps (measured: 2.2e-14), which varies with the
    # processor: 1e-9 of the momentum
    assert np.abs(full["momentum_x"]).max() <= 1e-9 * momentum


@pytest.mark.parametrize(
    "scheme",
    [HybridScheme(), ThetaScheme(0.5), NewmarkScheme(0.25, 0.5), CrankNicolson()],
    ids=["hybrid", "theta", "newmark", "cn"],
)
def test_half_disk_has_half_the_history(scheme):
    assert_halved(impact_run(scheme, False), impact_run(scheme, True))


@pytest.mark.parametrize(
    "method, scheme", [("penalty", HybridScheme()), ("mixed", CrankNicolson())]
)
def test_half_disk_with_other_methods(method, scheme):
    assert_halved(impact_run(scheme, False, method=method), impact_run(scheme, True, method=method))


@pytest.mark.mpi
def test_half_disk_on_ranks():
    """Under mpirun: the same on any number of ranks (the cut shared between them)."""
    full, half = impact_run(HybridScheme(), False), impact_run(HybridScheme(), True)
    assert_halved(full, half)


@pytest.mark.mpi
def test_half_disk_restarts_from_its_checkpoint(mpi_tmp_path):
    """A run of the half disk stopped at t = 11 and restarted goes on as if uninterrupted
    (the condition on one component holds through the checkpoint)."""
    out = f"{mpi_tmp_path}/restarted"
    whole = impact_run(HybridScheme(), True)
    mesh, _, tags = symmetric_disks(True)

    def half(t_end):
        problem = impact_problem(dim=2, mesh=(mesh, tags))
        problem.add_dirichlet(SYMMETRY, 0.0, component=0)
        return Simulation(problem, HybridScheme(), dt=0.25, t_end=t_end)

    half(11.0).run(out=out, checkpoint_every=4)
    restarted = half(12.0).run(out=out, restart=True)
    # the same computation serially: bitwise; on ranks the two builds of the mesh may be
    # partitioned otherwise (dolfinx 0.9), round-off then: 1e-9 of each column's largest
    tolerance = 0.0 if MPI.COMM_WORLD.size == 1 else 1e-9
    for name in HALVED:
        scale = np.abs(whole[name]).max()
        assert np.abs(restarted[name] - whole[name]).max() <= tolerance * scale, name


@pytest.mark.mpi
def test_half_disks_in_contact_with_each_other():
    """Two disks colliding head-on through a contact pair (paired along the axis), and the
    left halves of both held by u_x = 0: the halves' history is half the disks'. The
    Dirichlet dofs enter the pair's coupling, here on both bodies."""
    from nitsche_dolfinx import ContactProblem, Material
    from nitsche_dolfinx.cases import body_velocities

    histories = []
    for half in (False, True):
        mesh, cells, tags = symmetric_disks(half, pair=True)
        problem = ContactProblem(mesh, tags, Material.from_lame(20.0, 20.0), 2, 1e-3, 1.0)
        problem.add_contact_pair(DISK_CONTACT, 4, direction=[0.0, -1.0])
        if half:
            problem.add_dirichlet(SYMMETRY, 0.0, component=0)
        velocities = {1: [0.0, -1.0], 2: [0.0, 1.0]}
        problem.set_initial_conditions(velocity=body_velocities(problem, cells, velocities))
        simulation = Simulation(problem, HybridScheme(), dt=0.25, t_end=2.0)
        histories.append(simulation.run(columns=[*HISTORY_COLUMNS, "momentum_x", "momentum_y"]))
    full, half = histories
    assert_halved(full, half, momentum=False)
    for history in histories:  # the bodies' momenta cancel, up to round-off: 1e-9 of
        # one disk's m v, which (v = 1) is the largest kinetic energy, 2 x m v^2 / 2
        assert np.abs(history["momentum_y"]).max() <= 1e-9 * history["kinetic"].max()


@pytest.mark.parametrize(
    "scheme",
    [HybridScheme(), ThetaScheme(0.5), NewmarkScheme(0.25, 0.5), CrankNicolson()],
    ids=["hybrid", "theta", "newmark", "cn"],
)
def test_roller_moving_in_time_carries_the_body(scheme):
    """A block on a roller that rises as 0.1 t (u_y = 0.1 t on its bottom, u_x free),
    pushed along x by the body force (1, 0), starting with the velocity (0, 0.1): it moves
    rigidly, u = (t^2 / 2, 0.1 t), exact for every scheme (constant acceleration): its
    centre of mass and momentum say so, and its elastic energy stays zero (round-off)."""
    from nitsche_dolfinx import ContactProblem, Material
    from nitsche_dolfinx.meshing import BLOCK_CONTACT, block_mesh

    mesh, tags = block_mesh(2.0, 1.0, 4, 2)
    problem = ContactProblem(mesh, tags, Material(E=10.0, nu=0.3, rho=2.0), degree=2)
    problem.add_dirichlet(BLOCK_CONTACT, lambda t: 0.1 * t, component=1)
    problem.add_body_force([2.0, 0.0])  # rho * (1, 0)
    problem.set_initial_conditions(velocity=[0.0, 0.1])
    columns = [*HISTORY_COLUMNS, "momentum_x", "momentum_y", "centre_of_mass_x"]
    history = Simulation(problem, scheme, dt=0.1, t_end=1.0).run(
        columns=[*columns, "centre_of_mass_y"]
    )
    t, mass = history["t"], 2.0 * 2.0  # rho |Omega|
    # the run against the exact motion, round-off apart: 1e-9 of the scales, the block's
    # size 1, its momentum mass x 1, and its kinetic energy for the elastic one (round-off)
    assert history["centre_of_mass_x"] == pytest.approx(t**2 / 2, abs=1e-9)
    assert history["centre_of_mass_y"] == pytest.approx(0.5 + 0.1 * t, abs=1e-9)
    assert history["momentum_x"] == pytest.approx(mass * t, abs=1e-9 * mass)
    assert history["momentum_y"] == pytest.approx(mass * 0.1, abs=1e-9 * mass)
    assert np.abs(history["elastic"]).max() <= 1e-9 * history["kinetic"].max()
