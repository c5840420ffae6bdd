"""The demos run as users run them: as scripts, with the flags and outputs of docs/method.md
section 6."""

import contextlib
import io
import os
import re
import runpy
import subprocess
import sys
from typing import NamedTuple

import numpy as np
import pytest
from runs import MPIRUN, assert_same_history, assert_xdmf_readable, run

from nitsche_dolfinx import read_history
from nitsche_dolfinx.cases import BAR_COLUMNS
from nitsche_dolfinx.output import HISTORY_COLUMNS, body_columns, read_solution
from nitsche_dolfinx.post.pictures import _colour_scale

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEMOS = sorted(name for name in os.listdir(os.path.join(REPO, "demos")) if name.endswith(".py"))
#: The flags every demo takes (docs/method.md section 6): the common ones, then the scheme
#: and Nitsche flags.
COMMON_FLAGS = ("--out", "--quiet", "--no-plot", "--output-every", "--version")
METHOD_FLAGS = ("--scheme", "--theta", "--beta", "--gamma", "--nitsche-theta", "--gamma0")


def run_demo(name, *args):
    env = {**os.environ, "PYTHONPATH": REPO + os.pathsep + os.environ.get("PYTHONPATH", "")}
    return subprocess.run(
        [sys.executable, os.path.join(REPO, "demos", name), *args],
        capture_output=True,
        text=True,
        env=env,
        timeout=600,
    )


def run_here(name: str, *args) -> tuple[int, str, str]:
    """``demos/<name> args`` run as a script in this process (without the start-up of a
    Python of its own): its exit status, standard output and standard error."""
    folder = os.path.join(REPO, "demos")
    saved = sys.argv, list(sys.path)
    sys.argv = [os.path.join(folder, name), *args]
    sys.path.insert(0, folder)  # disk_2d.py and two_disks_2d.py import their 3D demo
    out, err = io.StringIO(), io.StringIO()
    status = 0
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            runpy.run_path(sys.argv[0], run_name="__main__")
    except SystemExit as stop:
        status = stop.code or 0
    finally:
        sys.argv, sys.path[:] = saved
    return status, out.getvalue(), err.getvalue()


def demo_help(name: str) -> str:
    """What ``demos/<name> --help`` prints, the demo run as a script in this process."""
    status, out, _ = run_here(name, "--help")
    assert status == 0, name
    return out


@pytest.mark.parametrize("name", DEMOS)
def test_every_demo_takes_the_common_flags(name):
    """--out, --quiet, --no-plot, --output-every, --version, and the scheme and Nitsche
    flags, in every demo's --help."""
    shown = set(re.findall(r"--[a-z0-9-]+", demo_help(name)))
    missing = [flag for flag in (*COMMON_FLAGS, *METHOD_FLAGS) if flag not in shown]
    assert not missing, (name, missing)


def loop_and_run(tmp_path, ranks: int) -> tuple:
    """``demos/bar_loop_1d.py`` with its loop and with ``--run`` (Simulation.run), the talk's
    bar to T = 3 (an impact and a release), fields every 20 steps: the two output folders."""
    outs = (tmp_path / "loop", tmp_path / "run")
    flags = ["--t-end", "3", "--output-every", "20", "--no-plot", "--quiet"]
    for out, extra in zip(outs, ([], ["--run"])):
        result = run("demos/bar_loop_1d.py", *flags, *extra, "--out", str(out), ranks=ranks)
        assert result.returncode == 0, result.stderr
    return outs


def assert_same_files(a, b) -> None:
    """history.csv equal byte for byte; solution.xdmf's levels and every HDF5 dataset equal."""
    assert (a / "history.csv").read_bytes() == (b / "history.csv").read_bytes()
    times = assert_xdmf_readable(str(a / "solution.xdmf"), 3.0)
    assert times == assert_xdmf_readable(str(b / "solution.xdmf"), 3.0)
    assert times == pytest.approx(np.arange(0.0, 3.0 + 1e-9, 0.3))
    h5py = pytest.importorskip("h5py")

    def datasets(path) -> dict:
        found = {}

        def keep(name, item):
            if isinstance(item, h5py.Dataset):
                found[name] = item[()]

        with h5py.File(path, "r") as h5:
            h5.visititems(keep)
        return found

    first, second = datasets(a / "solution.h5"), datasets(b / "solution.h5")
    assert first and list(first) == list(second)
    for name, values in first.items():  # the same operations in the same order: bitwise
        assert np.array_equal(values, second[name]), name


