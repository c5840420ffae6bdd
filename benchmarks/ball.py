"""Benchmark of the ball impact: cost per time step, its split, and contact vs linear steps.

For each mesh size it runs the talk's ball (P2, tau = 0.1, hybrid scheme, Theta = 1,
gamma0 = 1e-3) and the same ball without the obstacle (plain linear elastodynamics,
same mesh, same solver), and prints one row per run:

- DOFs, steps, mean Newton iterations per step;
- the median wall time per step, over all steps, over the steps in contact, and
  over the steps of the linear run; their ratio (contact step / linear step), and
  the same ratio of the mean times (occasional re-factorisations weigh in it);
- the split of the time loop between assembly (SNES residual and Jacobian
  evaluations), linear solves (KSP) and the rest (diagnostics, output, Python);
- the peak memory (resident set, max over ranks).

Usage::

    python benchmarks/ball.py                       # this process (serial, or under mpirun)
    mpirun -n 2 python benchmarks/ball.py
    python benchmarks/ball.py --all                 # serial and mpirun -n 2, one table
    python benchmarks/ball.py --mesh-sizes 8 6 --t-end 20 --linear-solver lu-lagged
    python benchmarks/ball.py --mesh-sizes 8 --no-reuse   # the straightforward loop
    python benchmarks/ball.py --mesh-sizes 8 6 5 4 3 --t-end 20 --linear-solver auto --out DIR

The last is the scaling mode (``--out``): the ball alone (its free steps, falling
before the impact and vibrating in flight after it, and its contact steps), each mesh
size serially and under ``mpirun -n 2`` in a process of its own, written to
``DIR/scaling.csv`` (one row per mesh size and number of ranks, a row as soon as it is
measured) and ``DIR/scaling.png`` (time per step against DOFs, log-log). With
``--repeat N`` each row is run N times and gives the median of each figure over the
runs (the ratio of a contact step to a rebound step is taken in each run: the shared
machine's load drifts between the contact steps and the rebound after them). With
``--vs NAME --repeat N`` it runs instead N pairs of time loops, the linear solver and
``NAME`` in turn, into ``DIR/versus.csv``, and prints the median ratio::

    python benchmarks/ball.py --mesh-sizes 8 --t-end 40 --linear-solver auto --vs lu --out DIR

The figures are medians measured in one run on a shared machine: compare ratios
measured together rather than absolute times across runs.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import resource
import subprocess
import sys
import time

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from nitsche_dolfinx import Simulation, make_scheme
from nitsche_dolfinx.cases import impact_problem
from nitsche_dolfinx.solvers import LINEAR_SOLVERS

#: A variant of the library's presets for comparison: its "lu" with PETSc's own LU.
PETSC_LU = {"pc_type": "lu", "pc_factor_mat_solver_type": "petsc"}


def run_command(command: list[str]) -> subprocess.CompletedProcess:
    """Run a benchmark process; exit naming it if it fails. It gets the environment this
    process started with: MPI, started here as a singleton, adds variables of its own at
    the C level that make a child ``mpirun`` fail without a word."""
    result = subprocess.run(command, capture_output=True, text=True, env=dict(os.environ))
    if result.returncode != 0:
        sys.exit(f"{' '.join(command)} failed:\n{result.stderr[-3000:]}")
    return result


def log_time(event: str) -> float:
    """Seconds spent in a PETSc event so far (max over ranks)."""
    return MPI.COMM_WORLD.allreduce(PETSc.Log.Event(event).getPerfInfo()["time"], op=MPI.MAX)


def ball_simulation(problem, t_end: float, linear_solver: str, scheme: str, **options):
    """The talk's run of ``problem`` (tau = 0.1) with ``linear_solver``, "lu-petsc" being
    PETSc's own LU."""
    petsc = linear_solver == "lu-petsc"
    return Simulation(
        problem,
        make_scheme(scheme),
        dt=0.1,
        t_end=t_end,
        petsc_options=PETSC_LU if petsc else None,
        linear_solver="lu" if petsc else linear_solver,
        **options,
    )


