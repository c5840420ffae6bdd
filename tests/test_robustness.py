"""Runs that survive bad input, solver failures and interruptions, and lose nothing.

- every bad input stops a demo or the command line at once, with one line naming the
  value, exit status 2 and no traceback;
- a Newton failure stops the run with the step, t and the SNES reason, the outputs
  readable and the last converged state saved;
- SIGINT stops a run (serial, or under mpirun with the signal sent to one rank only)
  after a complete step, and ``--restart`` reproduces the uninterrupted history;
- an error on one MPI rank only aborts the job instead of leaving the others waiting.
"""

import gc
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest
from mpi4py import MPI

from nitsche_dolfinx import CrankNicolson, HybridScheme, Simulation, read_history
from nitsche_dolfinx.cases import impact_problem
from nitsche_dolfinx.checkpoint import CHECKPOINT_FILE, CheckpointError, RunInterrupted

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MESH = os.path.join(REPO, "meshes", "ring_2d.msh")
MPIRUN = shutil.which("mpirun")
#: The disk of the talk on its coarse default mesh (290 DOFs), without the comparison runs.
DISK = ["demos/disk_2d.py", "--no-compare", "--no-plot", "--mesh-size", "8"]

# -- helpers -------------------------------------------------------------------------------


def environment() -> dict:
    env = {**os.environ, "PYTHONPATH": REPO + os.pathsep + os.environ.get("PYTHONPATH", "")}
    env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    env.update(OMPI_MCA_rmaps_base_oversubscribe="1", OPENBLAS_NUM_THREADS="1")
    env.update(MPLBACKEND="Agg")
    return env


def command(*args, ranks: int = 1) -> list[str]:
    """``python args`` (a demo path relative to the repository, or ``-m ...``), under mpirun
    when ``ranks > 1``."""
    args = [os.path.join(REPO, a) if a.startswith("demos/") else a for a in args]
    prefix = [MPIRUN, "-n", str(ranks)] if ranks > 1 else []
    return [*prefix, sys.executable, *args]


def run(*args, ranks: int = 1, timeout: float = 300) -> subprocess.CompletedProcess:
    return subprocess.run(
        command(*args, ranks=ranks),
        capture_output=True,
        text=True,
        env=environment(),
        timeout=timeout,
    )


def assert_one_line_error(result, named: str, status: int = 2) -> None:
    """Exit status, the value named on stderr, and no traceback anywhere."""
    assert result.returncode == status, (result.returncode, result.stderr)
    assert named in result.stderr, result.stderr
    assert "Traceback" not in result.stderr + result.stdout


def assert_same_history(a: dict, b: dict, tolerance: float = 1e-12) -> float:
    """The largest difference of two histories, relative to each column's largest value."""
    assert list(a) == list(b)
    assert len(a["t"]) == len(b["t"])
    worst = 0.0
    for name in a:
        if name == "step_seconds":
            continue
        scale = max(np.abs(a[name]).max(), 1e-300)
        worst = max(worst, np.abs(a[name] - b[name]).max() / scale)
    assert worst <= tolerance, worst
    return worst


def assert_xdmf_readable(path: str, last_time: float) -> list[float]:
    """The XDMF file reopens (mesh read back) and its time levels are increasing, none after
    ``last_time``; with h5py, every dataset it names is finite."""
    from dolfinx.io import XDMFFile

    with XDMFFile(MPI.COMM_SELF, path, "r") as xdmf:
        mesh = xdmf.read_mesh(name="mesh")
    assert mesh.topology.index_map(mesh.topology.dim).size_global > 0
    import xml.etree.ElementTree as ElementTree

    root = ElementTree.parse(path).getroot()
    times = {}
    for collection in root.iter("Grid"):
        if collection.get("GridType") == "Collection":
            values = [float(grid.find("Time").get("Value")) for grid in collection]
            assert values == sorted(set(values)), values  # no time level twice
            assert values[-1] <= last_time + 1e-9
            times[collection.get("Name")] = values
    assert set(times) == {"displacement", "velocity", "von_mises"}
    try:
        import h5py
    except ImportError:
        return times["displacement"]
    with h5py.File(os.path.splitext(path)[0] + ".h5", "r") as h5:
        for item in root.iter("DataItem"):
            name = item.text.strip().split(":", 1)[1]
            assert np.all(np.isfinite(h5[name][()])), name
    return times["displacement"]


