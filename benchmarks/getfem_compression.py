"""Finite deformations against GetFEM (issue 33): a neo-Hookean half ball pressed on a
rigid plane to 40% of its height, the force against the displacement computed by this
package and by GetFEM's large-deformation Nitsche contact, on the same mesh.

    python benchmarks/getfem_compression.py [--mesh-size 0.15] [--out out/getfem_compression]

The problem
-----------
The lower half of a ball of radius 1 (centre (0, 0, 1)) rests on the plane z = 0 with its
lowest point. Its flat face z = 1 is clamped to a rigid plate that moves down by d, in
steps of 0.025 up to 0.4 (quasi-static: each step is an equilibrium, solved by Newton from
the last one). Compressible neo-Hookean material (E = 1, nu = 0.3),
W = mu/2 (tr C - 3) - mu ln J + lambda/2 (ln J)^2, which is GetFEM's
``Compressible_Neo_Hookean_Bonet``. P2 displacements on the gmsh tetrahedra of the file
both codes read; quadrature of degree 5 in both (GetFEM's ``IM_TETRAHEDRON(5)``).

The contact terms
-----------------
- This package: :class:`~nitsche_dolfinx.contact.finite.FiniteContact` (docs/method.md
  section 15) through ``ContactProblem.operator``: the gap of x = X + u to the plane along
  its normal, sigma_n = (P N) . n_c, gamma_h = gamma0 h_T (h_T the largest distance between
  two vertices of the cell), Theta = 0 and Theta = 1.
- GetFEM: the rigid-obstacle term of its Nitsche large-sliding brick (raytracing
  transformation, the gap along the body's current normal ``Transformed_unit_vector``, the
  nominal traction (F S) N, ``Coulomb_friction_coupled_projection`` with f = 0), whose
  parameter is r = 1 / gamma_h: its ``element_size`` is not h_T, so r is given cell by cell
  to make the two gamma_h equal. GetFEM's variant is Theta = 0. The brick itself
  (``add_Nitsche_large_sliding_contact_brick_raytracing`` with a rigid obstacle) stops in
  GetFEM 5.4.2 with "No valid element for the transformation": its expression tests the
  rigid-obstacle term with the master surface's test function too, which has no element
  on an obstacle. The benchmark therefore adds the brick's rigid-obstacle term alone
  (``add_nonlinear_term``), as the brick writes it.
- The linear (small-strain) material on the same mesh, for scale: its force departs from
  the neo-Hookean one as the strains grow.
- The force: GetFEM's reaction on the plate (the multiplier of its clamping); here the
  contact force, the contact terms tested with e_z (equal at equilibrium).

GetFEM (``apt-get install python3-getfem``) runs in a process of its own. Prints the table
and writes ``getfem_compression.md``, ``.csv`` and ``.png`` (force against d) to OUT.
Serial; about four minutes at h = 0.15 (16,197 DOFs), most of it GetFEM's.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import subprocess
import sys

import numpy as np

E, NU = 1.0, 0.3
LAMBDA, MU = E * NU / ((1 + NU) * (1 - 2 * NU)), E / (2 * (1 + NU))
CONTACT, PLATE, VOLUME = 1, 2, 3  # physical groups of the mesh file


def write_mesh(path: str, mesh_size: float) -> None:
    """The half ball's gmsh file (format 2.2, which GetFEM reads)."""
    import gmsh

    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    occ = gmsh.model.occ
    ball = occ.addSphere(0.0, 0.0, 1.0, 1.0)
    upper = occ.addBox(-2.0, -2.0, 1.0, 4.0, 4.0, 2.0)
    volume, _ = occ.cut([(3, ball)], [(3, upper)])
    occ.synchronize()
    flat, curved = [], []
    for _, tag in gmsh.model.getBoundary(volume, oriented=False):
        z = occ.getCenterOfMass(2, tag)[2]
        (flat if abs(z - 1.0) < 1e-9 else curved).append(tag)
    gmsh.model.addPhysicalGroup(3, [volume[0][1]], VOLUME)
    gmsh.model.addPhysicalGroup(2, curved, CONTACT)
    gmsh.model.addPhysicalGroup(2, flat, PLATE)
    gmsh.option.setNumber("Mesh.CharacteristicLengthMax", mesh_size)
    gmsh.model.mesh.generate(3)
    gmsh.option.setNumber("Mesh.MshFileVersion", 2.2)
    gmsh.write(path)
    gmsh.finalize()