def measure(
    mesh_size: float, t_end: float, contact: bool, linear_solver: str, scheme: str, reuse: bool
):
    """Run the ball once; return its figures."""
    comm = MPI.COMM_WORLD
    problem = impact_problem(dim=3, mesh_size=mesh_size, contact=contact, comm=comm)
    simulation = ball_simulation(problem, t_end, linear_solver, scheme, reuse_jacobian=reuse)
    events = ("SNESFunctionEval", "SNESJacobianEval", "KSPSolve", "PCSetUp")
    before = {event: log_time(event) for event in events}
    start = time.perf_counter()
    history = simulation.run()
    loop = comm.allreduce(time.perf_counter() - start, op=MPI.MAX)
    after = {event: log_time(event) for event in events}
    assembly = sum(after[e] - before[e] for e in events[:2])
    solve = sum(after[e] - before[e] for e in events[2:])  # factorisations and solves
    steps = history["step_seconds"][1:]
    steps = (
        comm.allreduce(steps, op=MPI.MAX)
        if comm.size == 1
        else np.max(comm.allgather(steps), axis=0)
    )
    in_contact = history["contact_force"][1:] > 0
    memory = comm.allreduce(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, op=MPI.MAX)
    return {
        "ranks": comm.size,
        "mesh_size": mesh_size,
        "dofs": simulation.dofs,
        "steps": len(steps),
        "newton": history.mean_newton_iterations(),
        "loop_seconds": loop,
        "median_step": float(np.median(steps)),
        "median_contact_step": float(np.median(steps[in_contact])) if in_contact.any() else None,
        "mean_contact_step": float(np.mean(steps[in_contact])) if in_contact.any() else None,
        "mean_step": float(np.mean(steps)),
        "assembly_seconds": assembly,
        "solve_seconds": solve,
        "other_seconds": loop - assembly - solve,
        "peak_memory_mb": memory / 1024.0,
        "factorisations": simulation.solver.petsc.preconditioner_updates,
    }


#: The columns of ``scaling.csv`` (SPEC section 8, then more): a free step has no contact
#: force; the falling steps are the free steps before the first contact (a rigid fall,
#: whose last acceleration is already the solution), the rebound steps those after it
#: (the ball vibrating in flight). ``contact_over_rebound`` is the median contact step
#: over the median rebound step of one run; with ``runs`` > 1 each column is the median
#: of the runs' (the peak memory their largest).
SCALING_COLUMNS = (
    "h",
    "ranks",
    "dofs",
    "steps",
    "newton_per_step",
    "median_free_step_s",
    "median_contact_step_s",
    "loop_s",
    "peak_memory_mb",
    "krylov_per_step",
    "newton_per_free_step",
    "newton_per_contact_step",
    "krylov_per_free_step",
    "krylov_per_contact_step",
    "median_falling_step_s",
    "median_rebound_step_s",
    "contact_steps",
    "mesh_s",
    "setup_s",
    "linear_solver",
    "contact_over_rebound",
    "runs",
)


def scaling_simulation(mesh_size: float, t_end: float, linear_solver: str, scheme: str):
    """The ball with the obstacle, and the seconds its mesh and its set-up took."""
    comm = MPI.COMM_WORLD
    start = time.perf_counter()
    problem = impact_problem(dim=3, mesh_size=mesh_size, comm=comm)
    mesh_seconds = comm.allreduce(time.perf_counter() - start, op=MPI.MAX)
    simulation = ball_simulation(problem, t_end, linear_solver, scheme)
    setup_seconds = comm.allreduce(time.perf_counter() - start, op=MPI.MAX) - mesh_seconds
    return simulation, mesh_seconds, setup_seconds