def ring_config(folder: str, replace: dict | None = None, t_end: float = 0.05) -> str:
    """The shipped ring configuration, shortened, next to a copy of its mesh."""
    text = open(os.path.join(REPO, "demos", "ring_2d.toml")).read()
    text = text.replace('"../meshes/ring_2d.msh"', '"ring_2d.msh"')
    text = text.replace("t_end = 1.0", f"t_end = {t_end}")
    for old, new in (replace or {}).items():
        assert old in text, old
        text = text.replace(old, new, 1)
    shutil.copy(MESH, os.path.join(folder, "ring_2d.msh"))
    path = os.path.join(folder, "config.toml")
    with open(path, "w") as f:
        f.write(text)
    return path


def child_pids(pid: int) -> list[int]:
    """The processes whose parent is ``pid`` (the ranks that mpirun started)."""
    children = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            children.append(int(entry))
    return sorted(children)


# -- 1. bad input: one line naming the value, before any computing ---------------------------


@pytest.mark.parametrize(
    "flags, named",
    [
        (["--dt", "-0.1"], "dt=-0.1"),
        (["--dt", "0"], "dt=0.0"),
        (["--t-end", "0.05"], "t_end=0.05 < dt=0.1"),
        (["--gamma0", "0"], "gamma0=0.0"),
        (["--gamma0", "-0.001"], "gamma0=-0.001"),
        (["--scheme", "leapfrog"], "invalid choice: 'leapfrog'"),
        (["--scheme", "theta", "--theta", "1.5"], "theta=1.5"),
        (["--scheme", "theta", "--theta", "-0.5"], "theta=-0.5"),
        (["--scheme", "newmark", "--beta", "0.7"], "beta=0.7"),
        (["--scheme", "newmark", "--gamma", "1.5"], "gamma=1.5"),
        (["--checkpoint-every", "-1"], "--checkpoint-every must be >= 0, got -1"),
        (["--mesh-size", "0"], "--mesh-size 0"),
    ],
    ids=[
        "dt-negative",
        "dt-zero",
        "t-end-below-dt",
        "gamma0-zero",
        "gamma0-negative",
        "unknown-scheme",
        "theta-above-1",
        "theta-below-0",
        "newmark-beta",
        "newmark-gamma",
        "checkpoint-every",
        "mesh-size",
    ],
)
def test_disk_demo_refuses_bad_flag(tmp_path, flags, named):
    out = tmp_path / "out"
    result = run(*DISK, *flags, "--out", str(out))
    assert_one_line_error(result, named)
    assert not (out / "history.csv").exists()


def test_bar_demo_refuses_unknown_method(tmp_path):
    result = run("demos/bar_1d.py", "--method", "lagrange", "--out", str(tmp_path / "out"))
    assert_one_line_error(result, "invalid choice: 'lagrange'")


@pytest.mark.parametrize("demo", ["disk", "bar"])
def test_demo_refuses_unwritable_output_folder(tmp_path, demo):
    """CI runs as root, so no chmod: the parent of --out is a regular file."""
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    out = str(blocker / "out")
    script = DISK if demo == "disk" else ["demos/bar_1d.py", "--no-plot"]
    result = run(*script, "--out", out)
    assert_one_line_error(result, f"output folder {out!r} cannot be written: Not a directory")


def test_restart_without_checkpoint_is_named(tmp_path):
    out = tmp_path / "out"
    result = run(*DISK, "--restart", "--out", str(out))
    assert_one_line_error(result, f"no checkpoint in {str(out / 'checkpoint')!r}")


