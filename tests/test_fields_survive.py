"""The fields of ``solution.xdmf`` survive kills and restarts (issue 15, item 4).

- A run killed by SIGKILL, between two time levels or in the middle of one, leaves
  ``solution.xdmf`` and its HDF5 data readable with every level written before, and
  each of them equals the uninterrupted run's; the restart from the checkpoint goes on
  in the right files.
- A 2-rank run restarted on 2 ranks, and on 1 rank then on 2 again, appends fields that
  equal the uninterrupted run's node by node: the nodes are numbered by the partition
  of the mesh, which is not the same from one ``mpirun`` to the next.

The series are read as ParaView reads them (``series.read_solution``): each level with the
geometry of the mesh grid its ``xi:include`` points to, the values from the HDF5 file its
``DataItem`` names.
"""

import os
import re
import shutil
import signal
import subprocess

import numpy as np
import pytest
from mpi4py import MPI
from runs import MPIRUN, command, environment

from nitsche_dolfinx import HybridScheme, Simulation
from nitsche_dolfinx.cases import block_problem
from nitsche_dolfinx.output import match_points, read_solution

# -- reading a series ---------------------------------------------------------------------------


def read_series(path: str) -> dict[str, dict[float, tuple[np.ndarray, np.ndarray]]]:
    """``{field: {t: (node coordinates, values)}}`` of an XDMF time series, read with h5py,
    each level with the mesh its grid includes."""
    pytest.importorskip("h5py")
    series = {}
    for level in read_solution(path):
        for name, values in level.fields.items():
            assert level.t not in series.setdefault(name, {}), (name, level.t)
            assert len(level.points) == len(values)
            series[name][level.t] = (level.points, values)
    return series


def assert_same_fields(series: dict, reference: dict, tolerance: float = 0.0) -> float:
    """Every level of ``series`` is a level of ``reference`` with the same values at the same
    nodes (matched by their coordinates), up to ``tolerance`` times the largest value of the
    field: bitwise by default, for the same computation (a restart on the same partition).
    Returns the largest relative difference."""
    assert set(series) == set(reference)
    worst = 0.0
    for name, levels in series.items():
        expected = reference[name]
        times = np.array(sorted(expected))
        scale = max(max(np.abs(values).max() for _, values in expected.values()), 1e-300)
        for t, (points, values) in levels.items():
            nearest = times[np.argmin(np.abs(times - t))]
            assert abs(nearest - t) <= 1e-9 * max(1.0, abs(t)), (name, t)
            reference_points, reference_values = expected[nearest]
            assert points.shape == reference_points.shape
            extent = np.abs(reference_points).max()
            index = match_points(points, reference_points, 1e-8 * max(extent, 1.0))
            assert np.all(index >= 0), (name, t)
            difference = np.abs(values[index] - reference_values).max() / scale
            assert difference <= tolerance, (name, t, difference)
            worst = max(worst, difference)
    return worst


def times_of(series: dict) -> list[float]:
    (times,) = {tuple(sorted(levels)) for levels in series.values()}  # every field alike
    return list(times)


# -- SIGKILL ------------------------------------------------------------------------------------

#: The friction block (P2 on an affine mesh: the fields are written at its vertices, with
#: the friction fields), 60 steps, every level written, a checkpoint every 10 steps; prints
#: each step after it is written. With "hold", the write of the level at t = 0.41 stops
#: after its first field, the HDF5 file open, until the process is killed.
KILLED_RUN = """
import sys, time
from nitsche_dolfinx import HybridScheme, Simulation
from nitsche_dolfinx.output import writers as output
from nitsche_dolfinx.cases import block_problem

out, hold = sys.argv[1], sys.argv[2] == "hold"

class HeldXDMFFile(output.XDMFFile):
    def write_function(self, function, t, *args):
        super().write_function(function, t, *args)
        if abs(t - 0.41) < 1e-9:
            print("holding", flush=True)
            time.sleep(120)

if hold:
    output.XDMFFile = HeldXDMFFile
simulation = Simulation(block_problem(), HybridScheme(), dt=0.01, t_end=0.6)
simulation.run(out=out, output_every=1, checkpoint_every=10,
               callback=lambda s: print("step", s.step_index, flush=True))
"""


def block(t_end=0.6):
    return Simulation(block_problem(), HybridScheme(), dt=0.01, t_end=t_end)


@pytest.fixture(scope="module")
def block_reference(tmp_path_factory):
    out = str(tmp_path_factory.mktemp("reference"))
    block().run(out=out, output_every=1)
    return read_series(os.path.join(out, "solution.xdmf"))


