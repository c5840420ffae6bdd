"""Benchmark of contact between two bodies: a two-body step against a rigid-obstacle step
at the same number of DOFs (issue 17: a contact step may cost at most 2 times as much).

Two runs, made one after the other in the same process, on the same cores:

- the pair: two mirror-image balls (``--dim 3``) or disks (``--dim 2``) of the impact test
  colliding head-on (:func:`nitsche_dolfinx.cases.two_bodies.two_bodies_problem`: v0 = 1, gap 1,
  gamma0 = 1e-3, unbiased and paired along the axis unless ``--variant`` or
  ``--pairing`` say otherwise), mesh size ``--mesh-size``;
- the plane: one body of the same kind thrown at v0 on a rigid plane with gamma0 / 2 (the
  pair's symmetric equivalent, docs/method.md section 11; ``--plane-gamma0-factor 1``:
  gamma0), on a mesh with about as many DOFs as the pair (its mesh size found among a
  few near h / 2^(1/dim), or ``--plane-mesh-size``).

P2, the hybrid scheme with Theta = 1, tau = 0.1, the package's default linear solver
(``auto``) unless ``--linear-solver``. For each run: the DOFs, the median wall time of the
free steps (no contact force) and of the contact steps, the Newton iterations and
factorisations per contact step, and the split of the time loop between assembly (SNES
residuals and Jacobians), factorisation (PCSetUp) and triangular solves (KSPSolve).

Each repeat runs both bodies serially and then under ``mpirun -n 2`` (``--ranks``), each
in a process of its own, so that the load of a shared machine falls on all of them alike;
the table gives the medians over the repeats and the median of the per-repeat ratios
pair / plane. Written to ``OUT/two_bodies.csv`` (one row per run) and
``OUT/two_bodies.png`` (the medians per step side by side).

Usage::

    python benchmarks/two_bodies.py --out out/two_bodies                 # balls, h = 8
    python benchmarks/two_bodies.py --dim 2 --mesh-size 4 --out out/two_disks
    python benchmarks/two_bodies.py --repeat 5 --t-end 12 --ranks 1 2 --out DIR
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import subprocess
import sys
import time

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from nitsche_dolfinx import ContactProblem, HybridScheme, Material, PlaneObstacle, Simulation
from nitsche_dolfinx.cases import two_bodies_problem
from nitsche_dolfinx.common import function_space
from nitsche_dolfinx.meshing import ball_mesh, disk_mesh
from nitsche_dolfinx.solvers import LINEAR_SOLVERS

RADIUS, GAMMA0, V0, GAP, DT = 20.0, 1e-3, 1.0, 1.0, 0.1

#: The columns of ``two_bodies.csv``.
COLUMNS = (
    "repeat", "ranks", "body", "h", "dofs", "steps", "contact_steps", "median_free_step_s",
    "median_contact_step_s", "newton_per_contact_step", "factorisations_per_contact_step",
    "assembly_s", "factorisation_s", "solve_s", "loop_s",
)  # fmt: skip


def plane_problem(
    dim: int, mesh_size: float, gamma0_factor: float = 0.5, comm=MPI.COMM_WORLD
) -> ContactProblem:
    """One body of the pair (the upper one) thrown at v0 on the rigid plane of symmetry,
    with gamma0 times ``gamma0_factor`` (1/2: the pair's equivalent)."""
    center = [0.0] * dim
    center[-1] = RADIUS + GAP / 2
    mesh, tags = (ball_mesh if dim == 3 else disk_mesh)(mesh_size, 2, RADIUS, center, comm)
    gamma0 = GAMMA0 * gamma0_factor
    problem = ContactProblem(mesh, tags, Material.from_lame(20.0, 20.0), 2, gamma0, 1.0)
    up = np.zeros(dim)
    up[-1] = 1.0
    problem.add_obstacle(PlaneObstacle(np.zeros(dim), up), 1)
    problem.set_initial_conditions(velocity=-V0 * up)
    return problem


def body_dofs(dim: int, mesh_size: float) -> int:
    """The DOFs of one body of the impact test meshed with ``mesh_size`` (P2)."""
    mesh, _ = (ball_mesh if dim == 3 else disk_mesh)(mesh_size, 2, RADIUS, comm=MPI.COMM_SELF)
    V = function_space(mesh, "Lagrange", 2, (dim,))
    return V.dofmap.index_map.size_global * V.dofmap.index_map_bs


def matching_mesh_size(dim: int, mesh_size: float) -> float:
    """The mesh size near h / 2^(1/dim) whose body has as many DOFs as two bodies of mesh
    size h (the closest of a few candidates)."""
    target = 2 * body_dofs(dim, mesh_size)
    candidates = mesh_size * 2 ** (-1 / dim) * np.linspace(0.85, 1.15, 7)
    return float(min(candidates, key=lambda h: abs(body_dofs(dim, h) - target)))


def event_seconds(name: str) -> float:
    """Seconds spent so far in a PETSc event (max over ranks)."""
    return MPI.COMM_WORLD.allreduce(PETSc.Log.Event(name).getPerfInfo()["time"], op=MPI.MAX)


def measure(problem: ContactProblem, args) -> dict:
    """Run ``problem`` to t_end; its figures."""
    comm = MPI.COMM_WORLD
    simulation = Simulation(
        problem, HybridScheme(), dt=DT, t_end=args.t_end, linear_solver=args.linear_solver
    )
    events = ("SNESFunctionEval", "SNESJacobianEval", "PCSetUp", "KSPSolve")
    before = [event_seconds(e) for e in events]
    factorisations = simulation.solver.petsc.preconditioner_updates
    start = time.perf_counter()
    history = simulation.run()
    loop = comm.allreduce(time.perf_counter() - start, op=MPI.MAX)
    spent = [event_seconds(e) - b for e, b in zip(events, before)]
    steps = np.max(comm.allgather(np.asarray(history["step_seconds"][1:])), axis=0)
    contact = np.asarray(history["contact_force"][1:]) > 0
    newton = np.asarray(history["newton_iterations"][1:])
    factorisations = simulation.solver.petsc.preconditioner_updates - factorisations

    def median(selected):
        return float(np.median(steps[selected])) if selected.any() else float("nan")

    return {
        "ranks": comm.size,
        "dofs": simulation.dofs,
        "steps": len(steps),
        "contact_steps": int(contact.sum()),
        "median_free_step_s": median(~contact),
        "median_contact_step_s": median(contact),
        "newton_per_contact_step": float(newton[contact].mean()) if contact.any() else 0.0,
        # the few factorisations of free steps (the first, the step before contact) included
        "factorisations_per_contact_step": factorisations / max(int(contact.sum()), 1),
        "assembly_s": spent[0] + spent[1],
        "factorisation_s": spent[2],
        "solve_s": spent[3],
        "loop_s": loop,
    }


def measure_both(args) -> list[dict]:
    """The pair and the body on the plane, in this process (serial or under mpirun)."""
    PETSc.Log.begin()
    pair, _ = two_bodies_problem(
        dim=args.dim, mesh_size=args.mesh_size, v0=V0, gap=GAP, gamma0=GAMMA0,
        variant=args.variant, along_axis=args.pairing == "axis",
    )  # fmt: skip
    body = "balls" if args.dim == 3 else "disks"
    rows = [{"body": f"two {body}", "h": args.mesh_size, **measure(pair, args)}]
    plane = plane_problem(args.dim, args.plane_mesh_size, args.plane_gamma0_factor)
    rows.append({"body": "one on a plane", "h": args.plane_mesh_size, **measure(plane, args)})
    return rows


def run_command(command: list[str]) -> str:
    """Run a benchmark process (with the environment this one started with: a child
    mpirun fails silently in the variables a singleton MPI adds); its output."""
    result = subprocess.run(command, capture_output=True, text=True, env=dict(os.environ))
    if result.returncode != 0:
        sys.exit(f"{' '.join(command)} failed:\n{result.stderr[-3000:]}")
    return result.stdout


def ratio(rows: list[dict], column: str) -> float:
    """The median over the repeats of pair / plane for ``column``."""
    values = []
    for repeat in {row["repeat"] for row in rows}:
        pair, plane = (
            next(r for r in rows if r["repeat"] == repeat and r["body"].startswith(kind))
            for kind in ("two", "one")
        )
        values.append(pair[column] / plane[column])
    return float(np.median(values))


def table(rows: list[dict]) -> str:
    """Medians over the repeats, one line per number of ranks and body, and the ratios."""
    lines = [
        "| ranks | body | h | DOFs | contact steps | free step (ms) | contact step (ms) "
        "| Newton / contact step | factorisations / contact step "
        "| assembly / factorisation / solve (s) |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for ranks in sorted({row["ranks"] for row in rows}):
        mine = [row for row in rows if row["ranks"] == ranks]
        for body in dict.fromkeys(row["body"] for row in mine):
            runs = [row for row in mine if row["body"] == body]
            median = {column: float(np.median([r[column] for r in runs])) for column in COLUMNS[3:]}
            lines.append(
                f"| {ranks} | {body} | {median['h']:g} | {median['dofs']:.0f} "
                f"| {median['contact_steps']:.0f} | {1e3 * median['median_free_step_s']:.1f} "
                f"| {1e3 * median['median_contact_step_s']:.1f} "
                f"| {median['newton_per_contact_step']:.2f} "
                f"| {median['factorisations_per_contact_step']:.2f} "
                f"| {median['assembly_s']:.2f} / {median['factorisation_s']:.2f} / "
                f"{median['solve_s']:.2f} |"
            )
        lines.append(
            f"| {ranks} | **pair / plane** | | {ratio(mine, 'dofs'):.3f} | "
            f"| {ratio(mine, 'median_free_step_s'):.2f} "
            f"| **{ratio(mine, 'median_contact_step_s'):.2f}** "
            f"| {ratio(mine, 'newton_per_contact_step'):.2f} | | |"
        )
    return "\n".join(lines)


def plot(rows: list[dict], path: str) -> None:
    """The medians per free and contact step, pair and plane side by side, per ranks."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ranks = sorted({row["ranks"] for row in rows})
    bodies = list(dict.fromkeys(row["body"] for row in rows))
    figure, axes = plt.subplots(figsize=(6.4, 3.8))
    width = 0.8 / (2 * len(bodies))
    for k, (column, what) in enumerate(
        (("median_free_step_s", "free"), ("median_contact_step_s", "contact"))
    ):
        for j, body in enumerate(bodies):
            heights = [
                1e3 * np.median([r[column] for r in rows if r["ranks"] == n and r["body"] == body])
                for n in ranks
            ]
            offset = (k * len(bodies) + j - len(bodies) + 0.5) * width
            axes.bar(np.arange(len(ranks)) + offset, heights, width, label=f"{body}, {what} step",
                     hatch="" if k else "//", color=f"C{j}", alpha=1.0 if k else 0.6)  # fmt: skip
    axes.set_xticks(np.arange(len(ranks)), [f"{n} rank{'s' if n > 1 else ''}" for n in ranks])
    axes.set_ylabel("median wall time per step (ms)")
    dofs = int(np.median([r["dofs"] for r in rows if r["body"] == bodies[0]]))
    axes.set_title(f"{bodies[0]} against {bodies[1]}, about {dofs} DOFs (P2, tau = 0.1)",
                   fontsize=9)  # fmt: skip
    axes.legend(fontsize=7)
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    plt.close(figure)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dim", type=int, choices=(2, 3), default=3)
    parser.add_argument("--mesh-size", type=float, default=8.0, help="the pair's mesh size h")
    parser.add_argument("--plane-mesh-size", type=float, help="default: DOFs as the pair")
    parser.add_argument("--plane-gamma0-factor", type=float, default=0.5, help="of gamma0")
    parser.add_argument("--t-end", type=float, default=8.0)
    parser.add_argument("--variant", choices=("unbiased", "biased"), default="unbiased")
    parser.add_argument("--pairing", choices=("axis", "closest"), default="axis")
    parser.add_argument("--linear-solver", choices=list(LINEAR_SOLVERS), default="auto")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--out", default=os.path.join("out", "two_bodies"))
    parser.add_argument("--rows", action="store_true", help=argparse.SUPPRESS)  # a child
    args = parser.parse_args()

    if args.rows:
        rows = measure_both(args)
        if MPI.COMM_WORLD.rank == 0:
            for row in rows:
                print(json.dumps(row), flush=True)
        return
    if args.plane_mesh_size is None:
        args.plane_mesh_size = matching_mesh_size(args.dim, args.mesh_size)
    os.makedirs(args.out, exist_ok=True)
    forwarded = [a for a in sys.argv[1:] if a != "--rows"]
    forwarded += ["--plane-mesh-size", f"{args.plane_mesh_size!r}", "--rows"]
    rows = []
    path = os.path.join(args.out, "two_bodies.csv")
    with open(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=COLUMNS)
        writer.writeheader()
        for repeat in range(args.repeat):
            for ranks in args.ranks:
                command = [sys.executable, os.path.abspath(__file__), *forwarded]
                if ranks > 1:
                    command = ["mpirun", "-n", str(ranks), *command]
                for line in run_command(command).splitlines():
                    if line[:1] == "{":
                        row = {"repeat": repeat, **json.loads(line)}
                        rows.append(row)
                        writer.writerow(row)
                        handle.flush()
                        print(json.dumps(row), flush=True)
    print(table(rows))
    plot(rows, os.path.join(args.out, "two_bodies.png"))
    print(f"rows: {path}")


if __name__ == "__main__":
    main()