@pytest.mark.parametrize(
    "replace, named",
    [
        ({"rho = 1.0": "rho = -1.0"}, "density rho must be positive, got rho=-1.0"),
        ({"nu = 0.3": "nu = 0.5"}, "Poisson's ratio nu must lie in (-1, 1/2), got nu=0.5"),
        ({"nu = 0.3": "nu = -1.2"}, "got nu=-1.2"),
        ({'name = "hybrid"': 'name = "leapfrog"'}, "unknown scheme 'leapfrog'"),
        ({"gamma0 = 1e-6": "gamma0 = -1e-6"}, "gamma0=-1e-06"),
        ({"dt = 0.005": "dt = 0.5"}, "t_end=0.05 < dt=0.5"),
        ({"tag = 1": "tag = 42"}, "facet tag 42 is not in the mesh"),
        ({"normal = [0.0, 1.0]": "normal = [0.0, 0.0]"}, "non-zero length, got [0.0, 0.0]"),
        ({'"ring_2d.msh"': '"missing.msh"'}, "missing.msh' does not exist"),
    ],
    ids=[
        "negative-density",
        "poisson-ratio-half",
        "poisson-ratio-below-minus-one",
        "unknown-scheme",
        "gamma0-negative",
        "t-end-below-dt",
        "absent-contact-tag",
        "zero-obstacle-normal",
        "missing-mesh",
    ],
)
def test_command_refuses_bad_configuration(tmp_path, replace, named):
    config = ring_config(str(tmp_path), replace)
    out = tmp_path / "out"
    result = run("-m", "nitsche_dolfinx", "run", config, "--out", str(out))
    assert_one_line_error(result, named)
    assert not (out / "history.csv").exists()


