"""Runs that survive bad input, solver failures and errors on one rank.

- every bad input stops a demo or the command line at once, with one line naming the
  value, exit status 2 and no traceback;
- a Newton failure stops the run with the step, t and the SNES reason, the outputs
  readable and the last converged state saved;
- an error on one MPI rank only aborts the job instead of leaving the others waiting.

Interruptions, checkpoints and restarts are in ``test_checkpoints.py``.
"""

import json
import re
import textwrap
import time

import numpy as np
import pytest
from mpi4py import MPI
from runs import (
    DISK,
    MESH,
    MPIRUN,
    assert_one_line_error,
    assert_same_history,
    assert_xdmf_readable,
    ring_config,
    run,
)

from nitsche_dolfinx import read_history
from nitsche_dolfinx.output import CHECKPOINT_FILE

# -- 1. bad input: one line naming the value, before any computing ---------------------------


@pytest.mark.parametrize(
    "flags, named",
    [
        (["--dt", "-0.1"], "--dt -0.1: the time step must be positive"),
        (["--dt", "0"], "--dt 0:"),
        (["--t-end", "0.05"], "--t-end 0.05: the final time must be finite and at least one"),
        (["--gamma0", "0"], "--gamma0 0: the Nitsche parameter must be positive"),
        (["--gamma0", "-0.001"], "--gamma0 -0.001:"),
        (["--scheme", "leapfrog"], "invalid choice: 'leapfrog'"),
        (["--scheme", "theta", "--theta", "1.5"], "--theta 1.5: theta must lie in [0, 1]"),
        (["--scheme", "theta", "--theta", "-0.5"], "--theta -0.5:"),
        (["--scheme", "newmark", "--beta", "0.7"], "--beta 0.7: Newmark beta must lie in [0, 1/2]"),
        (["--scheme", "newmark", "--gamma", "1.5"], "--gamma 1.5:"),
        (["--checkpoint-every", "-1"], "--checkpoint-every -1: must be an integer >= 0"),
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
        ({"rho = 1.0": "rho = -1.0"}, "[material] rho = -1.0: the density must be positive"),
        ({"nu = 0.3": "nu = 0.5"}, "[material] nu = 0.5: Poisson's ratio must lie in (-1, 1/2)"),
        ({"nu = 0.3": "nu = -1.2"}, "[material] nu = -1.2"),
        ({'name = "hybrid"': 'name = "leapfrog"'}, "[scheme] name = 'leapfrog': unknown scheme"),
        ({"gamma0 = 1e-6": "gamma0 = -1e-6"}, "[nitsche] gamma0 = -1e-06: the Nitsche"),
        ({"dt = 0.005": "dt = 0.5"}, "[scheme] t_end = 0.05: the final time"),
        ({"tag = 1": "tag = 42"}, "facet tag 42 is not in the mesh"),
        ({"normal = [0.0, 1.0]": "normal = [0.0, 0.0]"}, "normal = [0.0, 0.0]: the plane's normal"),
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
    """snes_max_it = 1 and no step cutting: the disk converges in one Newton iteration per
    step until the first step of the contact that needs two (step 183 with this host's
    gmsh; the mesh, so the step, depends on the gmsh version)."""
    out = tmp_path / "failed"
    flags = ["--t-end", "20", "--output-every", "10", "--quiet"]
    failing = ["--petsc", "snes_max_it=1", "--max-step-cuts", "0"]
    result = run(*DISK, *flags, *failing, "--out", str(out))
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
    # a restart repeats the same operations: bitwise
    assert_same_history(
        read_history(str(tmp_path / "reference" / "history.csv")),
        read_history(str(out / "history.csv")),
    )
    assert_xdmf_readable(str(out / "solution.xdmf"), last_time=20.0)


# -- 5. errors on one rank only ----------------------------------------------------------------

ONE_RANK_SCRIPT = textwrap.dedent(
    """
    import sys
    from mpi4py import MPI
    from nitsche_dolfinx.cli import one_line_errors

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
