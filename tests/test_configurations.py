"""Each shipped demo and its TOML file side by side: the same history.csv, column by column.

Both run in this process, shortened the same way (small t_end, coarse meshes): the demo
through its ``main`` with flags, the TOML file through ``nitsche-dolfinx run`` on a
copy whose values are replaced as the flags say. Every column but the wall time
``step_seconds`` must agree to round-off.
"""

import os
import runpy
import sys
from pathlib import Path

import numpy as np
import pytest
from runs import REPO

from nitsche_dolfinx import read_history
from nitsche_dolfinx.cli import main as cli

DEMOS = os.path.join(REPO, "demos")

#: The gmsh bodies coarse, with long steps (a TOML file's values, and the demos' flags).
COARSE = {"dt = 0.1": "dt = 0.5", "mesh_size = 8.0": "mesh_size = 16.0"}
COARSE_FLAGS = ["--dt", "0.5", "--mesh-size", "16"]

#: name -> (TOML file, its replacements, the demo and its flags, the demo's run folder).
CASES = {
    "bar_1d": (
        "bar_1d.toml",
        {"t_end = 6.0": "t_end = 1.5", "nx = 100": "nx = 40", "every = 10": "every = 5"},
        ["bar_1d.py", "--t-end", "1.5", "--nx", "40", "--no-compare", "--output-every", "5"],
        "",
    ),
    "compare_methods_1d_penalty_hybrid": (
        "compare_methods_1d_penalty_hybrid.toml",
        {"t_end = 6.0": "t_end = 1.5", "nx = 100": "nx = 40"},
        ["compare_methods_1d.py", "--t-end", "1.5", "--nx", "40", "--penalty"],
        "penalty_hybrid",
    ),
    "compare_methods_1d_modified_mass": (
        "compare_methods_1d_modified_mass.toml",
        {"t_end = 6.0": "t_end = 1.5", "nx = 100": "nx = 40"},
        ["compare_methods_1d.py", "--t-end", "1.5", "--nx", "40"],
        "modified_mass",
    ),
    "ring_2d": (
        "ring_2d.toml",
        {"t_end = 1.0": "t_end = 0.2"},
        ["ring_2d.py", "--t-end", "0.2"],
        "",
    ),
    "disk_2d": (
        "disk_2d.toml",
        {"t_end = 40.0": "t_end = 11.0", **COARSE},
        ["disk_2d.py", "--t-end", "11", *COARSE_FLAGS, "--no-compare"],
        "",
    ),
    "ball_3d": (
        "ball_3d.toml",
        {"t_end = 40.0": "t_end = 11.0", **COARSE},
        ["ball_3d.py", "--t-end", "11", *COARSE_FLAGS, "--no-compare"],
        "",
    ),
    "friction_block_2d": (
        "friction_block_2d.toml",
        {"t_end = 7.0": "t_end = 0.6"},
        ["friction_block_2d.py", "--t-end", "0.6"],
        "",
    ),
    "two_bars_1d": (
        "two_bars_1d.toml",
        {"t_end = 4.0": "t_end = 1.2", "nx = 100": "nx = 30"},
        ["two_bars_1d.py", "--t-end", "1.2", "--nx", "30"],
        "",
    ),
    "two_disks_2d": (
        "two_disks_2d.toml",
        {"t_end = 20.0": "t_end = 2.0", **COARSE},
        ["two_disks_2d.py", "--t-end", "2", *COARSE_FLAGS, "--no-compare"],
        "",
    ),
    "two_disks_2d_neo_hookean": (
        "two_disks_2d_neo_hookean.toml",
        {"t_end = 20.0": "t_end = 2.0", **COARSE},
        ["two_disks_2d.py", "--law", "neo_hookean", "--t-end", "2", *COARSE_FLAGS,
         "--no-compare"],
        "",
    ),
    "sliding_disks_2d": (
        "sliding_disks_2d.toml",
        {"t_end = 14.0": "t_end = 8.0", "dt = 0.1": "dt = 0.5",
         "mesh_size = 4.0": "mesh_size = 8.0"},
        ["sliding_disks_2d.py", "--t-end", "8", "--dt", "0.5", "--mesh-size", "8"],
        "",
    ),
    "two_balls_3d": (
        "two_balls_3d.toml",
        {"t_end = 20.0": "t_end = 1.5", **COARSE},
        ["two_balls_3d.py", "--t-end", "1.5", *COARSE_FLAGS, "--no-compare"],
        "",
    ),
    "indenter_2d": (
        "indenter_2d.toml",
        {"t_end = 1e-4": "t_end = 3e-5", "nx = 80": "nx = 16", "ny = 20": "ny = 4"},
        ["indenter_2d.py", "--t-end", "3e-5", "--nx", "16"],
        "",
    ),
    "shaker_2d": (
        "shaker_2d.toml",
        {"t_end = 5e-4": "t_end = 1e-4", "nx = 40": "nx = 8", "ny = 20": "ny = 4"},
        ["shaker_2d.py", "--t-end", "1e-4", "--nx", "8"],
        "",
    ),
    "block_on_slab_2d": (
        "block_on_slab_2d.toml",
        {"t_end = 8.5": "t_end = 0.5"},
        ["block_on_slab_2d.py", "--t-end", "0.5"],
        "",
    ),
    "c_shape_2d": (
        "c_shape_2d.toml",
        {"t_end = 3.0": "t_end = 0.5", "mesh_size = 0.1": "mesh_size = 0.2"},
        ["c_shape_2d.py", "--t-end", "0.5", "--mesh-size", "0.2"],
        "",
    ),
    "soft_ring_2d": (
        "soft_ring_2d.toml",
        {"t_end = 3.0": "t_end = 0.2"},
        ["soft_ring_2d.py", "--t-end", "0.2"],
        "",
    ),
    "rubber_ball_3d": (
        "rubber_ball_3d.toml",
        {"t_end = 6.0": "t_end = 0.2", "mesh_size = 0.3": "mesh_size = 0.6"},
        ["rubber_ball_3d.py", "--t-end", "0.2", "--mesh-size", "0.6"],
        "",
    ),
    "ball_3d_neo_hookean": (
        "ball_3d_neo_hookean.toml",
        {"t_end = 40.0": "t_end = 11.0", **COARSE},
        ["ball_3d.py", "--law", "neo_hookean", "--gamma0", "1e-4", "--t-end", "11",
         *COARSE_FLAGS, "--no-compare"],
        "",
    ),
    "ball_on_slab_3d": (
        "ball_on_slab_3d.toml",
        {"t_end = 15.0": "t_end = 2.0", "dt = 0.1": "dt = 1.0",
         "mesh_size = 8.0": "mesh_size = 12.0"},
        ["ball_on_slab_3d.py", "--t-end", "2", "--dt", "1", "--mesh-size", "12"],
        "",
    ),
}  # fmt: skip


