"""Coulomb friction (issue 7): the sliding block against the rigid-body solution."""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

from nitsche_dolfinx import Simulation
from nitsche_dolfinx.cases import add_block_probes, block_problem, impact_problem
from nitsche_dolfinx.output import FRICTION_HISTORY_COLUMNS, STATE_COLUMNS
from nitsche_dolfinx.steppers import HybridScheme, make_scheme

DT = 0.05


def run_block(t_end, scheme=None, petsc_options=None, comm=MPI.COMM_WORLD, **kwargs):
    """The block's history, with its mean velocity along the plane."""
    problem = block_problem(comm=comm, **kwargs)
    simulation = Simulation(
        problem, scheme or HybridScheme(), dt=DT, t_end=t_end, petsc_options=petsc_options
    )
    add_block_probes(simulation)
    history = simulation.run()
    return {name: np.array([row[name] for row in history]) for name in history[0]}, simulation


# Crank-Nicolson is left out: its spurious contact oscillations amplify the round-off of
# the differently compiled (but equal) normal terms to 4.5e-12 in 10 steps on one machine.
@pytest.mark.parametrize("scheme", ["hybrid", "newmark"])
def test_zero_friction_is_frictionless(scheme):
    # both runs converge to round-off, so that they differ by round-off only
    exact = {"snes_rtol": 1e-14, "snes_atol": 1e-13}
    frictionless, sim0 = run_block(0.5, make_scheme(scheme), exact, friction=None, v0=1.0)
    zero, sim1 = run_block(0.5, make_scheme(scheme), exact, friction=0.0, v0=1.0)
    # Two computations of the same equations: other forms, and LU (the frictional Jacobian
    # is not symmetric) instead of LDL^T. Each step is solved to ||F|| <= snes_atol, so a
    # step's unknowns may differ by 2 snes_atol ||J^-1|| = 1.5e-11 (||J^-1|| = 77 here);
    # after 10 steps of 0.05, v by 7.7e-12 and u by 10^2 / 2 dt^2 1.5e-11 = 1.9e-12. How
    # much of that the columns show depends on the processor (its BLAS kernels): measured
    # 5.7e-13 in the energies with three kernels, 1.35e-11 on a Xeon, 3.07e-12 in the
    # kinetic energy with OpenBLAS's Haswell kernels. Two computations, so each column to
    # 1e-9 of its scale, max(1, its largest value):
    tolerances = {
        # the energies, 1 to 2 (m = 2, v0 = 1); 1/2 u^T K u sums terms up to 4e4 x 0.5 that
        # cancel to the rigid slide's zero: its round-off, eps/2 |u|^T |K| |u| = 2.8e-10
        **dict.fromkeys(("energy", "energy_theta", "elastic"), 1e-9),
        # the kinetic and potential energies; the penetration on the scale of u, 1
        **dict.fromkeys(("kinetic", "potential", "penetration_max"), 1e-9),
        # the force, of scale m g = 2 (its hybrid value sums each step's y rows with
        # alternating signs: 2 x 10 x 5.5e-12 at most)
        "contact_force": 1e-9,
        # the area, 2, sums the weights of the points in contact: 1e-9 of it still tells one
        # point more or less (P_gamma = gamma_h |sigma_n| = 3.5e-8 there)
        "contact_area": 1e-9,
    }
    assert set(tolerances) == set(STATE_COLUMNS)
    for name in STATE_COLUMNS:
        scale = max(1.0, np.abs(frictionless[name]).max())
        assert np.abs(zero[name] - frictionless[name]).max() <= tolerances[name] * scale, name
    # u: the slide 0.5 and the block's size 1, so 1e-9 as well
    assert np.abs(sim1.u.x.array - sim0.u.x.array).max() <= 1e-9
    # frictionless: the block keeps its speed (v0 = 1: 1e-9 of it)
    assert np.allclose(frictionless["mean_velocity"], 1.0, atol=1e-9)


def test_sliding_block_decelerates_stops_and_stays():
    mu, v0 = 0.2, 1.0
    h, _ = run_block(6.0, friction=mu, v0=v0)
    t, velocity = h["t"], h["mean_velocity"]
    sliding = (t > 0.5) & (t < 4.5)
    deceleration = -np.polyfit(t[sliding], velocity[sliding], 1)[0]
    assert deceleration == pytest.approx(mu * 1.0, rel=0.05)
    # the stop: where the mean velocity first reaches zero
    k = int(np.argmax(velocity <= 0.0))
    assert k > 0
    t_stop = t[k - 1] + (t[k] - t[k - 1]) * velocity[k - 1] / (velocity[k - 1] - velocity[k])
    assert t_stop == pytest.approx(v0 / (mu * 1.0), rel=0.05)
    # and it stays: its base sticks, the rest rings elastically (measured: 2.3e-3)
    assert np.abs(velocity[t > 5.2]).max() < 5e-3
    # energy: the friction works against the motion at every sliding step, and accounts
    # for the loss of E_Theta to the solver's tolerance (hybrid scheme, Theta = 1)
    assert h["friction_dissipation"][1:k].min() > 0.0
    assert np.abs(h["energy_balance_residual"]).max() < 1e-8 * h["energy"][0]
    assert h["friction_dissipation"].sum() == pytest.approx(h["kinetic"][0], rel=1e-3)
    # in stick D^n is not sign-definite, but of the order gamma_h (measured: -2e-9)
    assert h["friction_dissipation"].min() > -1e-7 * h["kinetic"][0]