def test_command_refuses_corrupt_mesh(tmp_path):
    config = ring_config(str(tmp_path))
    text = open(MESH).read()
    with open(tmp_path / "ring_2d.msh", "w") as f:  # cut in the middle of the nodes
        f.write(text[: len(text) // 3])
    result = run("-m", "nitsche_dolfinx", "run", config, "--out", str(tmp_path / "out"))
    assert_one_line_error(result, "ring_2d.msh' cannot be read")


def test_command_refuses_unwritable_output_folder(tmp_path):
    config = ring_config(str(tmp_path))
    (tmp_path / "a-file").write_text("not a folder")
    out = str(tmp_path / "a-file" / "out")
    result = run("-m", "nitsche_dolfinx", "run", config, "--out", out)
    assert_one_line_error(result, f"output folder {out!r} cannot be written")


# -- 2. solver failure ------------------------------------------------------------------------


def test_newton_failure_keeps_outputs_and_saves_last_converged_state(tmp_path):
    """snes_max_it = 1: the disk converges in one Newton iteration per step until the first
    step of the contact that needs two (step 183 with this host's gmsh; the mesh, so the
    step, depends on the gmsh version)."""
    out = tmp_path / "failed"
    flags = ["--t-end", "20", "--output-every", "10", "--quiet"]
    result = run(*DISK, *flags, "--petsc", "snes_max_it=1", "--out", str(out))
    found = re.search(r"at step (\d+) \(t = ([0-9.]+)\): SNES did not converge", result.stderr)
    assert found, result.stderr
    step, dt = int(found.group(1)), 0.1
    assert 100 < step <= 200 and float(found.group(2)) == pytest.approx(step * dt)
    assert_one_line_error(result, f"at step {step} (t = {found.group(2)}): SNES did not", status=1)
    assert "DIVERGED_MAX_IT" in result.stderr
    saved = f"the state at step {step - 1} (t = {(step - 1) * dt:.6g}) is saved in"
    assert f"{saved} {out / 'checkpoint'}" in result.stderr
    history = read_history(str(out / "history.csv"))
    assert len(history["t"]) == step and history["t"][-1] == pytest.approx((step - 1) * dt)
    assert np.all(np.isfinite(history["energy"]))
    last_output = (step - 1) // 10 * 10 * dt
    times = assert_xdmf_readable(str(out / "solution.xdmf"), last_time=last_output)
    assert times == pytest.approx(np.arange(0.0, last_output + 0.05, 1.0))
    with open(out / "checkpoint" / CHECKPOINT_FILE) as f:
        assert json.load(f)["step"] == step - 1

    # with Newton's usual iterations, the restart reproduces an uninterrupted run
    restarted = run(*DISK, *flags, "--restart", "--out", str(out))
    assert restarted.returncode == 0, restarted.stderr
    reference = run(*DISK, *flags, "--out", str(tmp_path / "reference"))
    assert reference.returncode == 0, reference.stderr
    assert_same_history(
        read_history(str(tmp_path / "reference" / "history.csv")),
        read_history(str(out / "history.csv")),
    )
    assert_xdmf_readable(str(out / "solution.xdmf"), last_time=20.0)


# -- 3./4. SIGINT and restart -----------------------------------------------------------------


def interrupt_disk(out: str, ranks: int, after_step: int = 20) -> tuple[subprocess.Popen, str]:
    """Start the disk demo (400 steps on the h = 4 mesh), send SIGINT once it has printed step
    ``after_step``: to the process, or under mpirun to the last rank only (the ranks agree
    on stopping). Returns the finished process and its stderr."""
    args = [*DISK[:-1], "4", "--t-end", "40", "--output-every", "10", "--out", out]
    process = subprocess.Popen(
        command(*args, ranks=ranks),
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

    args = [*DISK[:-1], "4", "--t-end", "40", "--output-every", "10", "--quiet"]
    restarted = run(*args, "--restart", "--out", out, ranks=ranks)
    assert restarted.returncode == 0, restarted.stderr
    reference = run(*args, "--out", str(tmp_path / "reference"), ranks=ranks)
    assert reference.returncode == 0, reference.stderr
    difference = assert_same_history(
        read_history(str(tmp_path / "reference" / "history.csv")),
        read_history(os.path.join(out, "history.csv")),
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


# -- 5. errors on one rank only ----------------------------------------------------------------

ONE_RANK_SCRIPT = textwrap.dedent(
    """
    import sys
    from mpi4py import MPI
    from nitsche_dolfinx.arguments import one_line_errors

    comm = MPI.COMM_WORLD
    with one_line_errors("one-rank", comm, grace=float(sys.argv[2])):
        if sys.argv[1] == "all" or comm.rank == 1:
            raise ValueError(f"bad value on rank {comm.rank}")
        comm.barrier()  # without the abort, rank 0 would wait here forever
    print("finished", comm.rank)
    """
)


@pytest.mark.mpi
@pytest.mark.skipif(MPIRUN is None, reason="needs mpirun")
@pytest.mark.skipif(MPI.COMM_WORLD.size > 1, reason="starts mpirun itself: run it serially")
def test_error_on_one_rank_aborts_every_rank(tmp_path):
    script = tmp_path / "one_rank.py"
    script.write_text(ONE_RANK_SCRIPT)
    start = time.monotonic()
    result = run(str(script), "one", "2", ranks=2, timeout=120)
    assert result.returncode != 0
    assert (
        "one-rank: error on rank 1 of 2 (aborting all ranks): bad value on rank 1" in result.stderr
    )
    assert "finished" not in result.stdout
    assert time.monotonic() - start < 60


@pytest.mark.mpi
@pytest.mark.skipif(MPIRUN is None, reason="needs mpirun")
@pytest.mark.skipif(MPI.COMM_WORLD.size > 1, reason="starts mpirun itself: run it serially")
def test_error_on_every_rank_is_reported_once_by_rank_0(tmp_path):
    script = tmp_path / "all_ranks.py"
    script.write_text(ONE_RANK_SCRIPT)
    result = run(str(script), "all", "30", ranks=2, timeout=120)
    assert result.returncode == 2
    assert result.stderr.count("one-rank: error:") == 1
    assert "bad value on rank 0" in result.stderr and "aborting" not in result.stderr


@pytest.mark.mpi
@pytest.mark.skipif(MPIRUN is None, reason="needs mpirun")
@pytest.mark.skipif(MPI.COMM_WORLD.size > 1, reason="starts mpirun itself: run it serially")
def test_corrupt_mesh_under_mpirun_fails_on_every_rank(tmp_path):
    """Rank 0 alone reads a .msh file: its failure must reach the other rank."""
    config = ring_config(str(tmp_path))
    (tmp_path / "ring_2d.msh").write_text("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n12 x\n")
    result = run("-m", "nitsche_dolfinx", "run", config, ranks=2, timeout=120)
    assert_one_line_error(result, "ring_2d.msh' cannot be read")
    assert result.stderr.count("nitsche-dolfinx: error:") == 1


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
    assert_same_history(read_history(os.path.join(reference, "history.csv")), history)
    assert_same_history(columns(records, history), history)  # run returns the whole history
    if comm.rank == 0:
        assert_xdmf_readable(os.path.join(out, "solution.xdmf"), last_time=8.5)
        later = assert_xdmf_readable(os.path.join(out, "solution-from-step80.xdmf"), 12.0)
        assert later == pytest.approx(np.arange(8.5, 12.01, 0.5))
        names = [f"state-00000120.rank{rank:04d}.npz" for rank in range(comm.size)]
        assert sorted(os.listdir(os.path.join(out, "checkpoint"))) == sorted(
            [CHECKPOINT_FILE, *names]
        )


@pytest.mark.mpi
def test_checkpoint_refuses_another_scheme_time_step_or_mesh(mpi_tmp_path):
    folder = os.path.join(mpi_tmp_path, "checkpoint")
    simulation = disk(t_end=0.5)
    simulation.run()
    simulation.save_checkpoint(folder)
    with pytest.raises(CheckpointError, match=r"its scheme is 'hybrid', this run's is 'cn'"):
        disk(scheme=CrankNicolson()).load_checkpoint(folder)
    with pytest.raises(CheckpointError, match=r"its dt is 0.1, this run's is 0.05"):
        disk(dt=0.05).load_checkpoint(folder)
    with pytest.raises(CheckpointError, match="its dofs is"):
        disk(mesh_size=6.0).load_checkpoint(folder)
    with pytest.raises(CheckpointError, match=r"past t_end"):
        disk(t_end=0.3).load_checkpoint(folder)
    restored = disk()
    saved = restored.load_checkpoint(folder)
    assert (saved.step, saved.t) == (5, 0.5)
    assert np.array_equal(restored.u.x.array, simulation.u.x.array)


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
    for name in ("energy", "energy_theta", "kinetic", "contact_force", "penetration_max"):
        assert state[name] == pytest.approx(expected[name], rel=1e-12, abs=1e-12), name


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


def test_history_with_other_columns_is_not_continued(tmp_path):
    out = str(tmp_path / "out")
    disk(t_end=0.3).run(out=out, checkpoint_every=1)
    with pytest.raises(CheckpointError, match="history columns"):
        disk().run(out=out, columns=("t", "energy"), restart=True)


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
    assert_same_history(read_history(str(tmp_path / "straight" / "history.csv")), history)


def test_bar_demo_restarts(tmp_path):
    bar = ["demos/bar_1d.py", "--no-plot", "--no-compare", "--nx", "20", "--dt", "0.075"]
    out = str(tmp_path / "bar")
    first = run(*bar, "--t-end", "1.5", "--checkpoint-every", "7", "--out", out)
    assert first.returncode == 0, first.stderr
    second = run(*bar, "--t-end", "3", "--restart", "--out", out)
    assert second.returncode == 0, second.stderr
    straight = run(*bar, "--t-end", "3", "--out", str(tmp_path / "straight"))
    assert straight.returncode == 0, straight.stderr
    assert_same_history(
        read_history(str(tmp_path / "straight" / "history.csv")),
        read_history(os.path.join(out, "history.csv")),
    )