def getfem_forces(path: str, gamma0: float, depths) -> list[float]:
    """GetFEM's reaction on the plate at each depth (run in a process of its own)."""
    import getfem as gf

    m = gf.Mesh("import", "gmsh", path)
    mf = gf.MeshFem(m, 3)
    mf.set_classical_fem(2)
    mim = gf.MeshIm(m, gf.Integ("IM_TETRAHEDRON(5)"))
    md = gf.Model("real")
    md.add_fem_variable("u", mf)
    md.add_initialized_data("params", [LAMBDA, MU])
    md.add_finite_strain_elasticity_brick(mim, "u", "Compressible_Neo_Hookean_Bonet", "params")
    # r = 1 / gamma_h = element_size / (gamma0 h_T) in each cell, element_size being the
    # diameter GetFEM estimates (2 convex_radius)
    mf0 = gf.MeshFem(m, 1)
    mf0.set_classical_discontinuous_fem(0)
    r = np.zeros(mf0.nbdof())
    points = m.pts()
    for cell in range(m.nbcvs()):
        vertices = points[:, m.pid_from_cvid(cell)[0]]
        h = max(np.linalg.norm(vertices[:, i] - vertices[:, j]) for i in range(4) for j in range(i))
        r[mf0.basic_dof_from_cv(cell)[0]] = 2.0 * m.convex_radius(cell)[0] / (gamma0 * h)
    md.add_initialized_fem_data("r", mf0, r)
    md.add_raytracing_transformation("trans", 0.5)
    md.add_rigid_obstacle_to_raytracing_transformation("trans", "z", 3)
    md.add_slave_contact_boundary_to_raytracing_transformation("trans", m, "u", CONTACT)
    traction = "((Id(3)+Grad_u)*Compressible_Neo_Hookean_Bonet_PK2(Grad_u,params))*Normal"
    normal = "Transformed_unit_vector(Grad_u, Normal)"
    gap = f"(Interpolate(X,trans)-X-u).{normal}"
    projection = (
        f"Coulomb_friction_coupled_projection({traction}, {normal}, 0*u, {gap}, 0, r/element_size)"
    )
    md.add_nonlinear_term(mim, f"-Interpolate_filter(trans, {projection}.Test_u, 2)", CONTACT)
    md.add_initialized_data("plate", [0.0, 0.0, 0.0])
    md.add_Dirichlet_condition_with_multipliers(mim, "u", mf, PLATE, "plate")
    forces = []
    for d in depths:
        md.set_variable("plate", [0.0, 0.0, -d])
        md.solve("max_res", 1e-11, "max_iter", 50, "lsearch", "simplest")
        forces.append(float(gf.asm("generic", mim, 0, "mult_on_u(3)", PLATE, md)))
    return forces


