"""Runs that are interrupted and continued, and lose nothing.

- SIGINT stops a run (serial, or under mpirun with the signal sent to one rank only)
  after a complete step, and ``--restart`` reproduces the uninterrupted history;
- checkpoints reload on another partition or number of ranks, refuse another run,
  survive a killed write, and the command line and the bar demo continue from them.
"""

import gc
import json
import os
import signal
import subprocess
import time

import numpy as np
import pytest
from mpi4py import MPI
from runs import (
    DISK,
    MPIRUN,
    assert_same_history,
    assert_xdmf_readable,
    child_pids,
    command,
    environment,
    ring_config,
    run,
)

from nitsche_dolfinx import CrankNicolson, HybridScheme, Simulation, read_history
from nitsche_dolfinx.cases import impact_problem
from nitsche_dolfinx.common import RunInterrupted
from nitsche_dolfinx.output import CHECKPOINT_FILE, HISTORY_COLUMNS, CheckpointError

# -- 3./4. SIGINT and restart -----------------------------------------------------------------


def solver_of(ranks: int) -> list[str]:
    """The demo's linear solver for a check of a restart against a second run: serially
    the default, and the runs are the same computation (compared bitwise). On 2 ranks a
    direct solve: dolfinx 0.9 may partition the same mesh otherwise in two runs (the
    ranks' cell counts swap), so the two runs differ by round-off, which a direct solve
    keeps at round-off and the default's inexact CG solves raise to their tolerance (6e-13
    measured on the disk, docs/method.md section 8)."""
    return [] if ranks == 1 else ["--linear-solver", "lu"]


#: A restart against a second run on 2 ranks (:func:`solver_of`): besides the partitions,
#: MUMPS's factorisation on 2 ranks varies by round-off from one run to the next (its
#: dynamic scheduling; measured: 6 of 398 repeated solves of one system differ, and two
#: identical runs of the disk by 3.8e-14). Each step's solve then differs by about
#: cond(J) eps = 2e-15 of the state (cond(J) = 9 on this disk); 400 steps: 8e-13. Not the
#: same operations, so 1e-9 of each column's largest value, which holds on any processor.
TWO_RANKS_RESTART = 1e-9


def interrupt_disk(out: str, ranks: int, after_step: int = 20) -> tuple[subprocess.Popen, str]:
    """Start the disk demo (400 steps on the h = 4 mesh), send SIGINT once it has printed step
    ``after_step``: to the process, or under mpirun to the last rank only (the ranks agree
    on stopping). Returns the finished process and its stderr."""
    args = [*DISK[:-1], "4", *solver_of(ranks), "--t-end", "40", "--output-every", "10"]
    process = subprocess.Popen(
        command(*args, "--out", out, ranks=ranks),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=environment(),
    )
    try:
        for line in process.stdout:
            if line.startswith("step") and int(line.split()[1]) >= after_step:
                break
        else:
            pytest.fail("the demo ended before the signal")
        target = process.pid
        if ranks > 1:
            deadline = time.monotonic() + 30
            while len(child_pids(process.pid)) < ranks and time.monotonic() < deadline:
                time.sleep(0.05)
            target = child_pids(process.pid)[-1]
        os.kill(target, signal.SIGINT)
        stdout, stderr = process.communicate(timeout=300)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    return process, stderr


def check_interrupted_then_restart(tmp_path, ranks: int) -> float:
    out = str(tmp_path / "interrupted")
    process, stderr = interrupt_disk(out, ranks)
    assert "interrupted by SIGINT after step" in stderr, stderr
    assert "continue with --restart" in stderr and "Traceback" not in stderr
    if ranks == 1:
        assert process.returncode == 130
    else:
        assert process.returncode != 0  # mpirun reports a failed rank's status its own way
    # the outputs are readable, up to the step the run stopped after, and that step is saved
    history = read_history(os.path.join(out, "history.csv"))
    steps = len(history["t"]) - 1
    assert 20 <= steps < 400 and history["t"][-1] == pytest.approx(steps * 0.1)
    assert stderr.count("interrupted by SIGINT") == 1
    assert f"after step {steps} (t = {steps * 0.1:.6g})" in stderr
    assert_xdmf_readable(os.path.join(out, "solution.xdmf"), last_time=steps * 0.1)
    with open(os.path.join(out, "checkpoint", CHECKPOINT_FILE)) as f:
        saved = json.load(f)
    assert saved["step"] == steps and saved["ranks"] == ranks

    args = [*DISK[:-1], "4", *solver_of(ranks), "--t-end", "40", "--output-every", "10"]
    args.append("--quiet")
    restarted = run(*args, "--restart", "--out", out, ranks=ranks)
    assert restarted.returncode == 0, restarted.stderr
    reference = run(*args, "--out", str(tmp_path / "reference"), ranks=ranks)
    assert reference.returncode == 0, reference.stderr
    difference = assert_same_history(
        read_history(str(tmp_path / "reference" / "history.csv")),
        read_history(os.path.join(out, "history.csv")),
        0.0 if ranks == 1 else TWO_RANKS_RESTART,
    )
    times = assert_xdmf_readable(os.path.join(out, "solution.xdmf"), last_time=40.0)
    assert times == pytest.approx(np.arange(0.0, 40.05, 1.0))
    return difference


