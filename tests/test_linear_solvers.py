"""The linear-solver presets: what "auto" picks, and a Krylov preset that follows LU."""

import numpy as np
import pytest
from mpi4py import MPI

from nitsche_dolfinx import HybridScheme, Simulation
from nitsche_dolfinx.cases import impact_problem
from nitsche_dolfinx.linear_solvers import AUTO_COURANT, choose_linear_solver, courant_number


@pytest.fixture(scope="module")
def disk():
    """The talk's disk: P2, h = 8, c = sqrt(60), smallest cell about 8 across."""
    return impact_problem(dim=2, mesh_size=8.0)


def test_courant_number_is_tau_over_the_crossing_time(disk):
    h_min = MPI.COMM_WORLD.allreduce(disk.h.x.array.min(), op=MPI.MIN)
    assert courant_number(disk, 0.1) == pytest.approx(np.sqrt(60.0) * 0.1 / h_min)


def test_auto_takes_krylov_for_a_small_tau_and_lu_for_a_large_one(disk):
    small, large = 0.1, 10.0
    assert courant_number(disk, small) < AUTO_COURANT < courant_number(disk, large)
    assert choose_linear_solver(disk, small) == "cg-jacobi"
    assert choose_linear_solver(disk, large) == "lu"
    simulation = Simulation(disk, HybridScheme(), dt=small, t_end=1.0, linear_solver="auto")
    assert simulation.solver_description.startswith("auto: cg-jacobi")
    assert simulation.solver.snes.getKSP().getType() == "cg"


def test_auto_keeps_lu_for_a_non_symmetric_jacobian():
    problem = impact_problem(dim=2, mesh_size=8.0, nitsche_theta=0.0)
    assert choose_linear_solver(problem, 0.1) == "lu"


def _history(linear_solver):
    problem = impact_problem(dim=2, mesh_size=8.0)
    simulation = Simulation(
        problem, HybridScheme(), dt=0.1, t_end=16.0, linear_solver=linear_solver
    )
    return simulation.run()


def test_cg_jacobi_gives_the_history_of_lu():
    """Through the impact (first contact at t = 10): every column of the history, every
    level, to 1e-8 of the column's largest value, with the same Newton iterations."""
    lu, krylov = _history("lu"), _history("cg-jacobi")
    assert (lu["contact_force"] > 0).sum() > 20
    for name in ("energy", "energy_theta", "kinetic", "elastic", "contact_force"):
        scale = np.abs(lu[name]).max()
        assert np.abs(krylov[name] - lu[name]).max() <= 1e-8 * scale, name
    assert np.array_equal(krylov["newton_iterations"], lu["newton_iterations"])
