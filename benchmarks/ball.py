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

The figures are medians measured in one run on a shared machine: compare ratios
measured together rather than absolute times across runs.
"""

from __future__ import annotations

import argparse
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
from nitsche_dolfinx.linear_solvers import LINEAR_SOLVERS

#: A variant of the library's presets for comparison: its "lu" with PETSc's own LU.
PETSC_LU = {"pc_type": "lu", "pc_factor_mat_solver_type": "petsc"}


def log_time(event: str) -> float:
    """Seconds spent in a PETSc event so far (max over ranks)."""
    return MPI.COMM_WORLD.allreduce(PETSc.Log.Event(event).getPerfInfo()["time"], op=MPI.MAX)


def measure(
    mesh_size: float, t_end: float, contact: bool, linear_solver: str, scheme: str, reuse: bool
):
    """Run the ball once; return its figures."""
    comm = MPI.COMM_WORLD
    problem = impact_problem(dim=3, mesh_size=mesh_size, contact=contact, comm=comm)
    petsc = linear_solver == "lu-petsc"
    simulation = Simulation(
        problem,
        make_scheme(scheme),
        dt=0.1,
        t_end=t_end,
        petsc_options=PETSC_LU if petsc else None,
        linear_solver="lu" if petsc else linear_solver,
        reuse_jacobian=reuse,
    )
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
        "factorisations": simulation.solver.preconditioner_updates,
    }


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
            f"| {1e3 * contact:.1f} | {1e3 * linear:.1f} | {ratio} | {means} "
            f"| {row['assembly_seconds']:.2f} / {row['solve_seconds']:.2f} / "
            f"{row['other_seconds']:.2f} | {row['factorisations']} "
            f"| {row['peak_memory_mb']:.0f} |"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mesh-sizes", type=float, nargs="+", default=[8.0, 6.0, 4.5])
    parser.add_argument("--t-end", type=float, default=40.0)
    parser.add_argument("--scheme", default="hybrid")
    parser.add_argument("--linear-solver", choices=[*LINEAR_SOLVERS, "lu-petsc"], default="lu")
    parser.add_argument("--all", action="store_true", help="serial and mpirun -n 2, one table")
    parser.add_argument(
        "--no-reuse",
        action="store_true",
        help="the straightforward loop: re-assemble and re-factorise at every Newton iteration",
    )
    parser.add_argument("--json", action="store_true", help="print the rows as JSON lines")
    args = parser.parse_args()

    if args.all:
        rows = []
        forwarded = [a for a in sys.argv[1:] if a != "--all"]
        for ranks in (1, 2):
            command = [sys.executable, os.path.abspath(__file__), *forwarded, "--json"]
            if ranks > 1:
                command = ["mpirun", "-n", str(ranks), *command]
            result = subprocess.run(command, capture_output=True, text=True)
            if result.returncode != 0:
                sys.exit(f"{' '.join(command)} failed:\n{result.stderr[-3000:]}")
            rows += [json.loads(line) for line in result.stdout.splitlines() if line[:1] == "{"]
        print(table(rows))
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