def measure_scaling(mesh_size: float, t_end: float, linear_solver: str, scheme: str) -> dict:
    """The ball once, with the obstacle: its free steps (no contact force) and its contact
    steps; Newton and Krylov iterations per step; the peak memory of the largest rank."""
    comm = MPI.COMM_WORLD
    simulation, mesh_seconds, setup_seconds = scaling_simulation(
        mesh_size, t_end, linear_solver, scheme
    )
    krylov = []

    def count(simulation):
        krylov.append(simulation.solver.snes.getLinearSolveIterations())

    start = time.perf_counter()
    history = simulation.run(callback=count)
    loop = comm.allreduce(time.perf_counter() - start, op=MPI.MAX)
    steps = np.max(comm.allgather(np.asarray(history["step_seconds"][1:])), axis=0)
    newton = np.asarray(history["newton_iterations"][1:], dtype=float)
    krylov = np.asarray(krylov, dtype=float)
    contact = np.asarray(history["contact_force"][1:]) > 0
    first = int(np.argmax(contact)) if contact.any() else len(contact)
    index = np.arange(len(contact))
    memory = comm.allreduce(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, op=MPI.MAX)

    def median(selected):
        return float(np.median(steps[selected])) if selected.any() else float("nan")

    def mean(values, selected):
        return float(np.mean(values[selected])) if selected.any() else float("nan")

    return {
        "h": mesh_size,
        "ranks": comm.size,
        "dofs": simulation.dofs,
        "steps": len(steps),
        "newton_per_step": float(np.mean(newton)),
        "median_free_step_s": median(~contact),
        "median_contact_step_s": median(contact),
        "loop_s": loop,
        "peak_memory_mb": memory / 1024.0,
        "krylov_per_step": float(np.mean(krylov)),
        "newton_per_free_step": mean(newton, ~contact),
        "newton_per_contact_step": mean(newton, contact),
        "krylov_per_free_step": mean(krylov, ~contact),
        "krylov_per_contact_step": mean(krylov, contact),
        "median_falling_step_s": median(~contact & (index < first)),
        "median_rebound_step_s": median(~contact & (index > first)),
        "contact_steps": int(contact.sum()),
        "mesh_s": mesh_seconds,
        "setup_s": setup_seconds,
        "linear_solver": simulation.solver_description,
        "contact_over_rebound": median(contact) / median(~contact & (index > first)),
        "runs": 1,
    }


def row_command(mesh_size: float, ranks: int, linear_solver: str, args) -> list[str]:
    """The command that measures one row of the scaling mode in a process of its own."""
    command = [sys.executable, os.path.abspath(__file__), "--scaling-row"]
    command += ["--mesh-sizes", f"{mesh_size:g}", "--t-end", f"{args.t_end:g}"]
    command += ["--linear-solver", linear_solver, "--scheme", args.scheme]
    return ["mpirun", "-n", str(ranks), *command] if ranks > 1 else command


def measure_row(mesh_size: float, ranks: int, linear_solver: str, args) -> dict:
    result = run_command(row_command(mesh_size, ranks, linear_solver, args))
    return json.loads([x for x in result.stdout.splitlines() if x[:1] == "{"][-1])


def median_row(runs: list[dict]) -> dict:
    """The row of several runs of the same mesh size and ranks: the median of each
    figure over the runs (the peak memory: the largest)."""
    row = dict(runs[0])
    for key, value in row.items():
        if isinstance(value, float) and key != "h":
            row[key] = float(np.median([run[key] for run in runs]))
    row["peak_memory_mb"] = max(run["peak_memory_mb"] for run in runs)
    row["runs"] = len(runs)
    return row


def scaling(args) -> None:
    """The scaling mode: each mesh size and number of ranks in a process of its own."""
    os.makedirs(args.out, exist_ok=True)
    path = os.path.join(args.out, "scaling.csv")
    rows = []
    with open(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=SCALING_COLUMNS)
        writer.writeheader()
        for mesh_size in args.mesh_sizes:
            for ranks in args.ranks:
                runs = [measure_row(mesh_size, ranks, args.linear_solver, args)]
                runs += [measure_row(mesh_size, ranks, args.linear_solver, args)
                         for _ in range((args.repeat or 1) - 1)]  # fmt: skip
                row = median_row(runs)
                rows.append(row)
                writer.writerow(row)
                handle.flush()
                print(json.dumps(row), flush=True)
    plot_scaling(rows, os.path.join(args.out, "scaling.png"))


