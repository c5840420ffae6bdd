"""The command line on the shipped TOML file, and its one-line errors for bad configurations."""

import os
import re
import shutil
import subprocess
import sys

import numpy as np
import pytest
from mpi4py import MPI

from nitsche_dolfinx import read_history
from nitsche_dolfinx.cli import main
from nitsche_dolfinx.config import ConfigError, load_config

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CONFIG = os.path.join(REPO, "demos", "ring_2d.toml")
MESH = os.path.join(REPO, "meshes", "ring_2d.msh")


def cli(*args, cwd=None):
    env = {**os.environ, "PYTHONPATH": REPO + os.pathsep + os.environ.get("PYTHONPATH", "")}
    return subprocess.run(
        [sys.executable, "-m", "nitsche_dolfinx", *args],
        capture_output=True,
        text=True,
        env=env,
        cwd=cwd,
        timeout=600,
    )


def short_config(tmp, text=None, **replace):
    """A copy of the shipped configuration next to a copy of its mesh, shortened to 10 steps."""
    text = text if text is not None else open(CONFIG).read()
    text = re.sub(r'file = ".*"', 'file = "ring_2d.msh"', text)
    text = re.sub(r"t_end = .*", "t_end = 0.05", text)
    text = re.sub(r"dt = .*", "dt = 0.005", text)
    for old, new in replace.items():
        assert old in text, old
        text = text.replace(old, new)
    shutil.copy(MESH, os.path.join(tmp, "ring_2d.msh"))
    path = os.path.join(tmp, "config.toml")
    with open(path, "w") as f:
        f.write(text)
    return path


@pytest.mark.mpi
def test_cli_runs_shipped_config(mpi_tmp_path):
    """In process, on every rank: `nitsche-dolfinx run` writes its history and XDMF."""
    comm = MPI.COMM_WORLD
    path = short_config(mpi_tmp_path) if comm.rank == 0 else None
    path = comm.bcast(path, root=0)
    out = os.path.join(mpi_tmp_path, "out")
    assert main(["run", path, "--out", out, "--quiet"]) == 0
    comm.barrier()
    history = read_history(os.path.join(out, "history.csv"))
    assert len(history["t"]) == 11
    assert np.all(np.isfinite(history["energy"]))
    assert os.path.exists(os.path.join(out, "solution.xdmf"))


def test_cli_subprocess_progress_and_quiet(tmp_path):
    path = short_config(str(tmp_path))
    loud = cli("run", path, "--out", str(tmp_path / "loud"))
    assert loud.returncode == 0, loud.stderr
    assert len(re.findall(r"^step +\d+ +t = ", loud.stdout, flags=re.M)) == 11
    quiet = cli("run", path, "--out", str(tmp_path / "quiet"), "--quiet")
    assert quiet.returncode == 0 and "step" not in quiet.stdout
    a = read_history(str(tmp_path / "loud" / "history.csv"))
    b = read_history(str(tmp_path / "quiet" / "history.csv"))
    assert np.array_equal(a["energy"], b["energy"])  # the same run twice: bitwise


@pytest.mark.parametrize(
    "replace, named",
    [
        ({"[scheme]": "[scheme]\ntau = 0.1"}, "unknown key 'tau'"),
        ({"dt = 0.005": 'dt = "fast"'}, "dt must be a number or \"auto\", got 'fast'"),
        ({'file = "ring_2d.msh"': 'file = "missing.msh"'}, "missing.msh' does not exist"),
        ({"tag = 1": "tag = 42"}, "facet tag 42 is not in the mesh"),
        ({"[scheme]": "[schemes]"}, "unknown table [schemes]"),
        ({"dt = 0.005": "dt = -0.1"}, "[scheme] dt = -0.1"),
    ],
    ids=["unknown-key", "wrong-type", "missing-mesh", "absent-tag", "unknown-table", "bad-dt"],
)
def test_bad_config_fails_before_computing(tmp_path, replace, named):
    path = short_config(str(tmp_path))
    text = open(path).read()
    for old, new in replace.items():
        assert old in text, old
        text = text.replace(old, new, 1)
    open(path, "w").write(text)
    out = tmp_path / "out"
    result = cli("run", path, "--out", str(out))
    assert result.returncode == 2
    assert named in result.stderr
    assert "Traceback" not in result.stderr + result.stdout
    assert not (out / "history.csv").exists()  # nothing was computed


def test_missing_required_key_is_named(tmp_path):
    path = short_config(str(tmp_path))
    text = re.sub(r"t_end = .*\n", "", open(path).read())
    open(path, "w").write(text)
    with pytest.raises(ConfigError, match="missing required key 't_end'"):
        load_config(path)


def test_check_only(tmp_path):
    result = cli("run", short_config(str(tmp_path)), "--check")
    assert result.returncode == 0 and "valid" in result.stdout
