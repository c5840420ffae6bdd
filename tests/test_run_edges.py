"""What a new case met through the API: unknown history columns refused before the run,
a restart into a new output folder, and read_history giving what run gives."""

import os

import numpy as np
import pytest
from mpi4py import MPI

from nitsche_dolfinx import HybridScheme, ParameterError, Simulation, read_history
from nitsche_dolfinx.cases import bar_simulation, impact_problem
from nitsche_dolfinx.output import HISTORY_COLUMNS, History


def disk(t_end):
    problem = impact_problem(dim=2, mesh_size=8.0)
    return Simulation(problem, HybridScheme(), dt=0.1, t_end=t_end)


@pytest.mark.mpi
def test_unknown_column_is_refused_before_the_run(mpi_tmp_path):
    """A biased pair has one contact term (contact_force_1), a disk on a plane too: a
    second one is named, with the run's columns, before a step or a file."""
    simulation = disk(t_end=0.2)
    out = os.path.join(mpi_tmp_path, "out")
    with pytest.raises(ParameterError, match="columns='contact_force_2': not a column of this"):
        simulation.run(out=out, columns=[*HISTORY_COLUMNS, "contact_force_2"])
    assert simulation.step_index == 0 and not os.path.exists(out)
    with pytest.raises(ParameterError, match="columns='energy'"):
        simulation.run(columns="energy")  # a string, not a list of names
    assert len(simulation.run(columns=["t", "contact_force_1"])) == 3


@pytest.mark.mpi
def test_restart_into_a_new_folder_continues_the_history(mpi_tmp_path):
    """A restart from another run's checkpoint writes into its own folder: the history
    beside the checkpoint up to its time, then the new levels; the same history as a run
    without the stop."""
    first, second = (os.path.join(mpi_tmp_path, name) for name in ("first", "second"))
    disk(t_end=0.5).run(out=first, checkpoint_every=5)
    returned = disk(t_end=1.0).run(out=second, restart=os.path.join(first, "checkpoint"))
    straight = disk(t_end=1.0).run(out=os.path.join(mpi_tmp_path, "straight"))
    written = read_history(os.path.join(second, "history.csv"))
    assert len(written) == len(straight) == len(returned) == 11
    for name in ("t", "energy", "kinetic", "contact_force"):
        # the same computation, restarted at t = 0.5 from the values it had: to the bit
        assert np.array_equal(written[name], straight[name]), name
        assert np.array_equal(returned[name], straight[name]), name


@pytest.mark.mpi
def test_restart_from_a_checkpoint_without_its_history_starts_one(mpi_tmp_path):
    """A checkpoint moved away from its history: the new history starts at its level."""
    first, second = (os.path.join(mpi_tmp_path, name) for name in ("first", "second"))
    disk(t_end=0.5).run(out=first, checkpoint_every=5)
    MPI.COMM_WORLD.barrier()
    if MPI.COMM_WORLD.rank == 0:
        os.remove(os.path.join(first, "history.csv"))
    MPI.COMM_WORLD.barrier()
    disk(t_end=0.8).run(out=second, restart=os.path.join(first, "checkpoint"))
    written = read_history(os.path.join(second, "history.csv"))
    # time levels: scalar IEEE arithmetic (no BLAS, no libm), the same bits on any processor
    assert written["t"] == pytest.approx([0.5, 0.6, 0.7, 0.8], abs=1e-14)


def test_read_history_is_the_history_run_returns(tmp_path):
    """read_history gives a History, as run does: columns, rows, arrays by name."""
    columns = ["t", "energy", "newton_iterations"]
    returned = bar_simulation(HybridScheme(), nx=10, t_end=0.06).run(
        out=str(tmp_path), columns=columns
    )
    read = read_history(str(tmp_path / "history.csv"))
    assert isinstance(read, History) and read.columns == columns
    assert len(read) == len(returned) == 5
    for name in columns:  # written with repr: read back to the bit
        assert np.array_equal(read[name], [row[name] for row in returned]), name
    assert read[-1]["newton_iterations"] == returned[-1]["newton_iterations"]
    assert read.energy_drift() == returned.energy_drift()


@pytest.mark.mpi
def test_on_several_ranks_the_cycle_collector_runs_where_every_rank_is():
    """dolfinx (>= 0.8) destroys a vector's PETSc object when Python frees it, and the last
    object on a communicator frees PETSc's communicator with it: if the cycle collector
    ran at each rank's own moment, one rank would duplicate the communicator again and the
    other not, and both would wait (a hang seen with dolfinx 0.11). So, on several ranks, a
    simulation's set-up and run collect cycles on entry and keep the collector to their
    own common points; serially nothing changes."""
    import gc

    freed = []

    class Cycle:
        def __init__(self):
            self.itself = self

        def __del__(self):
            freed.append(True)

    several = MPI.COMM_WORLD.size > 1
    Cycle()
    simulation = disk(t_end=0.2)
    assert freed == ([True] if several else freed)  # collected on entry, on every rank
    collector_on = []
    simulation.run(columns=["t"], callback=lambda _: collector_on.append(gc.isenabled()))
    assert collector_on == [not several] * 2
    assert gc.isenabled()  # as it was
