"""When Newton fails (docs/method.md section 8): the line search, then cut steps, then a
clean stop; t_end reached exactly; a lagged factorisation refreshed instead of failing."""

import numpy as np
import pytest
from mpi4py import MPI
from runs import MESH

from nitsche_dolfinx import (
    ContactProblem,
    HybridScheme,
    Material,
    PlaneObstacle,
    Simulation,
    SolverError,
    ThetaScheme,
    load_mesh,
)
from nitsche_dolfinx.cases import bar_simulation, block_problem, impact_problem
from nitsche_dolfinx.steppers import UncontrolledStep
from nitsche_dolfinx.steppers import base as stepping_module


def test_t_end_is_reached_exactly_by_a_shorter_last_step():
    history = bar_simulation(HybridScheme(), dt=0.005, t_end=0.0126, nx=20).run()
    # time levels: scalar IEEE arithmetic (no BLAS, no libm), the same bits on any processor
    assert history["t"] == pytest.approx([0.0, 0.005, 0.01, 0.0126], abs=1e-15)
    assert history["t"][-1] == 0.0126
    assert history["dt"] == pytest.approx([0.0, 0.005, 0.005, 0.0026], abs=1e-15)
    assert list(history["step_cuts"]) == [0, 0, 0, 0]


def test_grid_steps_are_tau_itself():
    """From a nominal level to the next the step is tau, not a difference of times (which
    differs by round-off): 6 / 0.015 is 400 steps of exactly 0.015, ending at 6.0."""
    history = bar_simulation(HybridScheme(), nx=10).run()
    assert len(history) == 401 and history["t"][-1] == 6.0
    assert np.all(history["dt"][1:] == 0.015)


def _disk(**options):
    return Simulation(impact_problem(dim=2, mesh_size=8.0), HybridScheme(), dt=0.1, **options)


def test_failed_steps_are_cut_and_the_run_goes_back_to_its_grid():
    """One Newton iteration per solve (snes_max_it = 1): the contact steps that need more
    are cut in halves until one iteration suffices; the run still ends at t_end, every
    nominal level is in the history, and the energy behaves as in the normal run."""
    options = {"snes_max_it": 1}
    history = _disk(t_end=20.0, petsc_options=options).run()
    reference = _disk(t_end=20.0).run()
    cut = history["step_cuts"] > 0
    assert cut.sum() >= 2 and history.cut_steps() == cut.sum()
    assert history["t"][-1] == 20.0 and np.all(np.diff(history["t"]) > 0)
    levels = history["t"] / 0.1
    on_grid = np.abs(levels - np.round(levels)) < 1e-9
    assert np.array_equal(np.round(levels[on_grid]), np.arange(201))  # every nominal level
    assert np.all(history["step_cuts"][~on_grid] > 0)
    assert history["dt"][cut] == pytest.approx(0.1 / 2 ** history["step_cuts"][cut])
    assert np.all(history["newton_iterations"][1:] <= 2)  # full steps, then the line search
    energy, expected = history["energy"][-1], reference["energy"][-1]
    assert abs(energy / expected - 1) < 1e-2


def test_a_step_that_cannot_converge_stops_the_run_after_the_cuts(tmp_path):
    """One Newton iteration and tolerances nothing reaches: every cut fails too;
    SolverError names the last step tried (tau / 2^2 here), and the last converged level is
    the checkpoint."""
    simulation = _disk(t_end=1.0, max_step_cuts=2)
    simulation.solver.convergence.user_atol = 1e-300
    simulation.solver.snes.setTolerances(rtol=1e-300, max_it=1)
    with pytest.raises(SolverError) as info:
        simulation.run(out=str(tmp_path))
    assert info.value.step == 1 and info.value.t == pytest.approx(0.025)
    assert "also with steps of dt/4; gamma0 * E = 0.05: a smaller gamma0" in str(info.value)
    assert info.value.checkpoint.step == 0
    assert simulation.t == 0.0


def _falling_block(gamma0):
    """A P2 block (E = 1000) dropped on the plane at speed 1, gamma0 scaled by E."""
    problem = block_problem(
        friction=None, v0=0.0, E=1000.0, nx=4, ny=2, gamma0=gamma0, gamma0_scaling="E"
    )
    problem.set_initial_conditions(velocity=[0.0, -1.0])
    return Simulation(problem, HybridScheme(), dt=0.01, t_end=0.1)


