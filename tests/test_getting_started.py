"""Every code block of docs/getting-started.md and of the README runs in the suite, as
written: a python block is executed, a shell block's commands are run (``python`` and
``nitsche-dolfinx`` by this interpreter, in a fresh folder that sees the repository's
demos and meshes), and a block that cannot run here (installs, ``make demo``) says so in
a ``<!-- not-run: why -->`` comment right before it; the ``make`` targets it names exist.
The README's python blocks are those that tests/test_readme.py runs, serially and under
mpirun."""

import os
import re
import shlex
import subprocess
import sys

import pytest
from runs import MPIRUN, environment

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PAGES = ["docs/getting-started.md", "README.md"]
#: A fenced block and the HTML comment right before it, if any.
BLOCK = re.compile(r"(?:<!--[ \t]*([^\n]*?)[ \t]*-->[ \t]*\n)?^```(\w*)\n(.*?)^```", re.S | re.M)
#: The commands a shell block may hold to be run here: the interpreter, the command of
#: the package and either under ``mpirun -n 2``.
RUNNABLE = re.compile(r"^(mpirun -n 2 )?(python|nitsche-dolfinx)( |$)")


def blocks(page: str) -> list[tuple[str | None, str, str]]:
    """(comment before it, language, text) of every fenced block of ``page``."""
    with open(os.path.join(REPO, page)) as f:
        return BLOCK.findall(f.read())


def commands(text: str) -> list[str]:
    """The command lines of a shell block, comments dropped."""
    lines = (line.split("  #")[0].strip() for line in text.splitlines())
    return [line for line in lines if line and not line.startswith("#")]


def make_targets() -> set[str]:
    with open(os.path.join(REPO, "Makefile")) as f:
        return set(re.findall(r"^([\w-]+):", f.read(), re.M))


def classify(page: str) -> dict[str, list]:
    """The blocks of ``page`` by what the suite does with them; "unmarked" must be empty."""
    kinds = {"python": [], "shell": [], "not-run": [], "unmarked": []}
    for comment, language, text in blocks(page):
        if comment.startswith("not-run:") and comment[len("not-run:") :].strip():
            kinds["not-run"].append(text)
        elif language == "python":
            kinds["python"].append((comment, text))
        elif language in ("sh", "bash", "console") and all(
            RUNNABLE.match(c) for c in commands(text)
        ):
            kinds["shell"].append(text)
        else:
            kinds["unmarked"].append(text)
    return kinds


@pytest.mark.parametrize("page", PAGES)
def test_every_block_runs_or_says_why_not(page):
    """A block the suite cannot run has a reason; its ``make`` targets exist."""
    kinds = classify(page)
    assert not kinds["unmarked"], f"{page}: blocks neither run nor marked not-run: {kinds}"
    targets = make_targets()
    for text in kinds["not-run"]:
        for line in commands(text):
            if line.startswith("make "):
                assert set(line.split()[1:]) <= targets, f"{page}: no such make target: {line}"
    if page == PAGES[0]:
        assert len(kinds["python"]) >= 1 and len(kinds["shell"]) >= 3, kinds


def test_readme_python_blocks_are_run_by_test_readme():
    """Each python block of the README carries a marker that tests/test_readme.py runs."""
    with open(os.path.join(REPO, "tests", "test_readme.py")) as f:
        source = f.read()
    run = {"readme-example"} | set(re.findall(r'readme_example\("([\w-]+)"\)', source))
    markers = [comment for comment, _ in classify("README.md")["python"]]
    assert markers and set(markers) <= run, (markers, run)


def fresh_folder(tmp_path) -> str:
    """A folder where the repository's demos/ and meshes/ are reachable, as in a clone."""
    for name in ("demos", "meshes"):
        os.symlink(os.path.join(REPO, name), tmp_path / name)
    return str(tmp_path)


@pytest.mark.slow
def test_getting_started_python_blocks_run(tmp_path, monkeypatch, capsys):
    """The first example, in a fresh folder: the disk lands at t = 10.1 and bounces off."""
    monkeypatch.chdir(fresh_folder(tmp_path))
    for _, text in classify("docs/getting-started.md")["python"]:
        namespace = {}
        exec(compile(text, "docs/getting-started.md", "exec"), namespace)
    first, last = namespace["history"].contact_interval()
    assert abs(first - 10.1) < 1e-9 and last < 30.0  # landed, and off again before T
    assert list(namespace["rows"]["energy"]) == list(namespace["history"]["energy"])
    assert os.path.getsize(tmp_path / "out" / "first_disk" / "energy.png") > 0
    assert "largest contact force" in capsys.readouterr().out


def shell_commands() -> list[str]:
    found = []
    for text in classify("docs/getting-started.md")["shell"]:
        found += commands(text)
    return found


@pytest.mark.slow
@pytest.mark.parametrize("line", shell_commands())
def test_getting_started_shell_commands_run(line, tmp_path):
    """Each command as written, ``python`` and ``nitsche-dolfinx`` being this interpreter
    (the command as ``python -m nitsche_dolfinx``); what it writes under ``--out``."""
    words = shlex.split(line)
    prefix = []
    if words[0] == "mpirun":
        if MPIRUN is None:
            pytest.skip("no mpirun")
        prefix, words = [MPIRUN, *words[1:3]], words[3:]
    program = [sys.executable] + (
        ["-m", "nitsche_dolfinx"] if words[0] == "nitsche-dolfinx" else []
    )
    result = subprocess.run(
        [*prefix, *program, *words[1:]],
        cwd=fresh_folder(tmp_path),
        env=environment(),
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    if "--out" in words:
        out = tmp_path / words[words.index("--out") + 1]
        assert (out / "history.csv").stat().st_size > 0
        assert (out / "solution.xdmf").exists()