#: The columns of ``versus.csv``: time loops of two linear solvers, run in turn.
VERSUS_COLUMNS = ("h", "ranks", "pair", "linear_solver", "versus", "loop_s", "versus_loop_s")


def versus(args) -> None:
    """The time loop of ``--linear-solver`` against that of ``--vs`` on the same ball, run
    in turn (A B A B ...) so that the ratio of each pair sees the same machine."""
    os.makedirs(args.out, exist_ok=True)
    path = os.path.join(args.out, "versus.csv")
    with open(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=VERSUS_COLUMNS)
        writer.writeheader()
        for mesh_size in args.mesh_sizes:
            for ranks in args.ranks:
                ratios = []
                for pair in range(args.repeat or 5):
                    a = measure_row(mesh_size, ranks, args.linear_solver, args)
                    b = measure_row(mesh_size, ranks, args.vs, args)
                    ratios.append(a["loop_s"] / b["loop_s"])
                    writer.writerow(
                        {
                            "h": mesh_size,
                            "ranks": ranks,
                            "pair": pair,
                            "linear_solver": a["linear_solver"],
                            "versus": b["linear_solver"],
                            "loop_s": a["loop_s"],
                            "versus_loop_s": b["loop_s"],
                        }
                    )
                    handle.flush()
                print(
                    f"h = {mesh_size:g}, {ranks} rank(s): time loop {args.linear_solver} / "
                    f"{args.vs} = {np.median(ratios):.3f} (median of {len(ratios)} pairs, "
                    f"{min(ratios):.3f} to {max(ratios):.3f})",
                    flush=True,
                )