def test_loop_demo_is_simulation_run(tmp_path):
    """The time loop written out (step, state, HistoryWriter, SolutionWriter) writes what
    Simulation.run writes, to the bit: the same computation in the same order. And it is
    the run of demos/bar_1d.py."""
    loop, shortcut = loop_and_run(tmp_path, ranks=1)
    assert_same_files(loop, shortcut)
    history = read_history(str(loop / "history.csv"))
    assert len(history["t"]) == 201 and np.all(history["sigma_contact"] <= 0)
    bar = tmp_path / "bar"
    flags = ["--t-end", "3", "--output-every", "0", "--no-compare", "--no-plot", "--quiet"]
    result = run_demo("bar_1d.py", *flags, "--out", str(bar))
    assert result.returncode == 0, result.stderr
    assert (bar / "history.csv").read_bytes() == (loop / "history.csv").read_bytes()


@pytest.mark.skipif(MPIRUN is None, reason="needs mpirun")
def test_loop_demo_is_simulation_run_on_two_ranks(tmp_path):
    """The same on two ranks: every rank steps, the writers gather."""
    assert_same_files(*loop_and_run(tmp_path, ranks=2))


def test_bar_demo_writes_history_and_figure(tmp_path):
    out = tmp_path / "bar"
    result = run_demo("bar_1d.py", "--t-end", "1.5", "--out", str(out))
    assert result.returncode == 0, result.stderr
    with open(out / "history.csv") as f:
        assert f.readline().strip() == ",".join(BAR_COLUMNS)
    history = read_history(out / "history.csv")
    assert len(history["t"]) == 101 and history["t"][0] == 0.0
    assert np.all(history["sigma_contact"] <= 0)
    assert (out / "cn" / "history.csv").exists()
    pytest.importorskip("matplotlib")
    assert (out / "bar_1d.png").stat().st_size > 10_000


@pytest.mark.parametrize(
    "flags, named",
    [
        (["--dt", "-1"], "--dt -1"),
        (["--gamma0", "0"], "--gamma0 0"),
        (["--scheme", "theta", "--theta", "2"], "--theta 2"),
        (["--scheme", "leapfrog"], "leapfrog"),
    ],
)
def test_bar_demo_bad_flags(tmp_path, flags, named):
    result = run_demo("bar_1d.py", *flags, "--out", str(tmp_path / "bad"))
    assert result.returncode != 0
    assert named in result.stderr
    assert "Traceback" not in result.stderr + result.stdout


