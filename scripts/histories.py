"""Run the demos whose histories a refactoring must keep, and compare two such sets of runs.

    python scripts/histories.py run OUT [--repo CHECKOUT] [--ranks 1 2] [--cases bar disk ...]
    python scripts/histories.py compare OLD NEW [--rtol 1e-10]

``run`` writes ``OUT/<case>-np<ranks>/history.csv`` for each case, with the demos of
``CHECKOUT`` (default: this one) and its package first on the path, so that a checkout of
an older commit (``git worktree add``) gives the histories from before a change.
``compare`` reads every ``history.csv`` under OLD and the same file under NEW: for each column, the
largest difference
must be at most ``rtol`` times that column's largest absolute value in OLD (the wall
times ``step_seconds`` are left out); it prints one line per history, the worst column
first, and for a column beyond ``rtol`` its absolute difference and largest value (a
column that is physically zero, such as the total momentum of two bodies thrown at each
other, is round-off in both: judge it against the scale of the physics), and exits with
status 1 if any differs more or is missing.
"""

from __future__ import annotations

import argparse
import csv
import os
import subprocess
import sys
import time

import numpy as np

#: case -> (demo script, its flags): every demo at its defaults, the main run only where it
#: compares others, no figure, no field output.
CASES = {
    "bar": ("bar_1d.py", ["--no-compare", "--no-plot"]),
    "bar_loop": ("bar_loop_1d.py", ["--no-plot"]),
    "compare_methods": ("compare_methods_1d.py", ["--no-plot"]),
    "convergence": ("convergence_1d.py", ["--no-plot"]),
    "disk": ("disk_2d.py", ["--no-compare", "--no-plot"]),
    "ball": ("ball_3d.py", ["--no-compare", "--no-plot"]),
    "ring": ("ring_2d.py", ["--no-plot"]),
    "soft_ring": ("soft_ring_2d.py", ["--no-plot"]),
    "two_bars": ("two_bars_1d.py", ["--no-plot"]),
    "two_disks": ("two_disks_2d.py", ["--no-compare", "--no-plot"]),
    "two_balls": ("two_balls_3d.py", ["--no-compare", "--no-plot"]),
    "sliding_disks": ("sliding_disks_2d.py", ["--no-plot"]),
    "ball_on_slab": ("ball_on_slab_3d.py", ["--no-plot"]),
    "block_on_slab": ("block_on_slab_2d.py", ["--no-plot"]),
    "friction_block": ("friction_block_2d.py", ["--no-plot"]),
    "c_shape": ("c_shape_2d.py", ["--no-plot"]),
    "indenter": ("indenter_2d.py", ["--no-plot"]),
    "shaker": ("shaker_2d.py", ["--no-plot"]),
    "rubber_ball": ("rubber_ball_3d.py", ["--no-plot"]),
}
COMMON = ["--quiet", "--output-every", "0"]
IGNORED = ("step_seconds",)


def run(out: str, repo: str, ranks: list[int], cases: list[str]) -> int:
    python = sys.executable
    env = {**os.environ, "PYTHONPATH": repo, "OMPI_ALLOW_RUN_AS_ROOT": "1",
           "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1", "OPENBLAS_NUM_THREADS": "1"}  # fmt: skip
    status = 0
    for case in cases:
        script, flags = CASES[case]
        for n in ranks:
            folder = os.path.join(out, f"{case}-np{n}")
            command = [python, os.path.join(repo, "demos", script), *flags, *COMMON]
            command += ["--out", folder]
            if n > 1:
                command = ["mpirun", "-n", str(n), *command]
            start = time.perf_counter()
            result = subprocess.run(command, env=env, capture_output=True, text=True)
            seconds = time.perf_counter() - start
            print(f"{case}-np{n}: exit {result.returncode}, {seconds:.1f} s", flush=True)
            if result.returncode:
                print(result.stderr[-2000:], file=sys.stderr)
                status = 1
    return status


def read(path: str) -> dict[str, np.ndarray]:
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    data = np.array([[float(x) for x in row] for row in rows[1:] if row], dtype=float)
    return {name: data[:, i] for i, name in enumerate(rows[0])}


def histories(folder: str) -> list[str]:
    """Every ``history.csv`` under ``folder`` (a demo that compares runs writes one each)."""
    found = []
    for root, _, files in os.walk(folder):
        if "history.csv" in files:
            found.append(os.path.relpath(os.path.join(root, "history.csv"), folder))
    return sorted(found)


def compare(old: str, new: str, rtol: float) -> int:
    status = 0
    for name in histories(old):
        path, other = os.path.join(old, name), os.path.join(new, name)
        if not os.path.isfile(other):
            print(f"{name}: MISSING in {new}")
            status = 1
            continue
        a, b = read(path), read(other)
        problems, worst, absolute = [], [], {}
        for column, values in a.items():
            if column in IGNORED:
                continue
            if column not in b or len(b[column]) != len(values):
                problems.append(f"{column} missing or of another length")
                continue
            largest = float(np.abs(values).max(initial=0.0))
            absolute[column] = (float(np.abs(b[column] - values).max(initial=0.0)), largest)
            worst.append((absolute[column][0] / max(largest, 1e-300), column))
        worst.sort(reverse=True)
        bad = [
            f"{column} {d:.2e} (difference {absolute[column][0]:.2e}, largest value "
            f"{absolute[column][1]:.2e})"
            for d, column in worst
            if d > rtol
        ] + problems
        shown = ", ".join(f"{column} {d:.2e}" for d, column in worst[:3])
        print(f"{name}: {'DIFFERS' if bad else 'same'} (largest relative differences: {shown})")
        if bad:
            print(f"  beyond {rtol:g}: {'; '.join(bad)}")
            status = 1
    return status


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    commands = parser.add_subparsers(dest="command", required=True)
    runner = commands.add_parser("run", help="run the demos")
    runner.add_argument("out")
    runner.add_argument(
        "--repo", default=os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    )
    runner.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    runner.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    comparer = commands.add_parser("compare", help="compare two sets of runs")
    comparer.add_argument("old")
    comparer.add_argument("new")
    comparer.add_argument("--rtol", type=float, default=1e-10)
    args = parser.parse_args()
    if args.command == "run":
        return run(args.out, os.path.abspath(args.repo), args.ranks, args.cases)
    return compare(args.old, args.new, args.rtol)


if __name__ == "__main__":
    sys.exit(main())