def plot_scaling(rows: list[dict], path: str) -> None:
    """Time per step against DOFs, log-log: contact steps and the free steps (falling
    before the impact, vibrating in flight after it) for each number of ranks, and a line
    of slope 1 through the smallest serial contact step."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(6.4, 4.4))
    kinds = (
        ("median_contact_step_s", "s", "C3", "contact"),
        ("median_rebound_step_s", "^", "C0", "free, after the impact"),
        ("median_falling_step_s", "o", "C2", "free, falling"),
    )
    for ranks in sorted({row["ranks"] for row in rows}):
        mine = sorted((row for row in rows if row["ranks"] == ranks), key=lambda r: r["dofs"])
        dofs = np.array([row["dofs"] for row in mine])
        for column, marker, colour, what in kinds:
            times = np.array([row.get(column, np.nan) for row in mine], dtype=float)
            if np.isnan(times).all():
                continue
            style = "-" if ranks == 1 else "--"
            label = f"{what}, {ranks} rank{'s' if ranks > 1 else ''}"
            axes.loglog(dofs, times, style, marker=marker, color=colour, label=label)
    serial = sorted((r for r in rows if r["ranks"] == 1), key=lambda r: r["dofs"]) or rows
    reach = np.array([serial[0]["dofs"], max(row["dofs"] for row in rows)])
    slope = serial[0]["median_contact_step_s"] * reach / reach[0]
    axes.loglog(reach, slope, ":", color="grey", label="DOFs$^1$")
    axes.set_xlabel("DOFs")
    axes.set_ylabel("median time per step (s)")
    axes.set_title(f"ball, P2, tau = 0.1: {rows[0]['linear_solver']}", fontsize=9)
    axes.legend(fontsize=7)
    axes.grid(True, which="both", alpha=0.3)
    figure.tight_layout()
    figure.savefig(path, dpi=90)
    plt.close(figure)


def _milliseconds(seconds: float | None) -> str:
    """A table cell: the time in ms, or "-" for a run without such steps."""
    return "-" if seconds is None else f"{1e3 * seconds:.1f}"


def table(rows: list[dict]) -> str:
    """The Markdown table of the benchmark."""
    lines = [
        "| ranks | h | DOFs | steps | Newton/step | loop (s) | median step (ms) "
        "| median contact step (ms) | median linear step (ms) | contact/linear "
        "| contact/linear (means) | assembly / solve / other (s) | factorisations "
        "| peak memory (MB) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        contact, linear = row["median_contact_step"], row["linear"]["median_step"]
        ratio = f"{contact / linear:.2f}" if contact else "-"
        means = f"{row['mean_contact_step'] / row['linear']['mean_step']:.2f}" if contact else "-"
        lines.append(
            f"| {row['ranks']} | {row['mesh_size']:g} | {row['dofs']} | {row['steps']} "
            f"| {row['newton']:.2f} | {row['loop_seconds']:.2f} "
            f"| {1e3 * row['median_step']:.1f} "
            f"| {_milliseconds(contact)} | {_milliseconds(linear)} | {ratio} | {means} "
            f"| {row['assembly_seconds']:.2f} / {row['solve_seconds']:.2f} / "
            f"{row['other_seconds']:.2f} | {row['factorisations']} "
            f"| {row['peak_memory_mb']:.0f} |"
        )
    return "\n".join(lines)


def serial_and_two_ranks() -> list[dict]:
    """The rows of this command's flags (but --all) run serially and on 2 ranks."""
    rows = []
    forwarded = [a for a in sys.argv[1:] if a != "--all"]
    for ranks in (1, 2):
        command = [sys.executable, os.path.abspath(__file__), *forwarded, "--json"]
        if ranks > 1:
            command = ["mpirun", "-n", str(ranks), *command]
        result = run_command(command)
        rows += [json.loads(line) for line in result.stdout.splitlines() if line[:1] == "{"]
    return rows


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mesh-sizes", type=float, nargs="+", default=[8.0, 6.0, 4.5])
    parser.add_argument("--t-end", type=float, default=40.0)
    parser.add_argument("--scheme", default="hybrid")
    parser.add_argument("--linear-solver", choices=[*LINEAR_SOLVERS, "lu-petsc"], default="auto")
    parser.add_argument("--out", help="scaling mode: write OUT/scaling.csv and OUT/scaling.png")
    parser.add_argument(
        "--ranks", type=int, nargs="+", default=[1, 2], help="scaling mode: numbers of ranks"
    )
    parser.add_argument(
        "--vs",
        choices=[*LINEAR_SOLVERS, "lu-petsc"],
        help="with --out: time loops against this linear solver, run in turn (versus.csv)",
    )
    parser.add_argument(
        "--repeat",
        type=int,
        help="with --vs: pairs of runs (5); else in the scaling mode: runs of each row (1), "
        "the row giving the median of each figure over them",
    )
    parser.add_argument("--scaling-row", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--all", action="store_true", help="serial and mpirun -n 2, one table")
    parser.add_argument(
        "--no-reuse",
        action="store_true",
        help="the straightforward loop: re-assemble and re-factorise at every Newton iteration",
    )
    parser.add_argument("--json", action="store_true", help="print the rows as JSON lines")
    return parser


def main() -> None:
    args = _parser().parse_args()

    if args.scaling_row:  # one row of the scaling mode, in this process
        row = measure_scaling(args.mesh_sizes[0], args.t_end, args.linear_solver, args.scheme)
        if MPI.COMM_WORLD.rank == 0:
            print(json.dumps(row), flush=True)
        return
    if args.out is not None and args.vs is not None:
        versus(args)
        return
    if args.out is not None:
        scaling(args)
        return
    if args.all:
        print(table(serial_and_two_ranks()))
        return

    PETSc.Log.begin()
    rows = []
    for mesh_size in args.mesh_sizes:
        reuse = not args.no_reuse
        row = measure(mesh_size, args.t_end, True, args.linear_solver, args.scheme, reuse)
        row["linear"] = measure(
            mesh_size, args.t_end, False, args.linear_solver, args.scheme, reuse
        )
        rows.append(row)
        if MPI.COMM_WORLD.rank == 0 and args.json:
            print(json.dumps(row), flush=True)
    if MPI.COMM_WORLD.rank == 0 and not args.json:
        print(table(rows))


if __name__ == "__main__":
    main()
