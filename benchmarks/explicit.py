"""Benchmark of the explicit Verlet scheme (docs/method.md section 12) against the hybrid one.

Three modes, each printing its table and saving it as CSV in ``--out``:

- ``cost`` (the default): the ball (P2) at each of ``--mesh-sizes``, falling freely
  before its impact (t < 10), stepped by Verlet (lumped HRZ mass, ``dt = auto``) and by
  the hybrid scheme (consistent mass, tau = 0.1, the default linear solver), the two
  runs alternated ``--repeat`` times in one process. Per mesh: the median explicit step
  and the median hybrid free step (``step_seconds``: the step alone), their ratio, and
  the same for the time loop per step (the step with the history's diagnostics); then the
  exponent of the explicit step in the DOFs (least squares in log-log). ``--ranks 1 2``
  runs each mesh serially and under ``mpirun -n 2``, each in a process of its own, and
  adds the speed-up of two ranks (serial median step over two-rank median step), and
  that of one product with the bulk stiffness matrix alone (``bulk_product_ms``), the
  ceiling the machine's memory bandwidth sets.
- ``long``: 10,000 steps of the bar (P1 lumped, Theta = 1, gamma0 = 0.5, repeated
  impacts) and 2,000 steps of the disk (P2 HRZ, the talk's gamma0, bouncing on the
  plane) at the default safety: the spread of E_Theta over the run, relative to
  E_Theta(0). Under ``mpirun -n 2`` it also runs the disk's 10,000 steps on both ranks
  and on one, and prints each column's largest difference over its largest value.
- ``ball``: the ball at one ``--mesh-sizes`` to ``--t-end`` with ``dt = auto``: the time
  loop, the peak memory, the peak contact force and the contact duration, beside the
  same of a hybrid history given with ``--hybrid-history`` (a ``history.csv`` of
  ``demos/ball_3d.py`` on the same mesh).

Usage::

    python benchmarks/explicit.py --mesh-sizes 4 3 2 --repeat 3 --out DIR
    python benchmarks/explicit.py --mesh-sizes 4 2 1.5 --ranks 1 2 --out DIR
    python benchmarks/explicit.py --mode long --out DIR
    mpirun -n 2 python benchmarks/explicit.py --mode long --out DIR
    mpirun -n 2 python benchmarks/explicit.py --mode ball --mesh-sizes 0.86 --out DIR

The machine is shared: the ratios are measured side by side in one process, and each
figure is a median.
"""

from __future__ import annotations

import argparse
import csv
import gc
import json
import os
import resource
import subprocess
import sys
import time

import numpy as np
import ufl
from mpi4py import MPI

from nitsche_dolfinx import Simulation, make_scheme, read_history
from nitsche_dolfinx.cases import bar_problem, impact_problem
from nitsche_dolfinx.output import assembled_matrix
from nitsche_dolfinx.steppers import VerletScheme

COST_COLUMNS = ("h", "ranks", "dofs", "explicit_step_ms", "hybrid_free_step_ms", "step_ratio",
                "explicit_loop_per_step_ms", "hybrid_loop_per_step_ms", "loop_ratio", "dt",
                "stable_dt", "bulk_product_ms", "runs")  # fmt: skip
#: Steps of each run of the cost mode: the explicit steps of one free fall are cheap, the
#: hybrid ones dear; both stay before the impact (t = 10).
EXPLICIT_STEPS, HYBRID_STEPS = 60, 12


def max_over_ranks(values) -> np.ndarray:
    """Each step's largest time over the ranks."""
    return np.max(MPI.COMM_WORLD.allgather(np.asarray(values)), axis=0)


def timed_run(simulation) -> tuple[float, float]:
    """The median step and the loop per step of a run (max over ranks), in ms."""
    comm = MPI.COMM_WORLD
    start = time.perf_counter()
    history = simulation.run()
    loop = comm.allreduce(time.perf_counter() - start, op=MPI.MAX)
    steps = max_over_ranks(history["step_seconds"][1:])
    # the hybrid's first step factorises (or sets up the preconditioner): not a free step
    return 1e3 * float(np.median(steps[1:])), 1e3 * loop / len(steps)