def run_demo(argv: list[str], out: str) -> None:
    """The demo ``argv[0]`` as a script, in this process."""
    path = os.path.join(DEMOS, argv[0])
    saved = sys.argv, list(sys.path)
    sys.argv = [path, *argv[1:], "--no-plot", "--quiet", "--out", out]
    sys.path.insert(0, DEMOS)  # disk_2d.py imports ball_3d.py
    try:
        runpy.run_path(path, run_name="__main__")
    finally:
        sys.argv, sys.path[:] = saved


def shortened(name: str, replace: dict, folder: str) -> str:
    """A copy of the demo's TOML file with ``replace`` done, its mesh file made absolute."""
    text = open(os.path.join(DEMOS, name)).read()
    text = text.replace('"../meshes/', f'"{REPO}/meshes/')
    for old, new in replace.items():
        assert old in text, old
        text = text.replace(old, new)
    path = os.path.join(folder, name)
    with open(path, "w") as f:
        f.write(text)
    return path


#: Columns that a TOML file computes otherwise than its demo: the bars' mean velocities, by
#: a [[probe]] with the problem's quadrature (2 points a cell) and by the demo's own (1):
#: sums of 60 and 30 terms, and of as many weights for the length, each up to n eps/2 of
#: max |v| off: 2e-14 of the column's largest value (measured: 1.1e-15). Other sums, so
#: 1e-9 of the column's largest value, which holds on any processor.
OTHERWISE_COMPUTED = {"v_left": 1e-9, "v_right": 1e-9}


def assert_same_columns(a, b, tolerance: float = 0.0) -> float:
    """The same columns in the same order and the same values (but the wall time): the
    largest difference relative to each column's largest value, bitwise by default (the
    same computation) but in :data:`OTHERWISE_COMPUTED`."""
    assert a.columns == b.columns
    worst = 0.0
    for column in a.columns:
        if column == "step_seconds":
            continue
        scale = max(np.abs(b[column]).max(), 1e-300)
        difference = np.abs(a[column] - b[column]).max() / scale
        assert difference <= max(tolerance, OTHERWISE_COMPUTED.get(column, 0.0)), (
            column,
            difference,
        )
        worst = max(worst, difference)
    return worst