def package_forces(path: str, gamma0: float, theta: float, depths, law="neo_hookean"):
    """This package's contact force, Newton iterations and contact radius (sqrt(A / pi),
    A the area in contact in the current configuration) at each depth."""
    import ufl
    from dolfinx import fem
    from mpi4py import MPI

    from nitsche_dolfinx import ContactProblem, Material, PlaneObstacle
    from nitsche_dolfinx.meshing import load_mesh
    from nitsche_dolfinx.solvers import SNESSolver

    mesh, facet_tags = load_mesh(path, comm=MPI.COMM_SELF)
    problem = ContactProblem(mesh, facet_tags, Material(E=E, nu=NU, law=law),
                             degree=2, gamma0=gamma0, nitsche_theta=theta,
                             quadrature_degree=5)  # fmt: skip
    contact = problem.add_obstacle(PlaneObstacle((0.0, 0.0, 0.0), (0.0, 0.0, 1.0)), CONTACT)
    V = problem.V
    u, plate, e_z = fem.Function(V), fem.Function(V), fem.Function(V)
    e_z.interpolate(lambda x: np.vstack([0 * x[0], 0 * x[0], 1 + 0 * x[0]]))
    clamped = fem.dirichletbc(plate, fem.locate_dofs_topological(V, 2, facet_tags.find(PLATE)))
    solver = SNESSolver(problem.operator(u, ufl.TestFunction(V)), u, [clamped],
                        petsc_options={"snes_rtol": 1e-11, "snes_max_it": 50})  # fmt: skip
    force = fem.form(contact.residual(u, e_z))
    area = fem.form(contact.current_area(u)) if problem.finite else None
    forces, iterations, radii = [], [], []
    for d in depths:
        plate.interpolate(lambda x, d=d: np.vstack([0 * x[0], 0 * x[0], -d + 0 * x[0]]))
        iterations.append(solver.solve())
        forces.append(abs(fem.assemble_scalar(force)))
        if area is not None:
            radii.append(np.sqrt(fem.assemble_scalar(area) / np.pi))
    dofs = V.dofmap.index_map.size_global * V.dofmap.index_map_bs
    return forces, iterations, radii, dofs


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mesh-size", type=float, default=0.15, help="largest cell size")
    parser.add_argument("--gamma0", type=float, default=1e-3, help="gamma_h = gamma0 h_T")
    parser.add_argument("--out", default="out/getfem_compression", help="output folder")
    parser.add_argument("--getfem-side", metavar="MSH", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    depths = [0.025 * k for k in range(1, 17)]
    if args.getfem_side:  # the GetFEM process
        print(json.dumps(getfem_forces(args.getfem_side, args.gamma0, depths)))
        return
    os.makedirs(args.out, exist_ok=True)
    path = os.path.join(args.out, "half_ball.msh")
    write_mesh(path, args.mesh_size)
    command = [sys.executable, __file__, "--getfem-side", path, "--gamma0", str(args.gamma0)]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or ["no output"])[-1]
        sys.exit(f"GetFEM's side failed ({last}); GetFEM: apt-get install python3-getfem")
    reference = json.loads(done.stdout.strip().splitlines()[-1])
    rows = [{"d": d, "F GetFEM": f} for d, f in zip(depths, reference)]
    for theta in (0.0, 1.0):
        forces, iterations, radii, dofs = package_forces(path, args.gamma0, theta, depths)
        for row, force, count, radius in zip(rows, forces, iterations, radii):
            row.setdefault("contact radius / R", radius)
            row[f"F Theta={theta:g}"] = force
            row[f"rel. diff Theta={theta:g}"] = abs(force - row["F GetFEM"]) / row["F GetFEM"]
            row[f"Newton Theta={theta:g}"] = count
    # small strains on the same mesh: how far the large-strain answer is from the linear one
    linear = package_forces(path, args.gamma0, 1.0, depths, "linear")[0]
    for row, force in zip(rows, linear):
        row["F linear / F GetFEM"] = force / row["F GetFEM"]
    from nitsche_dolfinx.post import markdown_table

    keys = list(rows[0])
    lines = [f"h = {args.mesh_size}, {dofs} DOFs, gamma0 = {args.gamma0}", "",
             markdown_table(keys, [[f"{v:.6g}" if isinstance(v, float) else str(v)
                                          for v in row.values()] for row in rows])]  # fmt: skip
    worst = max(row[f"rel. diff Theta={t:g}"] for row in rows for t in (0.0, 1.0))
    lines += ["", f"largest relative difference from GetFEM: {worst:.2e}"]
    print("\n".join(lines))
    with open(os.path.join(args.out, "getfem_compression.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    with open(os.path.join(args.out, "getfem_compression.csv"), "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=keys)
        writer.writeheader()
        writer.writerows(rows)
    figure(rows, os.path.join(args.out, "getfem_compression.png"))


def figure(rows, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5, 3.6))
    d = [row["d"] for row in rows]
    ax.plot(d, [row["F GetFEM"] for row in rows], "o", mfc="none", label="GetFEM")
    ax.plot(d, [row["F Theta=0"] for row in rows], "-", label="nitsche-dolfinx, Theta = 0")
    ax.plot(d, [row["F Theta=1"] for row in rows], "--", label="nitsche-dolfinx, Theta = 1")
    ax.set_xlabel("plate displacement d / R")
    ax.set_ylabel("force / (E R^2)")
    ax.set_title("neo-Hookean half ball pressed on a plane")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    main()