def test_gamma0_beyond_the_stability_limit_stops_the_run(tmp_path, monkeypatch):
    """gamma0 = 1 (scaled by E) on a P2 block: E_Theta, conserved or decreasing, stops
    controlling E, which then grows without bound while Newton converges at every step. The
    first such step is refused with the gamma0 named, without cutting it (a smaller step
    does not help), and the last controlled level is the checkpoint."""
    simulation = _falling_block(1.0)
    with pytest.raises(UncontrolledStep) as info:
        simulation.run(out=str(tmp_path))
    error = info.value
    assert error.reason_name == "ENERGY_NOT_CONTROLLED" and not error.cut_may_help
    assert error.step == 2 and error.t == pytest.approx(0.02)
    assert "gamma0 = 1 (scaled by E) is beyond the stability limit" in str(error)
    assert error.checkpoint.step == 1 and simulation.t == pytest.approx(0.01)
    written = np.loadtxt(tmp_path / "history.csv", delimiter=",", skiprows=1, ndmin=2)
    assert written.shape[0] == 2 and np.all(np.isfinite(written))
    assert simulation.state()["energy"] < 2.0  # u, v, a are those of t = 0.01 again

    # without the check, the same run goes on to an energy of 1e14
    monkeypatch.setattr(stepping_module, "ENERGY_CONTROL", -np.inf)
    history = _falling_block(1.0).run()
    assert history["energy"][-1] > 1e12 * history["energy"][0]
    assert history.cut_steps() == 0


@pytest.mark.parametrize("gamma0, share", [(0.01, 0.98), (0.1, 0.75)])
def test_a_stable_gamma0_keeps_the_energy_controlled(gamma0, share):
    """Below the limit (between 0.1 and 0.2 on this mesh: 0.2 grows to 1e303 by t = 1.7)
    E_Theta - potential keeps a share 1 - O(gamma0) of kinetic + elastic."""
    history = _falling_block(gamma0).run()
    controlled = history["energy_theta"] - history["potential"]
    assert np.all(controlled >= share * (history["kinetic"] + history["elastic"]))
    assert max(history["contact_force"]) > 0


def test_lagged_factorisation_is_refreshed_when_gmres_fails():
    """GMRES on a lagged factorisation, allowed one iteration only: at the first contact
    step it fails (DIVERGED_LINEAR_SOLVE), and the solve starts again with the current
    Jacobian factorised, instead of stopping the run; the state is the direct solver's."""
    lagged = _disk(t_end=11.0, preconditioner_lag=10, petsc_options={"ksp_max_it": 1})
    lagged.run()
    direct = _disk(t_end=11.0)
    direct.run()
    assert lagged.solver.petsc.preconditioner_updates > 2
    scale = np.abs(direct.u.x.array).max()
    assert np.abs(lagged.u.x.array - direct.u.x.array).max() < 1e-8 * scale


@pytest.mark.parametrize("scheme", [HybridScheme(), ThetaScheme(1.0)], ids=["hybrid", "euler"])
def test_ring_comes_to_rest_by_defaults(scheme):
    """The README's ring to t = 10, where it comes to rest on the ground (full Newton
    steps cycle there with the hybrid scheme; the line search takes over)."""
    mesh, tags = load_mesh(MESH, gdim=2, comm=MPI.COMM_WORLD)
    problem = ContactProblem(mesh, tags, Material(E=1000.0, nu=0.3, rho=1.0), gamma0=1e-6)
    problem.add_obstacle(PlaneObstacle(point=[0.0, 0.0], normal=[0.0, 1.0]), tag=1)
    problem.add_body_force([0.0, -1.0])
    problem.set_initial_conditions(velocity=[0.0, -1.0])
    history = Simulation(problem, scheme, dt=0.005, t_end=10.0).run()
    assert history["t"][-1] == 10.0
    assert history.largest_rise() < 1e-9


@pytest.mark.parametrize("scheme", ["theta", "newmark"])
@pytest.mark.parametrize("case", ["bar", "disk"])
def test_explicit_members_are_refused_before_any_computation(scheme, case):
    """theta = 0 and Newmark beta = 0 are explicit: with Dirichlet values (the bar) or
    without (the disk, which crashed in the solver's set-up before), one line names the
    scheme before any computation."""
    from nitsche_dolfinx import NewmarkScheme
    from nitsche_dolfinx.common import ParameterError

    explicit = ThetaScheme(0.0) if scheme == "theta" else NewmarkScheme(0.0, 0.5)
    expected = r"scheme='(theta\(theta=0\)|newmark\(beta=0, gamma=0.5\))': theta = 0 and "
    with pytest.raises(ParameterError, match=expected + "Newmark beta = 0 are explicit"):
        if case == "bar":
            bar_simulation(explicit, nx=10, t_end=0.03)
        else:
            Simulation(impact_problem(dim=2, mesh_size=8.0), explicit, dt=0.1, t_end=0.3)
