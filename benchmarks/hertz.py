"""A ball's impact on a rigid plane at small speed against Hertz's theory (issue 33): the
linear ball and the hyperelastic ones, same mesh, same step.

    python benchmarks/hertz.py [--laws linear neo_hookean svk] [--out out/hertz]

The problem
-----------
A ball of radius R = 1 (E = 1, nu = 0.3, rho = 1) touches the plane z = 0 with its lowest
point at t = 0 and moves down at speed V. Hertz's quasi-static theory of a sphere on a
rigid plane (E* = E / (1 - nu^2), mass m) gives the largest approach
alpha = (15 m V^2 / (16 E* sqrt(R)))^(2/5), the contact time 2.94 alpha / V and the peak
force 4/3 E* sqrt(R) alpha^(3/2). V is chosen for ``--approach`` alpha / R (default 0.01:
contact radius 0.1 R, V = 1.7e-3, mean strains of a few per cent, a contact ten times
longer than a wave's transit of the ball, so that the impact is nearly quasi-static).

The mesh (gmsh, second-order tetrahedra, nodes on the sphere) is the quarter x, y >= 0 of
the ball, with the conditions of symmetry u_x = 0 on x = 0 and u_y = 0 on y = 0 (the
force reported is four times the quarter's), refined near the lowest point: cells of
``--h-min`` within 0.15 of it, growing to 0.25. P2, the hybrid scheme with
Theta = 1, gamma0 = 1e-3, ``--steps`` steps over 1.15 times Hertz's contact time.

Reported per law: the contact time (to the last step in contact, the force's decrease
over its last two steps taken on to zero) and the peak force (the largest of the
steps'), their errors against Hertz, and the difference of the peak force from the
linear ball's. Writes ``hertz.md`` and ``hertz.csv`` (with the force histories) to OUT.
Serial, about 8 minutes; most of it goes to the hyperelastic runs, which assemble the
full Jacobian at every Newton iteration.
"""

from __future__ import annotations

import argparse
import csv
import math
import os

import numpy as np
from mpi4py import MPI

from nitsche_dolfinx import ContactProblem, Material, PlaneObstacle, Simulation, make_scheme
from nitsche_dolfinx.meshing import load_mesh
from nitsche_dolfinx.post import markdown_table

E, NU, RHO, R = 1.0, 0.3, 1.0, 1.0
SURFACE, X_PLANE, Y_PLANE, VOLUME = 1, 2, 3, 4  # physical groups of the mesh file


def write_mesh(path: str, h_min: float, h_max: float = 0.25, reach: float = 0.15) -> None:
    """The quarter x, y >= 0 of the ball of centre (0, 0, R), with cells of h_min within
    ``reach`` of its lowest point."""
    import gmsh

    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    occ = gmsh.model.occ
    sphere = occ.addSphere(0.0, 0.0, R, R)
    quarter = occ.addBox(0.0, 0.0, -R, 2 * R, 2 * R, 4 * R)
    (volume,), _ = occ.intersect([(3, sphere)], [(3, quarter)])
    lowest = occ.addPoint(0.0, 0.0, 0.0)
    occ.synchronize()
    ball = volume[1]
    faces = {SURFACE: [], X_PLANE: [], Y_PLANE: []}
    for _, tag in gmsh.model.getBoundary([volume], oriented=False):
        x, y, _ = occ.getCenterOfMass(2, tag)
        faces[X_PLANE if abs(x) < 1e-9 else Y_PLANE if abs(y) < 1e-9 else SURFACE].append(tag)
    field = gmsh.model.mesh.field
    field.add("Distance", 1)
    field.setNumbers(1, "PointsList", [lowest])
    field.add("Threshold", 2)
    for key, value in (("InField", 1), ("SizeMin", h_min), ("SizeMax", h_max),
                       ("DistMin", reach), ("DistMax", 4 * reach)):  # fmt: skip
        field.setNumber(2, key, value)
    field.setAsBackgroundMesh(2)
    for option in ("MeshSizeExtendFromBoundary", "MeshSizeFromPoints", "MeshSizeFromCurvature"):
        gmsh.option.setNumber(f"Mesh.{option}", 0)
    gmsh.model.addPhysicalGroup(3, [ball], VOLUME)
    for group, tags in faces.items():
        gmsh.model.addPhysicalGroup(2, tags, group)
    gmsh.model.mesh.generate(3)
    gmsh.model.mesh.setOrder(2)
    gmsh.write(path)
    gmsh.finalize()