def measure_cost(mesh_size: float, repeat: int) -> dict:
    """The ball's explicit and hybrid free steps on one mesh, alternated ``repeat`` times."""
    comm = MPI.COMM_WORLD
    explicit_problem = impact_problem(dim=3, mesh_size=mesh_size, mass="lumped", comm=comm)
    hybrid_problem = impact_problem(dim=3, mesh_size=mesh_size, comm=comm)
    probe = Simulation(explicit_problem, VerletScheme(), dt="auto", t_end=1.0)
    dt, stable = probe.dt, probe.stepper.stable_dt
    figures = []
    for _ in range(repeat):
        explicit = Simulation(explicit_problem, VerletScheme(), dt=dt, t_end=EXPLICIT_STEPS * dt)
        hybrid = Simulation(hybrid_problem, make_scheme("hybrid"), dt=0.1, t_end=HYBRID_STEPS * 0.1)
        figures.append((*timed_run(explicit), *timed_run(hybrid)))
    e_step, e_loop, h_step, h_loop = np.median(np.array(figures), axis=0)
    product = bulk_product(explicit_problem, repeat=50)
    return {
        "h": mesh_size, "ranks": comm.size, "dofs": probe.dofs,
        "explicit_step_ms": e_step, "hybrid_free_step_ms": h_step, "step_ratio": e_step / h_step,
        "explicit_loop_per_step_ms": e_loop, "hybrid_loop_per_step_ms": h_loop,
        "loop_ratio": e_loop / h_loop, "dt": dt, "stable_dt": stable,
        "bulk_product_ms": product, "runs": repeat,
    }  # fmt: skip


def bulk_product(problem, repeat: int) -> float:
    """The median time of one product with the bulk stiffness matrix, the largest part of
    an explicit step, in ms (each the slowest rank's): on two ranks, its speed-up is the
    ceiling this machine's memory bandwidth sets on the step's."""
    comm = MPI.COMM_WORLD
    trial, test = ufl.TrialFunction(problem.V), ufl.TestFunction(problem.V)
    matrix = assembled_matrix(problem.bulk_stiffness(trial, test))
    x, y = matrix.createVecs()
    x.set(1.0)
    times = []
    for _ in range(repeat):
        comm.Barrier()
        start = time.perf_counter()
        matrix.mult(x, y)
        times.append(comm.allreduce(time.perf_counter() - start, op=MPI.MAX))
    for obj in (matrix, x, y):
        obj.destroy()
    return 1e3 * float(np.median(times))


def cost(args) -> None:
    rows = []
    for mesh_size in args.mesh_sizes:
        for ranks in args.ranks:
            if ranks == MPI.COMM_WORLD.size and len(args.ranks) == 1:
                row = measure_cost(mesh_size, args.repeat)
            else:  # a process of its own per row
                command = [sys.executable, __file__, "--mode", "cost-row", "--mesh-sizes",
                           str(mesh_size), "--repeat", str(args.repeat)]  # fmt: skip
                if ranks > 1:
                    command = ["mpirun", "-n", str(ranks), *command]
                done = subprocess.run(command, capture_output=True, text=True, env=dict(os.environ))
                if done.returncode != 0:
                    sys.exit(f"{' '.join(command)} failed:\n{done.stderr[-3000:]}")
                row = json.loads(done.stdout.strip().splitlines()[-1])
            rows.append(row)
            if MPI.COMM_WORLD.rank == 0:
                print(" ".join(f"{k}={_fmt(row[k])}" for k in COST_COLUMNS), flush=True)
    if MPI.COMM_WORLD.rank != 0:
        return
    write_csv(os.path.join(args.out, "explicit_cost.csv"), COST_COLUMNS, rows)
    for ranks in args.ranks:
        mine = [row for row in rows if row["ranks"] == ranks]
        if len(mine) > 1:
            slope = np.polyfit(np.log([r["dofs"] for r in mine]),
                               np.log([r["explicit_step_ms"] for r in mine]), 1)[0]  # fmt: skip
            print(f"{ranks} rank(s): the explicit step grows like DOFs^{slope:.2f}")
    if 1 in args.ranks and 2 in args.ranks:
        for mesh_size in args.mesh_sizes:
            one, two = ([r for r in rows if r["h"] == mesh_size and r["ranks"] == n][0]
                        for n in (1, 2))  # fmt: skip
            print(
                f"h = {mesh_size}: {one['dofs']} DOFs, 2 ranks / 1 rank speed-up: step "
                f"{one['explicit_step_ms'] / two['explicit_step_ms']:.2f}, loop "
                f"{one['explicit_loop_per_step_ms'] / two['explicit_loop_per_step_ms']:.2f}, "
                f"bulk product alone {one['bulk_product_ms'] / two['bulk_product_ms']:.2f}"
            )


def energy_spread(history) -> float:
    energy = np.asarray(history["energy_theta"])
    return float((energy.max() - energy.min()) / abs(energy[0]))


