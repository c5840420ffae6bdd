"""Benchmark of contact pairs that follow the sliding (docs/method.md section 11).

Two measurements:

- ``cost``: two P2 disks of the impact test (radius 20) hitting off-centre and sliding
  past each other (centres 36 apart sideways, moving at (-+2, -+0.3), in contact from
  t = 5.7 to 13; the case of tests/test_sliding.py), paired by closest points and
  followed (``follow=True``) against the same run paired once in the reference
  configuration (``follow=False``), one after the other in this process, in turns over
  the repeats. Per run: the DOFs, the median wall time of a contact step and of a free
  step, the Newton iterations per contact step, the pairings made; per mesh size, the
  median over the repeats of the ratio of the contact steps' medians (followed / once).
- ``search``: the time of one pairing (:meth:`~nitsche_dolfinx.contact.pairing.Pairing.pair`, in
  the reference configuration, the median of ``--repeat`` calls) against the number of
  slave nodes, for the balls (``--dim 3``; disks: 2) at several mesh sizes, with the
  exponent of a fit time ~ n^p (n log n gives p slightly above 1).

Written to ``OUT/sliding_cost.csv`` and ``OUT/sliding_search.csv``; printed as tables.

Usage::

    python benchmarks/sliding.py --mode cost --mesh-sizes 2 1.2 --repeat 3 --out out/sliding
    python benchmarks/sliding.py --mode search --mesh-sizes 8 4 2 --out out/sliding
"""

from __future__ import annotations

import argparse
import csv
import os
import time

import numpy as np
from mpi4py import MPI

from nitsche_dolfinx import HybridScheme, Simulation
from nitsche_dolfinx.cases import LOWER_BODY, UPPER_BODY, body_velocities, two_bodies_problem

VX, VY, OFFSET, DT, T_END = 2.0, 0.3, 36.0, 0.1, 14.0


def sliding_disks(mesh_size: float, follow: bool, dim: int = 2):
    problem, cells = two_bodies_problem(
        dim=dim, mesh_size=mesh_size, gap=1.0, along_axis=False, offset=OFFSET, follow=follow
    )
    velocity = np.zeros(dim)
    velocity[0], velocity[-1] = VX, VY
    velocities = {UPPER_BODY: -velocity, LOWER_BODY: velocity}
    problem.set_initial_conditions(velocity=body_velocities(problem, cells, velocities))
    return problem


def cost_run(mesh_size: float, follow: bool) -> dict:
    problem = sliding_disks(mesh_size, follow)
    simulation = Simulation(problem, HybridScheme(), dt=DT, t_end=T_END)
    start = time.perf_counter()
    history = simulation.run()
    loop = time.perf_counter() - start
    force = np.asarray(history["contact_force"])[1:]
    seconds = np.asarray(history["step_seconds"])[1:]
    newton = np.asarray(history["newton_iterations"])[1:]
    contact = force > 0
    return {
        "h": mesh_size,
        "follow": int(follow),
        "dofs": problem.V.dofmap.index_map.size_global * problem.V.dofmap.index_map_bs,
        "contact_steps": int(contact.sum()),
        "median_contact_step_s": float(np.median(seconds[contact])),
        "median_free_step_s": float(np.median(seconds[~contact])),
        "newton_per_contact_step": float(newton[contact].mean()),
        "pairings": problem.pairs[0].pairing.generation,
        "loop_s": loop,
    }


def search_run(mesh_size: float, repeat: int, dim: int) -> dict:
    problem = sliding_disks(mesh_size, follow=True, dim=dim)
    pairing = problem.pairs[0].pairing
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        pairing.pair()
        times.append(time.perf_counter() - start)
    nodes = problem.mesh.comm.allreduce(len(pairing._nodes), op=MPI.SUM)
    return {"h": mesh_size, "slave_nodes": nodes, "median_pairing_s": float(np.median(times))}


def write(path: str, rows: list[dict]) -> None:
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--mode", choices=("cost", "search"), default="cost")
    parser.add_argument("--mesh-sizes", type=float, nargs="+", default=[2.0, 1.2])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--dim", type=int, choices=(2, 3), default=3,
                        help="search: disks (2) or balls (3)")  # fmt: skip
    parser.add_argument("--out", default="out/sliding")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    root = MPI.COMM_WORLD.rank == 0
    if args.mode == "search":
        rows = [search_run(h, args.repeat, args.dim) for h in args.mesh_sizes]
        n = np.array([row["slave_nodes"] for row in rows], dtype=float)
        t = np.array([row["median_pairing_s"] for row in rows])
        exponent = np.polyfit(np.log(n), np.log(t), 1)[0] if len(rows) > 1 else float("nan")
        if root:
            for row in rows:
                print(f"h {row['h']:g}: {row['slave_nodes']} slave nodes, "
                      f"a pairing {1e3 * row['median_pairing_s']:.1f} ms")  # fmt: skip
            print(f"time ~ n^{exponent:.2f} (n log n over this range: "
                  f"n^{np.polyfit(np.log(n), np.log(n * np.log(n)), 1)[0]:.2f})")  # fmt: skip
            write(os.path.join(args.out, "sliding_search.csv"), rows)
        return
    rows = []
    for repeat in range(args.repeat):
        for h in args.mesh_sizes:
            order = (True, False) if repeat % 2 == 0 else (False, True)
            for follow in order:
                rows.append({"repeat": repeat, **cost_run(h, follow)})
    if not root:
        return
    write(os.path.join(args.out, "sliding_cost.csv"), rows)
    for h in args.mesh_sizes:
        ratios = []
        for repeat in range(args.repeat):
            pair = {r["follow"]: r for r in rows if r["repeat"] == repeat and r["h"] == h}
            ratios.append(pair[1]["median_contact_step_s"] / pair[0]["median_contact_step_s"])
        for follow in (1, 0):
            mine = [r for r in rows if r["h"] == h and r["follow"] == follow]
            print(
                f"h {h:g} ({mine[0]['dofs']} DOFs) {'followed' if follow else 'once    '}: "
                f"contact step {1e3 * np.median([r['median_contact_step_s'] for r in mine]):.1f}"
                f" ms, free step {1e3 * np.median([r['median_free_step_s'] for r in mine]):.1f}"
                f" ms, Newton {np.median([r['newton_per_contact_step'] for r in mine]):.2f}"
                f" a contact step, {mine[0]['pairings']} pairings"
            )
        print(f"h {h:g}: contact step followed / once = {np.median(ratios):.2f} "
              f"(median of {len(ratios)} repeats)")  # fmt: skip


if __name__ == "__main__":
    main()