def hertz(approach: float) -> dict:
    """Hertz's impact of the ball for a largest approach ``approach`` R."""
    e_star = E / (1 - NU**2)
    mass = RHO * 4 / 3 * math.pi * R**3
    alpha = approach * R
    speed = math.sqrt(alpha**2.5 * 16 * e_star * math.sqrt(R) / (15 * mass))
    return {"speed": speed, "contact time": 2.94 * alpha / speed,
            "peak force": 4 / 3 * e_star * math.sqrt(R) * alpha**1.5}  # fmt: skip


def contact_time(t: np.ndarray, force: np.ndarray) -> float:
    """The time from t = 0 (the first touch) to the end of the contact, the force's
    decrease over its last two steps in contact taken on to zero (within one step)."""
    last = np.flatnonzero(force > 0)[-1]
    step = t[last] - t[last - 1]
    fall = force[last - 1] - force[last]
    extra = step if fall <= force[last] else step * force[last] / fall
    return float(t[last] + extra)


def run(mesh, tags, law: str, speed: float, dt: float, t_end: float):
    problem = ContactProblem(mesh, tags, Material(E=E, nu=NU, rho=RHO, law=law), degree=2,
                             gamma0=1e-3)  # fmt: skip
    problem.add_obstacle(PlaneObstacle((0.0, 0.0, 0.0), (0.0, 0.0, 1.0)), SURFACE)
    problem.add_dirichlet(X_PLANE, 0.0, component=0)  # the planes of symmetry
    problem.add_dirichlet(Y_PLANE, 0.0, component=1)
    problem.set_initial_conditions(velocity=[0.0, 0.0, -speed])
    simulation = Simulation(problem, make_scheme("hybrid"), dt=dt, t_end=t_end)
    columns = ("t", "contact_force", "newton_iterations")
    rows = list(simulation.run(columns=columns))
    dofs = problem.V.dofmap.index_map.size_global * problem.V.dofmap.index_map_bs
    values = {key: np.array([row[key] for row in rows]) for key in columns}
    values["contact_force"] = 4 * values["contact_force"]  # the whole ball's
    return values, dofs


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--laws", nargs="+", default=["linear", "neo_hookean", "svk"])
    parser.add_argument("--approach", type=float, default=0.01, help="Hertz's alpha / R")
    parser.add_argument("--h-min", type=float, default=0.03, help="cell size near contact")
    parser.add_argument("--steps", type=int, default=60, help="steps of the run")
    parser.add_argument("--out", default="out/hertz", help="output folder")
    args = parser.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    path = os.path.join(args.out, "ball.msh")
    write_mesh(path, args.h_min)
    mesh, tags = load_mesh(path, comm=MPI.COMM_SELF)
    theory = hertz(args.approach)
    t_end = 1.15 * theory["contact time"]
    dt = t_end / args.steps
    rows, histories = [], {}
    for law in args.laws:
        values, dofs = run(mesh, tags, law, theory["speed"], dt, t_end)
        force = values["contact_force"]
        histories[law] = force
        row = {"law": law, "contact time": contact_time(values["t"], force),
               "peak force": force.max(),
               "Newton mean": values["newton_iterations"][1:].mean()}  # fmt: skip
        row["time error"] = row["contact time"] / theory["contact time"] - 1
        row["force error"] = row["peak force"] / theory["peak force"] - 1
        rows.append(row)
        print(f"{law}: {dofs} DOFs, " + ", ".join(f"{k} {v:.4g}" for k, v in list(row.items())[1:]),
              flush=True)  # fmt: skip
    if "linear" in histories:
        for row in rows:
            row["peak vs linear"] = row["peak force"] / histories["linear"].max() - 1
    lines = [f"Hertz: V = {theory['speed']:.4g}, contact time {theory['contact time']:.4g}, "
             f"peak force {theory['peak force']:.4g}; {dofs} DOFs, tau = {dt:.4g}", "",
             markdown_table(list(rows[0]), [[f"{v:.4g}" if isinstance(v, float) else str(v)
                                          for v in row.values()] for row in rows])]  # fmt: skip
    print("\n".join(lines))
    with open(os.path.join(args.out, "hertz.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    with open(os.path.join(args.out, "hertz.csv"), "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["time", *(f"contact_force {law}" for law in histories)])
        times = dt * np.arange(len(next(iter(histories.values()))))
        writer.writerows(zip(times, *histories.values()))


if __name__ == "__main__":
    main()