def long_runs(args) -> None:
    comm = MPI.COMM_WORLD
    rows = []
    bar = Simulation(bar_problem(nx=100, gamma0=0.5, mass="lumped", comm=comm), VerletScheme(),
                     dt="auto", t_end=1.0)  # fmt: skip
    dt = bar.dt
    bar = Simulation(bar_problem(nx=100, gamma0=0.5, mass="lumped", comm=comm), VerletScheme(),
                     dt=dt, t_end=10_000 * dt)  # fmt: skip
    history = bar.run(columns=["t", "energy_theta", "contact_force"])
    impacts = int(np.sum(np.diff((np.asarray(history["contact_force"]) > 0).astype(int)) == 1))
    rows.append({"run": "bar P1 lumped, gamma0 0.5", "steps": bar.step_index, "dt": dt,
                 "impacts": impacts, "energy_spread": energy_spread(history)})  # fmt: skip

    def disk(steps, on=comm):
        problem = impact_problem(dim=2, mesh_size=8.0, mass="lumped", comm=on)
        probe = Simulation(problem, VerletScheme(), dt="auto", t_end=1.0)
        return Simulation(problem, VerletScheme(), dt=probe.dt, t_end=steps * probe.dt)

    simulation = disk(2_000)
    history = simulation.run()
    touching = (np.asarray(history["contact_force"]) > 0).astype(int)
    rows.append({"run": "disk P2 HRZ, the talk's gamma0", "steps": simulation.step_index,
                 "dt": simulation.dt, "impacts": int(np.sum(np.diff(touching) == 1)),
                 "energy_spread": energy_spread(history)})  # fmt: skip
    if comm.rank == 0:
        for row in rows:
            print(", ".join(f"{k} = {_fmt(v)}" for k, v in row.items()), flush=True)
        write_csv(os.path.join(args.out, "explicit_long.csv"), list(rows[0]), rows)
    if comm.size > 1:
        columns = ["t", "energy", "energy_theta", "kinetic", "elastic", "potential",
                   "contact_force", "contact_area", "penetration_max"]  # fmt: skip
        parallel = disk(10_000).run(columns=columns)
        gc.collect()  # on every rank here: the parallel run's PETSc objects, freed together
        serial = disk(10_000, MPI.COMM_SELF).run(columns=columns)
        if comm.rank == 0:
            print(
                f"disk, 10,000 steps, {comm.size} ranks against 1, largest difference over "
                "the column's largest value:"
            )
            for name in columns:
                scale = max(np.abs(serial[name]).max(), 1e-300)
                difference = np.abs(np.asarray(parallel[name]) - serial[name]).max()
                print(f"  {name}: {difference / scale:.2e}")


def ball(args) -> None:
    comm = MPI.COMM_WORLD
    problem = impact_problem(dim=3, mesh_size=args.mesh_sizes[0], mass="lumped", comm=comm)
    simulation = Simulation(problem, VerletScheme(), dt="auto", t_end=args.t_end, progress=True)
    start = time.perf_counter()
    history = simulation.run(out=os.path.join(args.out, "ball_verlet"), output_every=0)
    loop = comm.allreduce(time.perf_counter() - start, op=MPI.MAX)
    memory = comm.allreduce(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, op=MPI.MAX)
    rows = [{"run": "verlet", "dofs": simulation.dofs, "steps": simulation.step_index,
             "loop_s": loop, "peak_memory_mb": memory / 1024,
             **contact_figures(history)}]  # fmt: skip
    if args.hybrid_history:
        rows.append({"run": "hybrid", "dofs": simulation.dofs, "steps": None, "loop_s": None,
                     "peak_memory_mb": None,
                     **contact_figures(read_history(args.hybrid_history))})  # fmt: skip
    if comm.rank == 0:
        for row in rows:
            print(", ".join(f"{k} = {_fmt(v)}" for k, v in row.items()), flush=True)
        write_csv(os.path.join(args.out, "explicit_ball.csv"), list(rows[0]), rows)


def contact_figures(history) -> dict:
    """The peak contact force and when, and the time from the first to the last level with
    a contact force."""
    t, force = np.asarray(history["t"]), np.asarray(history["contact_force"])
    touching = np.flatnonzero(force > 0)
    duration = float(t[touching[-1]] - t[touching[0]]) if touching.size else 0.0
    return {"peak_force": float(force.max()), "peak_at": float(t[np.argmax(force)]),
            "contact_duration": duration}  # fmt: skip


def write_csv(path: str, columns, rows) -> None:
    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(columns))
        writer.writeheader()
        writer.writerows(rows)
    print(f"saved {path}")


def _fmt(value) -> str:
    return f"{value:.4g}" if isinstance(value, float) else str(value)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mode", choices=("cost", "long", "ball", "cost-row"), default="cost")
    parser.add_argument("--mesh-sizes", type=float, nargs="+", default=[4.0, 3.0, 2.0])
    parser.add_argument("--ranks", type=int, nargs="+", default=None,
                        help="cost: run each mesh on these numbers of ranks, each in a "
                        "process of its own (default: this process)")  # fmt: skip
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--t-end", type=float, default=40.0)
    parser.add_argument("--hybrid-history", help="ball: the hybrid run's history.csv")
    parser.add_argument("--out", default="explicit_results")
    args = parser.parse_args(argv)
    if args.mode == "cost-row":
        row = measure_cost(args.mesh_sizes[0], args.repeat)
        if MPI.COMM_WORLD.rank == 0:
            print(json.dumps(row), flush=True)
        return
    if args.ranks is None:
        args.ranks = [MPI.COMM_WORLD.size]
    {"cost": cost, "long": long_runs, "ball": ball}[args.mode](args)


if __name__ == "__main__":
    main()
