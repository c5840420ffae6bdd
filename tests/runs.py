"""Helpers of the tests that run the demos and the command as users do: in a subprocess,
serially or under mpirun, and check what they print and write."""

import os
import shutil
import subprocess
import sys

import numpy as np
from mpi4py import MPI

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MESH = os.path.join(REPO, "meshes", "ring_2d.msh")
MPIRUN = shutil.which("mpirun")
#: The disk demo, short and without the compared runs.
DISK = ["demos/disk_2d.py", "--no-compare", "--no-plot", "--mesh-size", "8"]


def environment() -> dict:
    env = {**os.environ, "PYTHONPATH": REPO + os.pathsep + os.environ.get("PYTHONPATH", "")}
    env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    # the BLAS threads of the test's own process (tests/conftest.py: one by default)
    env.update(OMPI_MCA_rmaps_base_oversubscribe="1")
    env.setdefault("OPENBLAS_NUM_THREADS", "1")
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


def column_names(history) -> list:
    """The columns of a History (``read_history``, ``run``) or of a dict of columns."""
    return history.columns if hasattr(history, "columns") else list(history)


def assert_same_history(a, b, tolerance: float = 0.0) -> float:
    """The largest difference of two histories, relative to each column's largest value:
    bitwise by default, for two runs of the same computation (the same code, inputs and
    partition: a restart from a level of the run's grid against an uninterrupted run);
    ``tolerance`` otherwise."""
    assert column_names(a) == column_names(b)
    assert len(a["t"]) == len(b["t"])
    worst = 0.0
    for name in column_names(a):
        if name == "step_seconds":
            continue
        scale = max(np.abs(a[name]).max(), 1e-300)
        worst = max(worst, np.abs(a[name] - b[name]).max() / scale)
    assert worst <= tolerance, worst
    return worst


def assert_xdmf_readable(path: str, last_time: float) -> list[float]:
    """The XDMF file reopens (mesh read back), its time levels are increasing, none after
    ``last_time``, each with at least the displacement, velocity and von Mises stress; with
    h5py, every dataset it names is finite. Returns the times."""
    import xml.etree.ElementTree as ElementTree

    from dolfinx.io import XDMFFile

    with XDMFFile(MPI.COMM_SELF, path, "r") as xdmf:
        mesh = xdmf.read_mesh(name="mesh")
    assert mesh.topology.index_map(mesh.topology.dim).size_global > 0
    root = ElementTree.parse(path).getroot()
    (series,) = [grid for grid in root.iter("Grid") if grid.get("GridType") == "Collection"]
    assert series.get("Name") == "fields"
    times = [float(level.find("Time").get("Value")) for level in series]
    assert times == sorted(set(times)), times  # no time level twice
    assert times[-1] <= last_time + 1e-9
    for level in series:
        names = {attribute.get("Name") for attribute in level.findall("Attribute")}
        assert {"displacement", "velocity", "von_mises"} <= names, names
    try:
        import h5py
    except ImportError:
        return times
    folder = os.path.dirname(path)
    for item in root.iter("DataItem"):
        name, inside = item.text.strip().split(":", 1)
        with h5py.File(os.path.join(folder, name), "r") as h5:
            assert np.all(np.isfinite(h5[inside][()])), inside
    return times


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