def run_oblique_disk(gamma0):
    problem = impact_problem(dim=2, gamma0=gamma0, friction=0.3, tangential_velocity=1.0)
    simulation = Simulation(problem, HybridScheme(), dt=0.1, t_end=40.0)
    history = simulation.run(columns=FRICTION_HISTORY_COLUMNS)
    return {name: np.array([row[name] for row in history]) for name in history[0]}


def test_oblique_disk_through_impact():
    """The disk thrown obliquely (plain semismooth Newton cycled here during impact)."""
    h, finer = run_oblique_disk(1e-3), run_oblique_disk(1e-4)
    work, balance = h["friction_dissipation"], h["energy_balance_residual"]
    assert work.sum() > 0.01 * h["energy"][0]
    # friction aside, the hybrid scheme only loses energy (where contact starts or ends)
    assert balance.max() < 1e-8 * h["energy"][0]
    # D^n < 0 at some steps: the Nitsche friction term tested with the increment is
    # (tau/gamma_h) [P_t]_r . P_t >= 0 plus an O(gamma_h) remainder; it shrinks with
    # gamma0 (measured: min D^n -0.16 at 1e-3, -0.011 at 1e-4, -2.4e-4 at 1e-5)
    assert work.min() < 0 and finer["friction_dissipation"].min() > 0.2 * work.min()


def test_block_sticks_below_the_friction_limit():
    # tangential load 0.1 m g < mu_f m g: the block stays put (up to its elastic ringing)
    stick, _ = run_block(2.0, friction=0.2, v0=0.0, slope=0.1)
    # tangential load 0.3 m g > mu_f m g: it slides with acceleration (0.3 - 0.2) g
    slide, _ = run_block(2.0, friction=0.2, v0=0.0, slope=0.3)
    assert slide["mean_velocity"][-1] == pytest.approx(0.1 * 2.0, rel=0.05)
    assert np.abs(stick["mean_velocity"]).max() < 0.01 * slide["mean_velocity"][-1]
    assert np.abs(stick["energy_balance_residual"]).max() < 1e-8


def test_friction_history_columns_and_fields(tmp_path):
    problem = block_problem(friction=0.2, v0=1.0)
    simulation = Simulation(problem, HybridScheme(), dt=DT, t_end=2 * DT)
    simulation.run(out=str(tmp_path), columns=FRICTION_HISTORY_COLUMNS, output_every=1)
    header = (tmp_path / "history.csv").read_text().splitlines()[0].split(",")
    assert header == list(FRICTION_HISTORY_COLUMNS)
    names = set(simulation.output_fields())
    assert {"slip_velocity", "friction_traction"} <= names
    fields = simulation.output_fields()
    slip = fields["slip_velocity"][0].source.function
    traction = fields["friction_traction"][0].source.function
    # sliding to +x: slip along +x and a traction along -x of magnitude mu_f |sigma_n| ~ 0.2
    bottom = np.flatnonzero(np.abs(slip.x.array.reshape(-1, 2)[:, 0]) > 0)
    assert bottom.size > 0
    assert np.all(slip.x.array.reshape(-1, 2)[bottom, 0] > 0.8)
    assert np.all(traction.x.array.reshape(-1, 2)[bottom, 0] < 0)
    mean_traction = traction.x.array.reshape(-1, 2)[bottom, 0].mean()
    assert mean_traction == pytest.approx(-0.2, rel=0.25)


@pytest.mark.mpi
def test_friction_mpi_matches_serial():
    parallel, _ = run_block(1.0, friction=0.2, v0=1.0)
    serial, _ = run_block(1.0, friction=0.2, v0=1.0, comm=MPI.COMM_SELF)
    # energies are parts of one budget: each is compared on the scale of the total energy
    # (the elastic energy is 5e-5 of it, and its partition round-off is ~1e-11)
    budget = ("energy", "energy_theta", "kinetic", "elastic", "potential")
    for name in (*STATE_COLUMNS, "friction_dissipation", "mean_velocity"):
        scale = np.abs(serial["energy" if name in budget else name]).max()
        assert np.abs(parallel[name] - serial[name]).max() <= 1e-8 * max(scale, 1e-12), name


def test_friction_block_demo(tmp_path):
    import importlib.util
    import os
    import subprocess
    import sys

    import h5py

    repo = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env = {**os.environ, "PYTHONPATH": repo + os.pathsep + os.environ.get("PYTHONPATH", "")}
    out = tmp_path / "block"
    args = ["--t-end", "1", "--mu", "0.2", "--v0", "1", "--out", str(out), "--quiet"]
    result = subprocess.run(
        [sys.executable, os.path.join(repo, "demos", "friction_block_2d.py"), *args],
        capture_output=True,
        text=True,
        env=env,
        timeout=600,
    )
    assert result.returncode == 0, result.stderr
    header = (out / "history.csv").read_text().splitlines()[0].split(",")
    assert {"friction_dissipation", "energy_balance_residual", "mean_velocity"} <= set(header)
    with h5py.File(out / "solution.h5", "r") as h5:
        fields = set(h5["Function"])
    assert {"displacement", "velocity", "von_mises", "slip_velocity", "friction_traction"} <= fields
    pictures = {"matplotlib": "energy.png", "pyvista": "deformed.png"}  # unless --no-plot
    for module, picture in pictures.items():
        if importlib.util.find_spec(module) is not None:
            assert (out / picture).stat().st_size > 10_000, picture
    bad = subprocess.run(
        [sys.executable, os.path.join(repo, "demos", "friction_block_2d.py"), "--mu", "-1"],
        capture_output=True,
        text=True,
        env=env,
        timeout=600,
    )
    assert bad.returncode == 2 and "-1" in bad.stderr and "Traceback" not in bad.stderr