def test_sigint_stops_cleanly_and_restart_reproduces_the_run(tmp_path):
    check_interrupted_then_restart(tmp_path, ranks=1)


@pytest.mark.mpi
@pytest.mark.skipif(MPIRUN is None, reason="needs mpirun")
@pytest.mark.skipif(MPI.COMM_WORLD.size > 1, reason="starts mpirun itself: run it serially")
def test_sigint_to_one_rank_under_mpirun_stops_all_and_restart_reproduces(tmp_path):
    check_interrupted_then_restart(tmp_path, ranks=2)


# -- the library: checkpoints in process -------------------------------------------------------


def disk(t_end=12.0, scheme=None, dt=0.1, comm=MPI.COMM_WORLD, mesh_size=8.0):
    problem = impact_problem(dim=2, mesh_size=mesh_size, comm=comm)
    return Simulation(problem, scheme or HybridScheme(), dt=dt, t_end=t_end)


def columns(records, names):
    """The columns ``names`` of ``run``'s records, as ``read_history`` gives them."""
    return {name: np.array([r[name] for r in records], dtype=float) for name in names}


@pytest.mark.mpi
def test_restart_after_a_hard_kill_continues_from_the_last_periodic_checkpoint(mpi_tmp_path):
    """A run dies (here: an exception in a callback, no clean stop) at step 87: the last
    checkpoint is at step 80, the files go further. The restart cuts the history at step 80,
    writes the fields from there to a new XDMF file and matches an uninterrupted run."""
    out = os.path.join(mpi_tmp_path, "killed")

    def die(simulation):
        if simulation.step_index == 87:
            raise RuntimeError("killed")

    with pytest.raises(RuntimeError, match="killed"):
        disk().run(out=out, output_every=5, checkpoint_every=20, callback=die)
    gc.collect()  # the failed run's objects, on all ranks at once: destroying them is collective
    comm = MPI.COMM_WORLD
    comm.barrier()
    assert len(read_history(os.path.join(out, "history.csv"))["t"]) == 88
    records = disk().run(out=out, output_every=5, checkpoint_every=20, restart=True)
    reference = os.path.join(mpi_tmp_path, "reference")
    disk().run(out=reference, output_every=5)
    comm.barrier()
    history = read_history(os.path.join(out, "history.csv"))
    assert len(records) == len(history["t"]) == 121
    # the same computation serially: bitwise; on ranks the two builds of the mesh may be
    # partitioned otherwise (dolfinx 0.9), round-off then. The history returned is the one
    # written (repr: the same numbers). Round-off of other partitions: 1e-9 of the columns.
    tolerance = 0.0 if comm.size == 1 else 1e-9
    assert_same_history(read_history(os.path.join(reference, "history.csv")), history, tolerance)
    assert_same_history(columns(records, history.columns), history)  # run returns the whole history
    if comm.rank == 0:
        assert_xdmf_readable(os.path.join(out, "solution.xdmf"), last_time=8.5)
        later = assert_xdmf_readable(os.path.join(out, "solution-from-step80.xdmf"), 12.0)
        assert later == pytest.approx(np.arange(8.5, 12.01, 0.5))
        names = [f"state-00000120.rank{rank:04d}.npz" for rank in range(comm.size)]
        assert sorted(os.listdir(os.path.join(out, "checkpoint"))) == sorted(
            [CHECKPOINT_FILE, *names]
        )


@pytest.mark.mpi
def test_checkpoint_refuses_another_scheme_or_mesh(mpi_tmp_path):
    folder = os.path.join(mpi_tmp_path, "checkpoint")
    simulation = disk(t_end=0.5)
    simulation.run()
    simulation.save_checkpoint(folder)
    with pytest.raises(CheckpointError, match=r"its scheme is 'hybrid', this run's is 'cn'"):
        disk(scheme=CrankNicolson()).load_checkpoint(folder)
    with pytest.raises(CheckpointError, match="its dofs is"):
        disk(mesh_size=6.0).load_checkpoint(folder)
    with pytest.raises(CheckpointError, match=r"past t_end"):
        disk(t_end=0.3).load_checkpoint(folder)
    restored = disk()
    saved = restored.load_checkpoint(folder)
    assert (saved.step, saved.t) == (5, 0.5)
    assert np.array_equal(restored.u.x.array, simulation.u.x.array)  # copied: bitwise


