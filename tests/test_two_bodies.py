"""Contact between two deformable bodies (docs/method.md section 12)."""

import numpy as np
import pytest
from mpi4py import MPI

from nitsche_dolfinx import ContactProblem, HybridScheme, Material, PlaneObstacle, Simulation
from nitsche_dolfinx.meshes import bar_mesh
from nitsche_dolfinx.parameters import ParameterError
from nitsche_dolfinx.twobody import (
    LOWER_BODY,
    UPPER_BODY,
    add_body_velocity_probes,
    two_bars_problem,
)

NX, DT, T = 20, 0.025, 3.0


def _bars(comm=MPI.COMM_WORLD, t_end=T, **kwargs):
    problem, cells = two_bars_problem(nx=NX, v0=0.5, gamma0=1e-6, comm=comm, **kwargs)
    simulation = Simulation(problem, HybridScheme(), dt=DT, t_end=t_end)
    add_body_velocity_probes(simulation, cells, {UPPER_BODY: "v_right", LOWER_BODY: "v_left"})
    return simulation.run()


def _bar_on_a_wall(gamma0):
    """The right bar alone, hitting a rigid wall at x = 0 (the plane of symmetry)."""
    mesh, tags = bar_mesh(NX)
    problem = ContactProblem(mesh, tags, Material(E=1.0, nu=0.0, rho=1.0), 1, gamma0, 1.0)
    problem.add_obstacle(PlaneObstacle([0.0], [1.0]), 1)
    problem.set_initial_conditions(velocity=[-0.5])
    return Simulation(problem, HybridScheme(), dt=DT, t_end=T).run()


@pytest.fixture(scope="module")
def bars():
    return _bars()


def test_unbiased_pair_is_the_rigid_plane_problem_with_half_gamma0(bars):
    """Two mirror-image bars at +v and -v with gamma0 are, term by term, one bar on a rigid
    wall with gamma0 / 2 (docs/method.md section 12): the same contact force, twice the
    energies."""
    wall = _bar_on_a_wall(1e-6 / 2)
    assert max(wall["contact_force"]) > 0.4
    np.testing.assert_allclose(
        bars["contact_force"], wall["contact_force"], rtol=0, atol=1e-7 * 0.5
    )
    for column in ("energy", "energy_theta", "kinetic", "elastic"):
        np.testing.assert_allclose(bars[column], 2 * wall[column], rtol=1e-10, atol=1e-14)
    np.testing.assert_array_equal(bars["newton_iterations"], wall["newton_iterations"])


def test_momentum_is_conserved_and_energy_theta_never_increases(bars):
    assert np.abs(bars["momentum"]).max() < 1e-8 * 0.5
    rises = np.diff(bars["energy_theta"])
    assert rises.max() < 1e-12 * bars["energy_theta"][0]


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
    problem = ContactProblem(mesh, tags, Material(E=1.0, nu=0.0), friction=0.1)
    with pytest.raises(ParameterError, match="frictionless"):
        problem.add_contact_pair(1, 2)
    problem = ContactProblem(mesh, tags, Material(E=1.0, nu=0.0))
    with pytest.raises(ParameterError, match="variant='sideways'"):
        problem.add_contact_pair(1, 2, variant="sideways")
    with pytest.raises(ParameterError, match="two surfaces"):
        problem.add_contact_pair(1, 1)


@pytest.mark.mpi
def test_parallel_pair_matches_serial():
    parallel = _bars(MPI.COMM_WORLD, t_end=1.0)
    serial = _bars(MPI.COMM_SELF, t_end=1.0)
    for column in ("energy", "energy_theta", "contact_force", "v_left", "v_right", "momentum"):
        # the momentum is zero: compared on the scale of one bar's, rho L v0 = 0.5
        scale = 0.5 if column == "momentum" else np.abs(serial[column]).max()
        assert np.abs(parallel[column] - serial[column]).max() <= 1e-8 * scale, column
