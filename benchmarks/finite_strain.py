"""Finite deformations (issue 33): the energy-consistent step against the midpoint rule
over 1,000 steps of free flight, the small-strain limit of the contact force, and E_Theta
through repeated impacts.

    python benchmarks/finite_strain.py [--steps 1000] [--out out/finite_strain]

What it measures
----------------
- **free flight**: a unit square (4 x 4 x 2 P2 triangles, plane strain, E = 1, nu = 0.3,
  rho = 1), neo-Hookean, thrown spinning at 0.5 rad/s and stretching, no obstacle, no
  load; ``--steps`` steps of tau = 0.05 with the hybrid scheme (the averaged stress of
  docs/method.md section 15) and with the midpoint rule (P at u^{n+1/2}), Newton to
  snes_rtol = 1e-13. Reported: max |E - E0| / E0, the largest stored energy over E0 (how
  far from a rigid motion), and the largest change of each momentum.
- **small strains**: a P2 block 1 x 1 (6 x 6 cells) falling flat at speed V on rigid
  ground, linear and St Venant-Kirchhoff, tau = 0.02, 30 steps; the largest difference of
  their contact forces over V, relative to the linear peak, for V = 1e-2, 1e-3, 1e-4
  (strains about V / 7.7).
- **repeated impacts**: the talk's disk (h = 4, P1, straight cells), neo-Hookean,
  Theta = 1, dropped under gravity, 400 steps of 0.1 (it bounces 3 times): the largest
  one-step rise of E_Theta over E_Theta(0), the impacts, Newton's iterations.

Prints the table and writes ``finite_strain.md`` and ``finite_strain.csv`` to OUT. Serial;
about a minute.
"""

from __future__ import annotations

import argparse
import csv
import os

import numpy as np
from dolfinx import mesh as dmesh
from mpi4py import MPI

from nitsche_dolfinx import ContactProblem, Material, PlaneObstacle, Simulation, make_scheme
from nitsche_dolfinx.cases import impact_problem
from nitsche_dolfinx.meshing import OnPlane, tag_facets
from nitsche_dolfinx.output import HISTORY_COLUMNS, angular_momentum_columns

MOMENTA = ("momentum_x", "momentum_y", *angular_momentum_columns(2))


class MidpointProblem(ContactProblem):
    """The midpoint rule's bulk term P(u^{n+1/2}), for comparison."""

    def hybrid_operator(self, u_old, u_new, v, velocity=None, reference=None):
        return self.bulk_stiffness((u_old + u_new) / 2, v)


def spinning_square(cls) -> ContactProblem:
    mesh = dmesh.create_unit_square(MPI.COMM_SELF, 4, 4)
    problem = cls(mesh, None, Material(E=1.0, nu=0.3, law="neo_hookean"), degree=2)

    def velocity(x):
        return np.vstack([-0.5 * (x[1] - 0.5) + 0.3 * (x[0] - 0.5),
                          0.5 * (x[0] - 0.5) - 0.2 * (x[1] - 0.5) ** 2])  # fmt: skip

    problem.set_initial_conditions(velocity=velocity)
    return problem


def columns_of(problem, steps: int, dt: float, columns, petsc=None) -> dict:
    simulation = Simulation(problem, make_scheme("hybrid"), dt=dt, t_end=steps * dt,
                            petsc_options=petsc)  # fmt: skip
    rows = list(simulation.run(columns=columns))
    return {key: np.array([row[key] for row in rows]) for key in columns}


def free_flight(steps: int) -> list[dict]:
    rows = []
    for name, cls in (("averaged stress", ContactProblem), ("midpoint rule", MidpointProblem)):
        values = columns_of(spinning_square(cls), steps, 0.05, (*HISTORY_COLUMNS, *MOMENTA),
                            {"snes_rtol": 1e-13})  # fmt: skip
        E = values["energy"]
        row = {"case": f"free flight, {name}", "steps": steps,
               "max |E - E0| / E0": np.max(np.abs(E - E[0])) / E[0],
               "max W / E0": np.max(values["elastic"]) / E[0]}  # fmt: skip
        for key in MOMENTA:
            row[f"max |d {key}|"] = np.max(np.abs(values[key] - values[key][0]))
        rows.append(row)
    return rows


def block_force(law: str, speed: float) -> np.ndarray:
    mesh = dmesh.create_rectangle(MPI.COMM_SELF, [[-0.5, 0.0], [0.5, 1.0]], [6, 6])
    tags = tag_facets(mesh, {1: OnPlane([0.0, 0.0], [0.0, 1.0])})
    problem = ContactProblem(mesh, tags, Material.from_lame(20.0, 20.0, law=law), degree=2,
                             gamma0=1e-3)  # fmt: skip
    problem.add_obstacle(PlaneObstacle([0.0, 0.0], [0.0, 1.0]), 1)
    problem.set_initial_conditions(velocity=[0.0, -speed])
    return columns_of(problem, 30, 0.02, HISTORY_COLUMNS)["contact_force"] / speed


def small_strains() -> list[dict]:
    linear = block_force("linear", 1e-3)
    rows = []
    for speed in (1e-2, 1e-3, 1e-4):
        difference = np.max(np.abs(block_force("svk", speed) - linear)) / linear.max()
        rows.append({"case": f"small strains, V = {speed:g}", "strain ~ V / c": speed / 7.75,
                     "max |F_svk - F_lin| / max F_lin": difference})  # fmt: skip
    return rows


def repeated_impacts() -> list[dict]:
    problem = impact_problem(dim=2, mesh_size=4.0, degree=1, geometry_order=1, law="neo_hookean",
                             comm=MPI.COMM_SELF)  # fmt: skip
    values = columns_of(problem, 400, 0.1, HISTORY_COLUMNS)
    force, energy = values["contact_force"], values["energy_theta"]
    impacts = int(np.sum((force[1:] > 0) & (force[:-1] == 0)))
    iterations = values["newton_iterations"][1:]
    return [{"case": "repeated impacts, Theta = 1", "impacts": impacts,
             "max rise of E_Theta / E_Theta(0)": np.max(np.diff(energy)) / energy[0],
             "Newton mean": iterations.mean(), "Newton max": int(iterations.max())}]  # fmt: skip


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=1000, help="free-flight steps")
    parser.add_argument("--out", default="out/finite_strain", help="output folder")
    args = parser.parse_args(argv)
    rows = [*free_flight(args.steps), *small_strains(), *repeated_impacts()]
    os.makedirs(args.out, exist_ok=True)
    lines = []
    for row in rows:
        text = "; ".join(f"{key} {value:.3g}" if isinstance(value, float) else f"{key} {value}"
                         for key, value in row.items())  # fmt: skip
        lines.append(f"- {text}")
    print("\n".join(lines))
    with open(os.path.join(args.out, "finite_strain.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    keys = list(dict.fromkeys(key for row in rows for key in row))
    with open(os.path.join(args.out, "finite_strain.csv"), "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=keys)
        writer.writeheader()
        writer.writerows(rows)


if __name__ == "__main__":
    main()
