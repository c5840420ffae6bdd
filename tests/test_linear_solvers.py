"""The linear-solver presets: what "auto" picks, and a Krylov preset that follows LU."""

import numpy as np
import pytest
from mpi4py import MPI

from nitsche_dolfinx import HybridScheme, Simulation
from nitsche_dolfinx.cases import impact_problem
from nitsche_dolfinx.solvers import (
    AUTO_CONTACT_STIFFNESS,
    AUTO_COURANT,
    choose_linear_solver,
    contact_stiffness,
    courant_number,
)


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


def test_auto_keeps_lu_for_a_stiff_contact():
    """gamma0 = 1e-6: the contact rows dominate the step's Jacobian (tau^2 / (rho gamma_h h)
    = 0.01 / (1e-6 h_min^2)), where a Krylov solve to Newton's tolerance drifts from lu."""
    h_min = MPI.COMM_WORLD.allreduce(impact_problem(dim=2).h.x.array.min(), op=MPI.MIN)
    soft, stiff = impact_problem(dim=2), impact_problem(dim=2, gamma0=1e-6)
    assert contact_stiffness(stiff, 0.1) == pytest.approx(0.01 / (1e-6 * h_min**2))
    assert contact_stiffness(soft, 0.1) < AUTO_CONTACT_STIFFNESS < contact_stiffness(stiff, 0.1)
    assert choose_linear_solver(soft, 0.1) == "cg-jacobi"
    assert choose_linear_solver(stiff, 0.1) == "lu"


def test_auto_is_the_default_unless_the_solver_is_the_users(disk):
    default = Simulation(disk, HybridScheme(), dt=0.1, t_end=1.0)
    assert default.solver_description.startswith("auto: cg-jacobi")
    for given in ({"petsc_options": {"pc_type": "lu"}}, {"preconditioner_lag": 10}):
        simulation = Simulation(disk, HybridScheme(), dt=0.1, t_end=1.0, **given)
        assert simulation.solver_description == "default"
        assert simulation.solver.snes.getKSP().getPC().getType() in ("lu", "cholesky")


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
    level, to 1e-8 of the column's largest value; an inexact first solve in contact may
    cost one more Newton iteration at a step (docs/method.md section 8)."""
    lu, krylov = _history("lu"), _history("cg-jacobi")
    assert (lu["contact_force"] > 0).sum() > 20
    for name in ("energy", "energy_theta", "kinetic", "elastic", "contact_force"):
        scale = np.abs(lu[name]).max()
        assert np.abs(krylov[name] - lu[name]).max() <= 1e-8 * scale, name
    extra = krylov["newton_iterations"] - lu["newton_iterations"]
    assert np.abs(extra).max() <= 1
    assert extra.sum() <= 0.05 * lu["newton_iterations"].sum()


def test_a_failed_krylov_solve_is_done_again_by_a_factorisation():
    """CG stopped after 2 iterations cannot solve a step: the step is solved again with
    LU, which the solver keeps; the history is lu's."""
    problem = impact_problem(dim=2, mesh_size=8.0)
    simulation = Simulation(
        problem,
        HybridScheme(),
        dt=0.1,
        t_end=11.0,
        linear_solver="cg-jacobi",
        petsc_options={"ksp_max_it": 2},
    )
    krylov = simulation.run()
    assert simulation.solver.petsc.direct_fallbacks == 1
    assert simulation.solver.snes.getKSP().getType() == "preonly"
    lu = Simulation(
        impact_problem(dim=2, mesh_size=8.0), HybridScheme(), dt=0.1, t_end=11.0, linear_solver="lu"
    ).run()
    for name in ("energy", "contact_force"):
        scale = np.abs(lu[name]).max()
        assert np.abs(krylov[name] - lu[name]).max() <= 1e-8 * scale, name