@pytest.mark.parametrize("name", list(CASES))
def test_configuration_reproduces_demo(tmp_path, name):
    toml, replace, argv, run_folder = CASES[name]
    demo_out = str(tmp_path / "demo")
    run_demo(argv, demo_out)
    config = shortened(toml, replace, str(tmp_path))
    assert cli(["run", config, "--quiet", "--out", str(tmp_path / "toml")]) == 0
    demo = read_history(os.path.join(demo_out, run_folder, "history.csv"))
    configured = read_history(str(tmp_path / "toml" / "history.csv"))
    assert len(demo["t"]) >= 3
    assert not list(Path(demo_out).rglob("*.png"))  # --no-plot: no figure, no picture
    assert_same_columns(configured, demo)  # the same operations: bitwise, but OTHERWISE_COMPUTED
    # the runs are not trivial: something touched, or the bar left its wall
    touched = demo["contact_force"] if "contact_force" in demo else -demo["sigma_contact"]
    assert touched.max() > 0


@pytest.mark.mpi
@pytest.mark.parametrize("name", ["disk_2d", "two_disks_2d", "sliding_disks_2d"])
def test_configuration_reproduces_demo_in_parallel(mpi_tmp_path, name):
    """The same on every rank of mpirun -n 2 (the pair's partners on other ranks too)."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    toml, replace, argv, run_folder = CASES[name]
    run_demo(argv, os.path.join(mpi_tmp_path, "demo"))
    folder = os.path.join(mpi_tmp_path, "config")
    if comm.rank == 0:
        os.makedirs(folder)
        shortened(toml, replace, folder)
    comm.barrier()
    config = os.path.join(folder, toml)
    assert cli(["run", config, "--quiet", "--out", os.path.join(mpi_tmp_path, "toml")]) == 0
    comm.barrier()
    demo = read_history(os.path.join(mpi_tmp_path, "demo", run_folder, "history.csv"))
    # bitwise serially; on ranks the two builds of the mesh may be partitioned otherwise
    # (dolfinx 0.9), and MUMPS's factorisation on ranks varies by round-off from one run to
    # the next (its dynamic scheduling): round-off then, 1e-9 of each column's largest value
    tolerance = 0.0 if comm.size == 1 else 1e-9
    assert_same_columns(
        read_history(os.path.join(mpi_tmp_path, "toml", "history.csv")), demo, tolerance
    )


def test_every_demo_has_a_configuration():
    """Every demo but the convergence study (runs of bar_1d.toml with other nx and dt) and
    the bar's time loop written out (bar_1d.toml's run: tests/test_demos.py checks that its
    history is bar_1d.py's) has its TOML files here."""
    demos = {name[:-3] for name in os.listdir(DEMOS) if name.endswith(".py")}
    tomls = {os.path.splitext(case[0])[0] for case in CASES.values()}
    covered = {name for name in demos if any(toml.startswith(name) for toml in tomls)}
    assert demos - covered == {"convergence_1d", "bar_loop_1d"}
    shipped = {name for name in os.listdir(DEMOS) if name.endswith(".toml")}
    assert shipped == {case[0] for case in CASES.values()} | set(TOML_ONLY)


#: TOML files of their own (no demo): each with the replacements of a short run.
TOML_ONLY = {
    # the ball as coarse as its contact zone, to the middle of its contact
    "steel_ball_3d.toml": {
        "mesh_size = 0.002": "mesh_size = 0.004",
        "t_end = 6e-5": "t_end = 1e-5",
    },
}


@pytest.mark.parametrize("name", sorted(TOML_ONLY))
def test_a_configuration_of_its_own_runs(tmp_path, name, capsys):
    """The steel ball in SI units: the verlet scheme's stable step said at the start, the
    ball in contact at the end of the short run, E_Theta kept (the explicit scheme's energy
    between status changes, docs/method.md section 12: 1e-4 of it, measured 4e-6 on the
    full run)."""
    path = shortened(name, TOML_ONLY[name], str(tmp_path))
    with open(path) as f:
        text = f.read().replace('dir = "../out/steel_ball_3d"', f'dir = "{tmp_path / "out"}"')
    with open(path, "w") as f:
        f.write(text)
    assert cli(["run", path]) == 0
    history = read_history(str(tmp_path / "out" / "history.csv"))
    assert "stable dt = " in capsys.readouterr().out
    assert history["contact_force"][-1] > 0
    energy = history["energy_theta"]
    assert np.abs(energy - energy[0]).max() <= 1e-4 * energy[0]