@pytest.mark.mpi
def test_restart_may_change_the_time_step_and_gamma0(mpi_tmp_path):
    """A run stopped at t = 0.5 continues with tau = 0.04 on a grid of its own from
    t = 0.5 (t_end = 0.7 reached exactly, by a shorter last step) and another gamma0;
    the changes are named in the returned state and in out/restarts.log."""
    out = os.path.join(mpi_tmp_path, "run")
    disk(t_end=0.5).run(out=out, checkpoint_every=5)
    problem = impact_problem(dim=2, mesh_size=8.0, gamma0=5e-4)
    changed = Simulation(problem, HybridScheme(), dt=0.04, t_end=0.7)
    history = changed.run(out=out, restart=True)
    # time levels: scalar IEEE arithmetic (no BLAS, no libm), the same bits on any processor
    assert history["t"][5:] == pytest.approx([0.5, 0.54, 0.58, 0.62, 0.66, 0.7], abs=1e-14)
    assert history["t"][-1] == 0.7
    assert history["dt"][6:] == pytest.approx([0.04, 0.04, 0.04, 0.04, 0.04], abs=1e-14)
    if MPI.COMM_WORLD.rank == 0:
        log = open(os.path.join(out, "restarts.log")).read()
        assert "dt 0.1 -> 0.04" in log and "gamma0 0.001 -> 0.0005" in log


def test_restart_after_a_shorter_last_step_goes_back_to_the_grid(tmp_path):
    """A run to t_end = 0.25 with tau = 0.1 ends by a step of 0.05; extended to t = 0.5, it
    steps 0.05 to the grid level 0.3, then tau: never a step longer than tau."""
    out = str(tmp_path / "out")
    disk(t_end=0.25).run(out=out, checkpoint_every=10)
    history = disk(t_end=0.5).run(out=out, restart=True)
    # time levels: scalar IEEE arithmetic (no BLAS, no libm), the same bits on any processor
    assert history["t"] == pytest.approx([0.0, 0.1, 0.2, 0.25, 0.3, 0.4, 0.5], abs=1e-15)
    assert history["dt"][1:] == pytest.approx([0.1, 0.1, 0.05, 0.05, 0.1, 0.1], abs=1e-15)


@pytest.mark.mpi
@pytest.mark.skipif(MPI.COMM_WORLD.size == 1, reason="needs two ranks")
def test_checkpoint_reloads_on_another_number_of_ranks(mpi_tmp_path):
    """Values are matched to dofs by the coordinates of their nodes: a checkpoint of a serial
    run reloads on all ranks, with the same energies."""
    comm = MPI.COMM_WORLD
    folder = os.path.join(mpi_tmp_path, "serial-checkpoint")
    expected = None
    if comm.rank == 0:
        serial = disk(t_end=11.0, comm=MPI.COMM_SELF)  # in contact at t = 11
        serial.run()
        serial.save_checkpoint(folder)
        expected = serial.state()
        serial.solver.destroy()
    expected = comm.bcast(expected, root=0)
    parallel = disk(t_end=12.0)
    saved = parallel.load_checkpoint(folder)
    assert saved.step == 110
    state = parallel.state()
    # the serial state summed on 2 ranks: other sums' round-off, 1e-9 of each value
    for name in ("energy", "energy_theta", "kinetic", "contact_force", "penetration_max"):
        assert state[name] == pytest.approx(expected[name], rel=1e-9, abs=1e-12), name


def test_corrupt_checkpoint_metadata_is_named(tmp_path):
    folder = str(tmp_path / "checkpoint")
    simulation = disk(t_end=0.2)
    simulation.save_checkpoint(folder)
    with open(os.path.join(folder, CHECKPOINT_FILE), "w") as f:
        f.write('{"format": "nitsche-dolfinx checkpoint", "vers')  # cut short
    with pytest.raises(CheckpointError, match="checkpoint.json' cannot be read"):
        disk().load_checkpoint(folder)


def test_interrupted_write_leaves_the_previous_checkpoint(tmp_path):
    """A checkpoint is complete once checkpoint.json names it: leftovers of a write that was
    killed (temporary files, a state file not yet named) do not matter."""
    folder = str(tmp_path / "checkpoint")
    simulation = disk(t_end=0.5)
    simulation.run()
    simulation.save_checkpoint(folder)
    (tmp_path / "checkpoint" / "state-00000009.rank0000.npz.tmp").write_bytes(b"half")
    (tmp_path / "checkpoint" / "checkpoint.json.tmp").write_text("{")
    assert disk().load_checkpoint(folder).step == 5


