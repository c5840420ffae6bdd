"""A few steps of the ball at one mesh size, to extrapolate a whole run without making it.

The talk's run (tau = 0.1, T = 40) has three kinds of steps: the fall (t < 10, a rigid
motion: the last acceleration is already the solution), the contact (about 19 time
units) and the flight after it (the ball vibrating). This script builds the ball at
``--mesh-size`` (hybrid scheme, the linear solver of ``--linear-solver``) and measures
``--steps`` steps of each kind from states of that kind:

- falling: the first steps of the run;
- contact: from the state of the fall 0.05 above the plane at speed 1 (the rigid fall
  arrives there at t = 9.95 with that velocity, so these are the run's first contact
  steps);
- flight: the last contact state moved 10 up, away from the plane, its velocity and
  acceleration kept (a vibrating ball in free flight).

It prints one JSON line: the set-up's seconds, the peak memory of the largest rank, and
for each kind the median seconds, Newton and Krylov iterations per step; then the time
loop of a run with ``--falling``, ``--contact`` and ``--flight`` steps of these costs
(the talk's run: 100, 192 and 108 steps, counted at h = 4 and 3)::

    mpirun -n 2 python benchmarks/ball_probe.py --mesh-size 0.86 --steps 5

The medians of a few steps on a shared machine: an estimate, not a measurement of the run.
"""

from __future__ import annotations

import argparse
import json
import resource
import time

import numpy as np
from mpi4py import MPI

from nitsche_dolfinx import Simulation, make_scheme
from nitsche_dolfinx.cases import impact_problem
from nitsche_dolfinx.solvers import LINEAR_SOLVERS

#: Height above the plane and speed of the rigid fall at the first contact state.
HEIGHT, GRAVITY = 0.05, 0.1


def timed_steps(simulation, steps: int) -> dict:
    """Make ``steps`` steps; their median seconds (max over ranks), Newton and Krylov
    iterations per step, and the largest contact force."""
    comm = simulation.comm
    seconds, newton, krylov, force = [], [], [], 0.0
    for _ in range(steps):
        comm.barrier()
        start = time.perf_counter()
        newton.append(simulation.step())
        seconds.append(comm.allreduce(time.perf_counter() - start, op=MPI.MAX))
        krylov.append(simulation.solver.snes.getLinearSolveIterations())
        force = max(force, simulation.state()["contact_force"])
    return {
        "median_step_s": float(np.median(seconds)),
        "newton_per_step": float(np.mean(newton)),
        "krylov_per_step": float(np.mean(krylov)),
        "contact_force": force,
    }


def set_rigid_state(simulation, height: float, velocity: float) -> None:
    """The ball translated: its bottom ``height`` above the plane, falling at ``velocity``,
    accelerated by gravity alone."""
    for function, value in (
        (simulation.u, height),
        (simulation.v, -velocity),
        (simulation.a, -GRAVITY),
    ):
        blocks = function.x.array.reshape(-1, 3)
        blocks[:] = 0.0
        blocks[:, 2] = value
        function.x.scatter_forward()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mesh-size", type=float, default=8.0)
    parser.add_argument("--steps", type=int, default=5, help="steps of each kind")
    parser.add_argument("--linear-solver", choices=list(LINEAR_SOLVERS), default="auto")
    parser.add_argument("--falling", type=int, default=100)
    parser.add_argument("--contact", type=int, default=192)
    parser.add_argument("--flight", type=int, default=108)
    args = parser.parse_args()

    comm = MPI.COMM_WORLD
    start = time.perf_counter()
    problem = impact_problem(dim=3, mesh_size=args.mesh_size, comm=comm)
    mesh_seconds = comm.allreduce(time.perf_counter() - start, op=MPI.MAX)
    simulation = Simulation(
        problem, make_scheme("hybrid"), dt=0.1, t_end=1e3, linear_solver=args.linear_solver
    )
    setup_seconds = comm.allreduce(time.perf_counter() - start, op=MPI.MAX) - mesh_seconds
    row = {"h": args.mesh_size, "ranks": comm.size, "dofs": simulation.dofs}
    row["linear_solver"] = simulation.solver_description
    row.update(mesh_s=mesh_seconds, setup_s=setup_seconds)
    row["falling"] = timed_steps(simulation, args.steps)
    set_rigid_state(simulation, HEIGHT, np.sqrt(1.0 - 2.0 * GRAVITY * HEIGHT))
    row["contact"] = timed_steps(simulation, args.steps)
    blocks = simulation.u.x.array.reshape(-1, 3)
    blocks[:, 2] += 10.0  # away from the plane: free flight, still vibrating
    simulation.u.x.scatter_forward()
    row["flight"] = timed_steps(simulation, args.steps)
    memory = comm.allreduce(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, op=MPI.MAX)
    row["peak_memory_mb"] = memory / 1024.0
    counts = {"falling": args.falling, "contact": args.contact, "flight": args.flight}
    row["estimated_loop_s"] = sum(n * row[kind]["median_step_s"] for kind, n in counts.items())
    if comm.rank == 0:
        print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()