def kill_run(out: str, hold: bool, after_step: int = 45) -> None:
    """Start the block, SIGKILL it once it has written the level of ``after_step`` (or, with
    ``hold``, once it is held in the middle of the write of t = 0.41)."""
    process = subprocess.Popen(
        command("-c", KILLED_RUN, out, "hold" if hold else "run"),
        stdout=subprocess.PIPE,
        text=True,
        env=environment(),
    )
    try:
        for line in process.stdout:
            if line.startswith("holding") or (
                not hold and line.startswith("step") and int(line.split()[1]) >= after_step
            ):
                break
        else:
            pytest.fail("the run ended before it was killed")
        process.send_signal(signal.SIGKILL)
        process.wait(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    assert process.returncode == -signal.SIGKILL


@pytest.mark.parametrize("hold", [False, True], ids=["between-levels", "during-a-level"])
def test_sigkill_leaves_every_written_level_readable_and_restart_goes_on(
    tmp_path, hold, block_reference
):
    """Killed between levels (after writing t = 0.45, the last checkpoint at t = 0.4): the
    levels up to 0.45 are all there, and the restart writes t = 0.41 ... 0.6 to
    solution-from-step40.xdmf. Killed in the middle of the level t = 0.41 (its first field
    written, the HDF5 file open): solution.xdmf holds t = 0 ... 0.4, every field readable,
    and the restart appends t = 0.41 ... 0.6 to it."""
    out = str(tmp_path / "killed")
    kill_run(out, hold)
    killed = read_series(os.path.join(out, "solution.xdmf"))
    times = times_of(killed)
    assert set(killed) == set(block_reference)
    # time levels: scalar IEEE arithmetic and its text, the same on any processor; the
    # fields: the same run, restarted, on one rank: the same operations, bitwise
    if hold:
        assert times == pytest.approx(np.arange(41) * 0.01, abs=1e-12)
    else:
        assert len(times) >= 46 and times == pytest.approx(np.arange(len(times)) * 0.01)
    assert_same_fields(killed, block_reference)

    block().run(out=out, output_every=1, checkpoint_every=10, restart=True)
    series = read_series(os.path.join(out, "solution.xdmf"))
    assert_same_fields(series, block_reference)
    if hold:  # one series, its levels from t = 0.41 on in a file of their own
        assert times_of(series) == pytest.approx(times_of(block_reference), abs=1e-12)
        assert os.path.exists(os.path.join(out, "solution-restart1.h5"))
    else:
        later = read_series(os.path.join(out, "solution-from-step40.xdmf"))
        assert times_of(later) == pytest.approx(np.arange(41, 61) * 0.01, abs=1e-12)
        assert_same_fields(later, block_reference)
        assert times_of(series) == times


# -- restarts on 2 and on 1 rank ----------------------------------------------------------------

#: Runs of the disk in contact (from t = 10), each ``OUT,T_END[,restart]``, every second
#: level written, a checkpoint every 10 steps and at the end.
DISK_RUNS = """
import sys
from nitsche_dolfinx import HybridScheme, Simulation
from nitsche_dolfinx.cases import impact_problem

for job in sys.argv[1:]:
    out, t_end, *restart = job.split(",")
    problem = impact_problem(dim=2, mesh_size=8.0)
    simulation = Simulation(problem, HybridScheme(), dt=0.1, t_end=float(t_end))
    simulation.run(out=out, output_every=2, checkpoint_every=10, restart=bool(restart))
"""


def disk_runs(*jobs: str, ranks: int) -> None:
    result = subprocess.run(
        command("-c", DISK_RUNS, *jobs, ranks=ranks),
        capture_output=True,
        text=True,
        env=environment(),
        timeout=300,
    )
    assert result.returncode == 0, result.stderr


@pytest.mark.mpi
@pytest.mark.skipif(MPIRUN is None, reason="needs mpirun")
@pytest.mark.skipif(MPI.COMM_WORLD.size > 1, reason="starts mpirun itself: run it serially")
def test_restart_on_two_and_on_one_rank_appends_fields_node_by_node(tmp_path):
    """A 2-rank run of the disk to t = 10.4 is continued to t = 12 by another ``mpirun -n 2``
    (folder a), and by one rank to t = 11.2 then two ranks to t = 12 (folder b): each
    solution.xdmf holds every level of the uninterrupted 2-rank run, equal to it node by
    node to Newton's tolerance.

    Two computations: b's steps from 10.4 to 11.2 on one rank (and any run on another
    partition: dolfinx 0.9 may partition the mesh otherwise from one mpirun to the next).
    Newton solves each step to snes_rtol = 1e-10 of its equation's scale S, which fixes a
    step's accelerations to 2 snes_rtol S ||J^-1|| <= 7.0e-10 of their size (this disk
    in contact, tau = 0.1: measured); from 10.4 on they add up in the velocities and the contact
    pressure, sum tau |a| being about |v| in contact: 1.4e-9, so 2e-9 (measured: 5.8e-15).
    """
    reference, a, b = (str(tmp_path / name) for name in ("reference", "a", "b"))
    disk_runs(f"{reference},12", f"{a},10.4", ranks=2)
    shutil.copytree(a, b)
    disk_runs(f"{b},11.2,restart", ranks=1)
    disk_runs(f"{a},12,restart", f"{b},12,restart", ranks=2)
    expected = read_series(os.path.join(reference, "solution.xdmf"))
    assert times_of(expected) == pytest.approx(np.arange(61) * 0.2, abs=1e-9)
    for out, restarts in ((a, 1), (b, 2)):
        series = read_series(os.path.join(out, "solution.xdmf"))
        assert times_of(series) == pytest.approx(times_of(expected), abs=1e-9)
        assert_same_fields(series, expected, 2e-9)
        text = open(os.path.join(out, "solution.xdmf")).read()
        assert len(re.findall(r'<Grid Name="mesh-restart\d+"', text)) == restarts