def test_signal_handlers_are_restored_and_signal_stops_after_the_step(tmp_path):
    before = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)

    def terminate(simulation):
        if simulation.step_index == 3:
            os.kill(os.getpid(), signal.SIGTERM)

    with pytest.raises(RunInterrupted, match=r"SIGTERM after step 3 \(t = 0.3\)") as caught:
        disk().run(out=str(tmp_path / "out"), callback=terminate)
    assert caught.value.exit_status == 143
    assert caught.value.checkpoint.step == 3
    assert (signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)) == before
    assert len(read_history(str(tmp_path / "out" / "history.csv"))["t"]) == 4


def test_history_columns_may_be_added_on_restart_not_left_out(tmp_path):
    """A restart may write more columns: the rows up to its level (t = 0.3) hold nan there,
    the later ones the values of an uninterrupted run; restarts.log names the change. A restart that
    leaves a column of the history out is refused (its rows would end there)."""
    out = str(tmp_path / "out")
    disk(t_end=0.3).run(out=out, checkpoint_every=1)
    with pytest.raises(CheckpointError, match="history columns energy_theta,kinetic"):
        disk().run(out=out, columns=("t", "energy"), restart=True)
    more = [*HISTORY_COLUMNS, "momentum_x", "momentum_y", "centre_of_mass_y"]
    returned = disk(t_end=0.5).run(out=out, columns=more, restart=True)
    reference = disk(t_end=0.5).run(out=str(tmp_path / "reference"), columns=more)
    history = read_history(os.path.join(out, "history.csv"))
    assert history.columns == more and len(history["t"]) == 6
    for name in ("momentum_y", "centre_of_mass_y"):
        assert np.all(np.isnan(history[name][:4])) and np.all(np.isnan(returned[name][:4]))
    # A run extended past its t_end by a restart, against a run straight to the new t_end:
    # the same steps, so bitwise. The restart resumes from t_end itself (0.3) where the
    # straight run is at the grid level 3 x 0.1 = 0.30000000000000004, but that level is on
    # the grid within round-off, so its first step is tau, not 0.4 - 0.3 =
    # 0.10000000000000003: only the t column of that one row differs, by an ulp.
    for name, first in (("energy", 0), ("momentum_y", 4), ("centre_of_mass_y", 4)):
        assert np.array_equal(history[name][first:], reference[name][first:]), name
    assert "history columns" in open(os.path.join(out, "restarts.log")).read()


# -- the command line and the bar demo continue too ---------------------------------------------


def test_command_checkpoints_and_restart_extends_the_run(tmp_path):
    """Run the ring to t = 0.05 with checkpoints, then continue it to t = 0.1 with --restart:
    the history is that of a run straight to t = 0.1, without a duplicated row."""
    short = ring_config(str(tmp_path), t_end=0.05)
    out = str(tmp_path / "out")
    first = run(
        "-m", "nitsche_dolfinx", "run", short, "--out", out, "--quiet", "--checkpoint-every", "4"
    )
    assert first.returncode == 0, first.stderr
    long = ring_config(str(tmp_path), t_end=0.1)
    second = run("-m", "nitsche_dolfinx", "run", long, "--out", out, "--quiet", "--restart")
    assert second.returncode == 0, second.stderr
    straight = run(
        "-m", "nitsche_dolfinx", "run", long, "--out", str(tmp_path / "straight"), "--quiet"
    )
    assert straight.returncode == 0, straight.stderr
    history = read_history(os.path.join(out, "history.csv"))
    assert len(history["t"]) == 21 and np.all(np.diff(history["t"]) > 0)
    straight = read_history(str(tmp_path / "straight" / "history.csv"))
    assert_same_history(straight, history)  # a restart repeats the same operations: bitwise


def test_bar_demo_restarts(tmp_path):
    bar = ["demos/bar_1d.py", "--no-plot", "--no-compare", "--nx", "20", "--dt", "0.075"]
    out = str(tmp_path / "bar")
    first = run(*bar, "--t-end", "1.5", "--checkpoint-every", "7", "--out", out)
    assert first.returncode == 0, first.stderr
    second = run(*bar, "--t-end", "3", "--restart", "--out", out)
    assert second.returncode == 0, second.stderr
    straight = run(*bar, "--t-end", "3", "--out", str(tmp_path / "straight"))
    assert straight.returncode == 0, straight.stderr
    # a restart repeats the same operations: bitwise
    assert_same_history(
        read_history(str(tmp_path / "straight" / "history.csv")),
        read_history(os.path.join(out, "history.csv")),
    )
