"""What the entry points show: --version, the same --quiet and --output-every on every demo,
one progress bar on a terminal and one line per step elsewhere."""

import io
import os
import re
import runpy
import sys

import pytest
from runs import REPO

import nitsche_dolfinx
from nitsche_dolfinx import HybridScheme
from nitsche_dolfinx.cases import bar_simulation
from nitsche_dolfinx.cli import main as cli
from nitsche_dolfinx.output import Progress

DEMOS = sorted(name for name in os.listdir(os.path.join(REPO, "demos")) if name.endswith(".py"))


class Terminal(io.StringIO):
    """A stream that says it is a terminal."""

    def isatty(self):
        return True


def run_script(name: str, *flags: str) -> int:
    """The demo ``name`` as a script in this process; its exit status."""
    folder = os.path.join(REPO, "demos")
    saved = sys.argv, list(sys.path)
    sys.argv = [os.path.join(folder, name), *flags]
    sys.path.insert(0, folder)
    try:
        runpy.run_path(sys.argv[0], run_name="__main__")
    except SystemExit as stop:
        return stop.code
    finally:
        sys.argv, sys.path[:] = saved
    return 0


def test_every_entry_point_has_version(capsys):
    import dolfinx

    versions = f"nitsche-dolfinx {nitsche_dolfinx.__version__} (dolfinx {dolfinx.__version__})"
    with pytest.raises(SystemExit) as stop:
        cli(["--version"])
    assert stop.value.code == 0 and capsys.readouterr().out.strip() == versions
    for demo in DEMOS:
        assert run_script(demo, "--version") == 0, demo
        assert capsys.readouterr().out.strip() == f"{demo}, {versions}", demo


def test_every_demo_has_quiet_and_output_every(capsys):
    for demo in DEMOS:
        assert run_script(demo, "--help") == 0
        text = capsys.readouterr().out
        for flag in ("--quiet", "--output-every", "--version"):
            assert flag in text, (demo, flag)


def test_progress_lines_when_not_a_terminal(capsys):
    """Without a terminal: one line per time level, t = 0 included, and none with --quiet."""
    simulation = bar_simulation(HybridScheme(), nx=10, dt=0.1, t_end=0.5)
    simulation.progress = True
    simulation.run()
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 6
    assert re.match(r"step +5 +t = +0\.5000 +newton = +\d +E = ", lines[-1])


def test_progress_bar_on_a_terminal(monkeypatch):
    """On a terminal (tqdm installed): one line, rewritten, ending at t = T with the step,
    the Newton iterations and the energy of the last level."""
    pytest.importorskip("tqdm")
    from mpi4py import MPI

    for name in ("NITSCHE_DOLFINX_PROGRESS", "OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK"):
        monkeypatch.delenv(name, raising=False)
    terminal = Terminal()
    progress = Progress(True, MPI.COMM_WORLD, 0.0, 0.5, stream=terminal)
    assert progress.bar
    for step in range(6):
        progress.record(step, 0.1 * step, {"newton_iterations": 2, "energy": 0.125})
    progress.write("a message")
    progress.close()
    text = terminal.getvalue()
    assert text.count("\n") == 2  # the message and the end of the bar
    last = text.split("\r")[-1]
    assert "100%" in last and "t = 0.5/0.5" in last
    assert "step 5, Newton 2, E = 1.250000e-01" in last
    assert "a message" in text


def test_quiet_progress_shows_nothing():
    from mpi4py import MPI

    terminal = Terminal()
    progress = Progress(False, MPI.COMM_WORLD, 0.0, 0.5, stream=terminal)
    progress.record(1, 0.1, {"newton_iterations": 2, "energy": 0.125, "contact_force": 0.0})
    progress.write("hidden")
    progress.close()
    assert terminal.getvalue() == ""


@pytest.mark.parametrize(
    "variable, value, bar",
    [
        ("OMPI_COMM_WORLD_SIZE", "1", False),  # mpirun fakes a terminal: lines
        ("NITSCHE_DOLFINX_PROGRESS", "lines", False),
        ("NITSCHE_DOLFINX_PROGRESS", "bar", True),
    ],
)
def test_progress_bar_or_lines(monkeypatch, variable, value, bar):
    if bar:
        pytest.importorskip("tqdm")
    from mpi4py import MPI

    for name in ("NITSCHE_DOLFINX_PROGRESS", "OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv(variable, value)
    progress = Progress(True, MPI.COMM_WORLD, 0.0, 1.0, stream=Terminal())
    assert progress.bar == bar
    progress.close()
