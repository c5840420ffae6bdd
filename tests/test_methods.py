"""The comparison methods: penalty contact, lumped and redistributed mass, the mixed method."""

import numpy as np
import pytest
from mpi4py import MPI

from nitsche_dolfinx import CrankNicolson, HybridScheme, Simulation
from nitsche_dolfinx.cases import BAR_COLUMNS, bar_problem, bar_simulation


def history(simulation):
    records = simulation.run()
    return {name: np.array([r[name] for r in records]) for name in records[0]}


@pytest.mark.mpi
@pytest.mark.parametrize("mass", ["lumped", "redistributed"])
def test_diagonal_masses_keep_the_total_mass(mass):
    problem = bar_problem(nx=20, mass=mass)
    diagonal = problem.mass_diagonal()
    assert diagonal.sum() == pytest.approx(1.0, rel=1e-9)  # rho |Omega|, assembled: 1e-9 of it
    assert diagonal.min()[1] >= 0.0  # (index, value)
    if mass == "redistributed":
        # the contact node x = 0 is massless, its mass h/2 went to its neighbour
        from dolfinx import fem

        coordinates = fem.Function(problem.V)
        coordinates.interpolate(lambda x: x[:1])
        values = coordinates.x.array
        owned = problem.V.dofmap.index_map.size_local
        local = diagonal.array_r
        at = {round(x, 12): m for x, m in zip(values[:owned], local)}
        if 0.0 in at:
            assert at[0.0] == 0.0
        if 0.05 in at:
            assert at[0.05] == pytest.approx(0.05 + 0.025)


def test_redistributed_mass_rejects_the_hybrid_scheme():
    with pytest.raises(ValueError, match="redistributed.*hybrid"):
        Simulation(bar_problem(nx=10, mass="redistributed"), HybridScheme(), dt=0.1, t_end=1.0)


def test_unknown_method_and_mass_are_named():
    with pytest.raises(ValueError, match="'lagrange'"):
        bar_problem(nx=10, method="lagrange")
    with pytest.raises(ValueError, match="'heavy'"):
        bar_problem(nx=10, mass="heavy")


@pytest.mark.parametrize("mass", ["consistent", "lumped"])
def test_free_flight_energy_with_each_mass(mass):
    """CN conserves 1/2 v.Mv + 1/2 A(u, u) whatever the (constant) mass matrix."""
    h = history(bar_simulation(CrankNicolson(), mass=mass, t_end=0.99, nitsche_theta=0.0))
    # conserved up to round-off, which varies with the processor: 1e-9 of E
    assert np.abs(h["energy"] - h["energy"][0]).max() < 1e-9 * h["energy"][0]


def test_penalty_conserves_energy_plus_penalty_energy_with_cn_before_impact():
    h = history(bar_simulation(CrankNicolson(), method="penalty", t_end=0.99))
    # conserved up to round-off, which varies with the processor: 1e-9 of E
    assert np.abs(h["energy_theta"] - h["energy_theta"][0]).max() < 1e-9 * h["energy"][0]


def test_mixed_method_rejects_other_schemes():
    with pytest.raises(ValueError, match="Crank-Nicolson only"):
        bar_simulation(HybridScheme(), method="mixed")


def test_mixed_multiplier_is_a_pressure():
    """lambda <= 0 always, zero in flight, and u(t, 0) >= 0: the constraint holds exactly."""
    h = history(bar_simulation(CrankNicolson(), method="mixed", t_end=3.0))
    # up to round-off, which varies with the processor: 1e-9 of the scales, sigma 1, u0(0) 1/2
    assert h["sigma_contact"].max() <= 1e-9
    assert h["u_contact"].min() >= -1e-9 * 0.5
    s = np.mod(h["t"], 3.0)
    assert np.all(h["sigma_contact"][s < 0.95] == 0.0)


@pytest.mark.mpi
def test_mixed_parallel_matches_serial():
    parallel = history(bar_simulation(CrankNicolson(), method="mixed", t_end=1.5))
    serial = history(bar_simulation(CrankNicolson(), method="mixed", t_end=1.5, comm=MPI.COMM_SELF))
    for column in BAR_COLUMNS:  # serial against 2 ranks: 1e-9 of the scales, 1/8 to 1
        assert np.allclose(parallel[column], serial[column], rtol=1e-9, atol=1e-9), column


@pytest.mark.mpi
@pytest.mark.parametrize("dim", [2, 3])
def test_mixed_method_in_2d_and_3d(dim):
    """The multiplier space builds on every dolfinx: a block dropped on the ground with the
    modified mass keeps its energy and does not penetrate the ground."""
    import sys

    sys.path.insert(0, __file__.rsplit("/", 1)[0])
    from test_problem import dropped_block

    problem = dropped_block(dim, gravity=0.5, method="mixed", mass="redistributed")
    h = history(Simulation(problem, CrankNicolson(), dt=0.01, t_end=0.3))
    assert h["contact_force"].max() > 0
    assert np.abs(h["energy"] - h["energy"][0]).max() < 0.01 * h["energy"][0]


@pytest.mark.mpi
def test_mixed_method_restarts_through_the_driver(mpi_tmp_path):
    """The mixed method runs through the same driver as Nitsche's: interrupted in contact
    (SIGTERM), its checkpoint (with the multiplier) restarts it, and the history and the
    XDMF series are those of the uninterrupted run."""
    import os
    import signal
    import xml.etree.ElementTree as ElementTree

    from nitsche_dolfinx import read_history
    from nitsche_dolfinx.common import RunInterrupted

    out, straight = (os.path.join(mpi_tmp_path, name) for name in ("interrupted", "straight"))
    options = {"columns": BAR_COLUMNS, "output_every": 10}

    def terminate(simulation):
        if simulation.step_index == 60:  # t = 0.9: in contact
            os.kill(os.getpid(), signal.SIGTERM)

    with pytest.raises(RunInterrupted) as caught:
        bar_simulation(CrankNicolson(), method="mixed", t_end=1.5).run(
            out=out, callback=terminate, **options
        )
    assert caught.value.checkpoint.step == 60
    restarted = bar_simulation(CrankNicolson(), method="mixed", t_end=1.5)
    history = restarted.run(out=out, restart=True, **options)
    reference = bar_simulation(CrankNicolson(), method="mixed", t_end=1.5).run(
        out=straight, **options
    )
    assert len(history) == len(reference) == 101
    assert reference["sigma_contact"].min() < 0  # the run goes through contact
    # the same computation serially: bitwise; on ranks with MUMPS, whose factorisation on
    # several ranks varies by round-off from one run to the next (its dynamic scheduling):
    # not the same operations then, 1e-9 of each column's largest value
    tolerance = 0.0 if MPI.COMM_WORLD.size == 1 else 1e-9
    for name in BAR_COLUMNS:
        scale = max(np.abs(reference[name]).max(), 1e-300)
        assert np.abs(history[name] - reference[name]).max() <= tolerance * scale, name
    written = read_history(os.path.join(out, "history.csv"))
    assert np.array_equal(written["t"], reference["t"])
    root = ElementTree.parse(os.path.join(out, "solution.xdmf")).getroot()
    (collection,) = [grid for grid in root.iter("Grid") if grid.get("GridType") == "Collection"]
    times = [float(level.find("Time").get("Value")) for level in collection]
    assert np.allclose(times, 0.15 * np.arange(11))  # every 10 steps, none twice
    fields = {"displacement", "velocity", "von_mises", "contact_pressure", "gap", "contact_status"}
    for level in collection:
        assert {attribute.get("Name") for attribute in level.findall("Attribute")} == fields