def test_two_bars_demo_contract(tmp_path):
    """docs/method.md section 6: the columns, the momentum kept, the velocities exchanged; the
    energy figure and the picture of the bars in space and time."""
    out = tmp_path / "bars"
    result = run_demo(
        "two_bars_1d.py", "--nx", "20", "--dt", "0.075", "--t-end", "3", "--quiet",
        "--out", str(out),
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    with open(out / "history.csv") as f:
        header = f.readline().strip().split(",")
    assert header[:8] == [
        "t", "energy", "energy_theta", "contact_force", "momentum", "v_left", "v_right",
        "newton_iterations",
    ]  # fmt: skip
    history = np.loadtxt(out / "history.csv", delimiter=",", skiprows=1)
    assert np.abs(history[:, 4]).max() < 1e-8
    assert history[-1, 6] > 0.45 and history[-1, 5] < -0.45  # exchanged
    assert "exit velocities" in result.stdout
    pytest.importorskip("matplotlib")
    for figure in ("energy.png", "worldlines.png", "two_bars_1d.png"):
        assert (out / figure).stat().st_size > 10_000, figure


def difference_from_plane(stdout: str) -> float:
    """The relative difference of the pair's contact force from one disk's on the plane of
    symmetry, as the two-disks demo prints it."""
    line = next(row for row in stdout.splitlines() if "against one disk" in row)
    return float(line.split("differs by ")[1].split()[0])


def test_two_disks_demo_contract(tmp_path):
    """docs/method.md section 6: the columns of section 6 then the momentum; the symmetric check
    against one disk on the plane; both bodies in solution.xdmf."""
    out = tmp_path / "disks"
    result = run_demo(
        "two_disks_2d.py", "--t-end", "2", "--output-every", "10", "--no-plot", "--quiet",
        "--out", str(out),
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    with open(out / "history.csv") as f:
        header = f.readline().strip().split(",")
    assert header[:13] == [
        "t", "energy", "energy_theta", "kinetic", "elastic", "potential", "contact_force",
        "contact_area", "penetration_max", "newton_iterations", "step_seconds",
        "momentum_x", "momentum_y",
    ]  # fmt: skip
    # then the angular momenta and each disk's columns (docs/method.md section 6)
    assert header[13:] == [
        "angular_momentum_z", "angular_momentum_reference_z",
        *body_columns(1, 2), *body_columns(2, 2),
    ]  # fmt: skip
    assert "580 DOFs" in result.stdout
    # two computations of the same steps, each to Newton's tolerance: 1e-8 of the force, as
    # in tests/test_two_bodies.py (measured: 2e-12)
    assert difference_from_plane(result.stdout) < 1e-8
    times = assert_xdmf_readable(str(out / "solution.xdmf"), 2.0)
    assert times[-1] == pytest.approx(2.0)


def test_two_disks_demo_hyperelastic(tmp_path):
    """`--law neo_hookean` reaches the pair: its finite-strain terms along the axis are one
    neo-Hookean disk on the plane of symmetry with gamma0 / 2 (docs/method.md section 15),
    and E_Theta does not rise."""
    out = tmp_path / "disks"
    result = run_demo(
        "two_disks_2d.py", "--law", "neo_hookean", "--t-end", "3", "--no-plot", "--quiet",
        "--out", str(out),
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    # as in test_two_disks_demo_contract: two computations to Newton's tolerance (measured
    # 1e-14)
    assert difference_from_plane(result.stdout) < 1e-8
    history = read_history(str(out / "history.csv"))
    assert history["contact_force"].max() > 0
    energy = history["energy_theta"]
    # the hybrid step's E_Theta rises at most by Newton's tolerance, 1e-10 of the equation's
    # scale (docs/method.md section 15; measured 3.6e-11)
    assert np.diff(energy).max() < 1e-9 * energy[0]


@pytest.mark.skipif(MPIRUN is None, reason="needs mpirun")
def test_two_disks_demo_under_mpirun_matches_serial(tmp_path):
    """The demo on two ranks, one disk on each (the pairs' partners all on the other
    rank): its history is the serial one to 1e-8, its fields readable."""
    outs = [tmp_path / "serial", tmp_path / "two_ranks"]
    for out, ranks in zip(outs, (1, 2)):
        flags = ["--t-end", "3", "--output-every", "10", "--no-compare", "--no-plot", "--quiet"]
        result = run("demos/two_disks_2d.py", *flags, "--out", str(out), ranks=ranks)
        assert result.returncode == 0, result.stderr
    serial, parallel = (read_history(str(out / "history.csv")) for out in outs)
    assert serial["contact_force"].max() > 0
    # columns zero by symmetry, compared on their physical size: the momenta on one disk's,
    # rho |disk| v0; the angular momenta on its moment about the origin, rho |disk| v0 R; the
    # centres of mass on the radius R
    sizes = {"momentum": np.pi * 20.0**2, "angular_momentum": np.pi * 20.0**3}
    sizes["centre_of_mass"] = 20.0
    scales = {
        name: size
        for name in serial.columns
        for quantity, size in sizes.items()
        if name.startswith(quantity)
    }
    for name, scale in scales.items():
        assert np.abs(parallel[name] - serial[name]).max() < 1e-8 * scale, name
    others = [name for name in serial.columns if name not in scales]
    assert_same_history(*({n: h[n] for n in others} for h in (parallel, serial)), 1e-8)
    assert assert_xdmf_readable(str(outs[1] / "solution.xdmf"), 3.0)[-1] == pytest.approx(3.0)


def test_sliding_disks_demo_contract(tmp_path):
    """docs/method.md section 11: two disks hitting off-centre, paired again by closest
    points as they slide (coarse and with long steps: in contact from t = 5.75). The
    columns: the total momentum and angular momenta, pairing_energy, each disk's; the
    total momentum zero to round-off; E_Theta - pairing_energy never rising; the pairings
    made again; the unbiased pair's gap and contact pressure on both surfaces; the energy
    figure."""
    out = tmp_path / "sliding"
    result = run_demo(
        "sliding_disks_2d.py", "--mesh-size", "8", "--dt", "0.25", "--t-end", "8",
        "--output-every", "16", "--quiet", "--out", str(out),
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    with open(out / "history.csv") as f:
        header = f.readline().strip().split(",")
    assert header == [
        *HISTORY_COLUMNS[:11], "momentum_x", "momentum_y", "angular_momentum_z",
        "angular_momentum_reference_z", "pairing_energy", *body_columns(1, 2),
        *body_columns(2, 2),
    ]  # fmt: skip
    assert "580 DOFs" in result.stdout
    history = read_history(str(out / "history.csv"))
    assert history["contact_force"].max() > 0
    one_disk = np.pi * 20.0**2 * np.hypot(2.0, 0.3)  # rho |disk| |v|
    # zero by symmetry up to the solves' round-off, processor-dependent: 1e-9 of one disk's
    for component in ("momentum_x", "momentum_y"):
        assert np.abs(history[component]).max() < 1e-9 * one_disk, component
    # as in tests/test_sliding.py: a step's rise is the solver's tolerance and round-off
    # (measured 5.5e-15 E_Theta(0)), so 1e-9 of E_Theta(0) on any processor; the pairings'
    # change is of order 1e-3 E_Theta(0)
    energy, pairing = history["energy_theta"], history["pairing_energy"]
    assert np.diff(energy - pairing).max() < 1e-9 * energy[0]
    assert 0 < abs(pairing[-1]) < 1e-2 * energy[0]
    pairings = int(re.search(r"(\d+) pairings", result.stdout).group(1))
    assert pairings > 10  # measured: 25
    times = assert_xdmf_readable(str(out / "solution.xdmf"), 8.0)
    assert times == pytest.approx([0.0, 4.0, 8.0])
    pytest.importorskip("h5py")
    last = read_solution(str(out / "solution.xdmf"))[-1]  # in contact
    upper = last.points[:, 1] > 0  # the reference positions: the upper disk above y = 0
    for name in ("contact_pressure", "gap"):
        values = last.fields[name].ravel()
        # each surface is a slave (unbiased): pressed and penetrated on both
        assert (values[upper] < -1e-9).any() and (values[~upper] < -1e-9).any(), name
    pytest.importorskip("matplotlib")
    assert (out / "energy.png").stat().st_size > 10_000


#: Demos given their pictures for the site's gallery (scripts/gallery.py), the flags of a
#: short run that reaches the time of the picture, and the pictures it draws.
PICTURE_RUNS = {
    "block_on_slab_2d.py": (("--t-end", "0.1"), ("energy.png", "deformed.png")),
    "c_shape_2d.py": (
        ("--mesh-size", "0.2", "--t-end", "0.46"),
        ("energy.png", "deformed_t0.46.png"),
    ),
    "ring_2d.py": (("--t-end", "0.3"), ("ring_2d.png", "deformed_t0.3.png")),
    "soft_ring_2d.py": (("--t-end", "1.4"), ("energy.png", "deformed_t1.4.png")),
}


@pytest.mark.parametrize("name", sorted(PICTURE_RUNS))
def test_demo_draws_its_pictures(tmp_path, name):
    """Unless --no-plot, the demo draws its energy figure and the deformed body."""
    pytest.importorskip("matplotlib")
    pytest.importorskip("pyvista")
    flags, pictures = PICTURE_RUNS[name]
    out = tmp_path / "out"
    result = run_demo(name, *flags, "--output-every", "0", "--quiet", "--out", str(out))
    assert result.returncode == 0, result.stderr
    for picture in pictures:
        assert (out / picture).stat().st_size > 10_000, picture


@pytest.mark.parametrize("largest", [0.5, 5.0, 8.36, 9.99, 10.0, 84.0, 5.2e8])
def test_colour_scale_of_the_pictures(largest):
    """The von Mises scale of the pictures: a round top above the largest value, in at most
    8 steps of 1, 2 or 5 times a power of ten (a largest value of 8.36, the sliding disks
    on 2 ranks, found no step before)."""
    top, step = _colour_scale(largest)
    assert largest <= top <= largest + step and top / step <= 8
    mantissa = step / 10.0 ** np.floor(np.log10(step))
    assert min(abs(mantissa - m) for m in (1.0, 2.0, 5.0)) < 1e-9


#: The user's-data demos (issue 30): the flags of a short run, the times of the restart,
#: and a column that must show that the run is not trivial.
USER_DATA_DEMOS = {
    "indenter_2d.py": (["--nx", "16"], ("2e-5", "3e-5"), "obstacle_work"),
    "shaker_2d.py": (["--nx", "8"], ("6e-5", "1e-4"), "damping_dissipation"),
}


@pytest.mark.skipif(MPIRUN is None, reason="needs mpirun")
@pytest.mark.parametrize("demo", sorted(USER_DATA_DEMOS))
def test_user_data_demo_on_two_ranks_restarts_and_opens(tmp_path, demo):
    """The moving-obstacle demo and the two-material damped one (issue 30's acceptance): on
    2 ranks the history is the serial one to 1e-9 of each column's largest value (the same
    equations, partitioned: sums in another order, each Newton solve to its tolerance:
    measured 1.8e-13); a run stopped halfway and restarted on 2 ranks gives the
    uninterrupted 2-rank history (1e-9 too: MUMPS on 2 ranks varies by round-off from one
    run to the next, see tests/test_checkpoints.py), the work and reaction columns included;
    the fields, material_id among them for the shaker, are readable."""
    flags, (middle, end), telling = USER_DATA_DEMOS[demo]
    flags = [*flags, "--output-every", "10", "--no-plot", "--quiet"]
    outs = {name: tmp_path / name for name in ("serial", "two_ranks", "restarted")}
    for name, ranks in (("serial", 1), ("two_ranks", 2)):
        result = run(f"demos/{demo}", *flags, "--t-end", end, "--out", str(outs[name]),
                     ranks=ranks)  # fmt: skip
        assert result.returncode == 0, result.stderr
    first = run(f"demos/{demo}", *flags, "--t-end", middle, "--checkpoint-every", "10",
                "--out", str(outs["restarted"]), ranks=2)  # fmt: skip
    assert first.returncode == 0, first.stderr
    again = run(f"demos/{demo}", *flags, "--t-end", end, "--restart",
                "--out", str(outs["restarted"]), ranks=2)  # fmt: skip
    assert again.returncode == 0, again.stderr
    histories = [read_history(str(out / "history.csv")) for out in outs.values()]
    serial = histories[0]
    assert serial["contact_force"].max() > 0 and serial[telling][-1] > 0
    # the energy balance is zero to Newton's tolerance: compared to the work, not to itself.
    # Each step leaves a residual of snes_rtol = 1e-10 of its scale (the table's forces,
    # 1e6 N/m) on increments of 1e-7 m, over 50 steps: 1e-8 of a work of 1.4 J/m
    # (measured: 1.5e-10 for the shaker on 8 x 4 cells, 1e-14 for the indenter)
    for history in histories:
        assert np.abs(history["energy_balance"]).max() < 1e-8 * np.abs(history["work"]).max()
    serial, parallel, restarted = (
        {name: h[name] for name in h.columns if name != "energy_balance"} for h in histories
    )
    assert_same_history(parallel, serial, 1e-9)
    assert_same_history(restarted, parallel, 1e-9)
    times = assert_xdmf_readable(str(outs["restarted"] / "solution.xdmf"), float(end))
    assert times[-1] == pytest.approx(float(end))


def test_ball_on_slab_demo_runs_both_contacts(tmp_path):
    """A disk (--dim 2) thrown on a plate resting on the ground: the pair and the obstacle
    in one run, E_Theta never rising."""
    out = tmp_path / "slab"
    result = run_demo(
        "ball_on_slab_3d.py", "--dim", "2", "--t-end", "3", "--no-plot", "--quiet",
        "--out", str(out),
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    history = read_history(str(out / "history.csv"))
    assert history.columns[-2:] == ["momentum_x", "momentum_y"]
    # a step's rise is <F, u^{n+1} - u^n> <= snes_rtol S |du| (at most 7.4e-9 here, measured)
    # plus twice the round-off of E_Theta (6.3e-11): 7.5e-9 = 1.2e-11 E_Theta; both vary
    # with the processor: 1e-9 of E_Theta
    assert np.diff(history["energy_theta"]).max() < 1e-9 * history["energy_theta"].max()
    assert history["contact_force"][-1] > 0


class VerletRun(NamedTuple):
    """A demo with ``--scheme verlet``, short: its flags, the history of its run (in OUT)
    with the columns docs/method.md section 6 gives it, and the histories of its compared
    runs (in OUT), which take the same step."""

    flags: tuple
    history: str
    columns: tuple
    compared: tuple = ()


#: The listed columns of the impact demos' history.csv (docs/method.md section 6).
IMPACT_COLUMNS = HISTORY_COLUMNS[:11]
#: Those of the two bars (docs/method.md section 6, two bodies).
TWO_BARS_COLUMNS = (
    "t", "energy", "energy_theta", "contact_force", "momentum", "v_left", "v_right",
    "newton_iterations",
)  # fmt: skip
BAR = ("--nx", "10", "--t-end", "0.02")  # 283 steps
#: The same with --scheme verlet, whose gamma0 is then 0.5 (dt 0.05 on 10 cells): 6 steps
VERLET_BAR = ("--nx", "10", "--t-end", "0.3")
SCHEMES = ("hybrid", "cn", "theta", "newmark")  # compared with the ball and the disk
VERLET_RUNS = {
    "bar_1d.py": VerletRun(VERLET_BAR, "history.csv", BAR_COLUMNS, ("cn",)),
    "bar_loop_1d.py": VerletRun(VERLET_BAR, "history.csv", BAR_COLUMNS),
    "bar_loop_1d.py --run": VerletRun((*VERLET_BAR, "--run"), "history.csv", BAR_COLUMNS),
    "compare_methods_1d.py": VerletRun(
        VERLET_BAR,
        "history.csv",  # a copy of nitsche_verlet's
        BAR_COLUMNS,
        ("nitsche_verlet", "mixed_cn", "nitsche_cn", "modified_mass"),
    ),
    "convergence_1d.py": VerletRun(
        ("--levels", "5", "10", "--t-end", "0.5"),
        "history.csv",  # a copy of the finest level of the first method's
        IMPACT_COLUMNS,
        ("hybrid/N10", "cn/N10", "mixed/N10", "modified_mass/N10"),
    ),
    "two_bars_1d.py": VerletRun(VERLET_BAR, "history.csv", TWO_BARS_COLUMNS),
    "ring_2d.py": VerletRun(("--t-end", "0.001"), "history.csv", IMPACT_COLUMNS),
    "disk_2d.py": VerletRun(
        ("--mesh-size", "16", "--t-end", "0.5"), "history.csv", IMPACT_COLUMNS, SCHEMES
    ),
    "ball_3d.py": VerletRun(
        ("--mesh-size", "20", "--t-end", "0.3"), "history.csv", IMPACT_COLUMNS, SCHEMES
    ),
    "two_disks_2d.py": VerletRun(
        ("--mesh-size", "16", "--t-end", "0.3"),
        "history.csv",
        (*IMPACT_COLUMNS, "momentum_x", "momentum_y"),
        ("plane",),
    ),
    "two_balls_3d.py": VerletRun(
        ("--mesh-size", "20", "--t-end", "0.2"),
        "history.csv",
        (*IMPACT_COLUMNS, "momentum_x", "momentum_y", "momentum_z"),
        ("plane",),
    ),
    "sliding_disks_2d.py": VerletRun(
        ("--mesh-size", "16", "--t-end", "0.3"),
        "history.csv",
        (*IMPACT_COLUMNS, "momentum_x", "momentum_y"),
    ),
    "indenter_2d.py": VerletRun(
        ("--nx", "16", "--t-end", "2e-6"),
        "history.csv",
        (*IMPACT_COLUMNS, "contact_force_1", "contact_area_1", "contact_force_2"),
    ),
    "shaker_2d.py": VerletRun(
        ("--nx", "8", "--t-end", "4e-6"),
        "history.csv",
        (*IMPACT_COLUMNS, "reaction_1_x", "reaction_1_y", "damping_dissipation"),
    ),
    "c_shape_2d.py": VerletRun(
        ("--mesh-size", "0.2", "--t-end", "0.02"), "history.csv", IMPACT_COLUMNS
    ),
    "ball_on_slab_3d.py": VerletRun(
        ("--dim", "2", "--t-end", "0.1"),
        "history.csv",
        (*IMPACT_COLUMNS, "momentum_x", "momentum_y"),
    ),
}
#: The demos that refuse --scheme verlet, with the flags of a short run.
VERLET_REFUSED = {
    "friction_block_2d.py": ("--nx", "2", "--t-end", "0.1"),  # the verlet scheme is frictionless
    "block_on_slab_2d.py": ("--t-end", "0.1"),  # likewise
    "compare_methods_1d.py --penalty": (*VERLET_BAR, "--penalty"),  # and Nitsche's method
    # and linear elasticity: a hyperelastic body (their default law) steps implicitly
    "rubber_ball_3d.py": ("--mesh-size", "0.6", "--t-end", "0.1"),
    "soft_ring_2d.py": ("--t-end", "0.1"),
}


def test_every_demo_is_tried_with_verlet():
    """Every demo runs with --scheme verlet or refuses it."""
    tried = {name.split()[0] for name in (*VERLET_RUNS, *VERLET_REFUSED)}
    assert tried == set(DEMOS)


@pytest.mark.parametrize("case", sorted(VERLET_RUNS))
def test_demo_runs_verlet(tmp_path, case):
    """docs/method.md section 12: with --scheme verlet, --dt is the stable step the package
    estimates, printed at the start; the history keeps its columns, with no Newton
    iterations; the compared runs take the same step."""
    run = VERLET_RUNS[case]
    status, out, err = run_here(
        case.split()[0], "--scheme", "verlet", *run.flags, "--no-plot", "--out", str(tmp_path)
    )
    assert status == 0, err
    stable = float(re.search(r"stable dt = (\S+)", out).group(1))
    history = read_history(str(tmp_path / run.history))
    assert history.columns[: len(run.columns)] == list(run.columns)
    assert np.all(history["newton_iterations"] == 0)
    assert 0 < history["t"][1] <= stable
    for folder in run.compared:
        compared = read_history(str(tmp_path / folder / "history.csv"))
        assert np.array_equal(compared["t"], history["t"]), folder


@pytest.mark.parametrize("case", sorted(VERLET_REFUSED))
def test_demo_refuses_verlet_in_one_line(tmp_path, case):
    flags = VERLET_REFUSED[case]
    status, out, err = run_here(
        case.split()[0], "--scheme", "verlet", *flags, "--out", str(tmp_path)
    )
    assert status == 2, err
    assert len(err.splitlines()) == 1 and "the verlet scheme" in err, err
    assert "Traceback" not in out + err
