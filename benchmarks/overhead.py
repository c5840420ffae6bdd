"""The package's per-step overhead on a small problem: the bar's time loop next to a minimal
dolfinx loop of the same scheme, with the same SNES and the same direct solver, in one run.

    python benchmarks/overhead.py [--repeat 5] [--t-end 9] [--out out/overhead]

The problem is the talk's 1D bar (docs/method.md section 5: 100 P1 cells, tau = 0.015,
Theta = 1, gamma0 = 1e-6, the hybrid scheme). Each repeat times, in turn, the package's
time loop (``Simulation.run`` with the bar demo's history columns, written to a CSV file)
and a minimal loop written here with dolfinx alone: the hybrid scheme's residual in UFL,
SNES (newtonls, full steps, snes_rtol 1e-10) with the residual and the Jacobian assembled
in full at each call, the package's direct solver for this problem (MUMPS's LDL^T where
PETSc has MUMPS: the same factorisation, so that the loops differ by their bookkeeping),
the energies E and E_Theta assembled each step, the same columns written to a CSV file.
Set-up (meshes, forms, the initial acceleration) is not timed.

Prints and writes ``OUT/overhead.csv`` (one row per repeat and loop: seconds, steps,
Newton iterations, ms per step) and ``OUT/summary.csv``: the median time of each loop, the
median of the ratios package / minimal taken in each repeat, and the largest difference
of the two histories (they solve the same equations with other convergence tests: they
agree to the Newton tolerance, not to the bit).
"""

from __future__ import annotations

import argparse
import csv
import os
import statistics
import sys
import time

import numpy as np
import ufl
from dolfinx import fem
from dolfinx import mesh as dmesh
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc

from nitsche_dolfinx import HybridScheme, Simulation
from nitsche_dolfinx.cases import BAR_COLUMNS, add_bar_probes, bar_simulation
from nitsche_dolfinx.common import compat
from nitsche_dolfinx.solvers import SolverSettings

NX, DT, GAMMA0, THETA = 100, 0.015, 1e-6, 1.0


class MinimalBar:
    """The bar by the hybrid scheme in plain dolfinx (see the module docstring)."""

    def __init__(self, comm, t_end: float, petsc_options=None):
        self.t_end = t_end
        mesh = dmesh.create_interval(comm, NX, [0.0, 1.0])
        V = self.V = compat.function_space(mesh, "Lagrange", 1, (1,))
        self.w, self.u, self.v, self.a = (fem.Function(V) for _ in range(4))
        wall = dmesh.locate_entities_boundary(mesh, 0, lambda x: np.isclose(x[0], 0.0))
        clamp = dmesh.locate_entities_boundary(mesh, 0, lambda x: np.isclose(x[0], 1.0))
        tags = dmesh.meshtags(mesh, 0, wall, np.full(len(wall), 1, dtype=np.int32))
        self.dx = ufl.Measure("dx", domain=mesh, metadata={"quadrature_degree": 2})
        ds = ufl.Measure("ds", domain=mesh, subdomain_data=tags, metadata={"quadrature_degree": 2})
        self.ds = ds(1)
        wall_dofs = fem.locate_dofs_topological(V, 0, wall)
        self.dofs_wall = wall_dofs[wall_dofs < V.dofmap.index_map.size_local]  # owned
        self.bcs = [fem.dirichletbc(fem.Function(V), fem.locate_dofs_topological(V, 0, clamp))]
        self.gamma_h = GAMMA0 * fem.Constant(mesh, 1.0 / NX)
        self.n, self.n_c = ufl.FacetNormal(mesh), fem.Constant(mesh, np.array([-1.0]))
        self.x_0 = ufl.SpatialCoordinate(mesh)[0]
        self._forms(fem.Constant(mesh, DT))
        self._snes(comm, petsc_options)
        # u0 = 1/2 - x/2, v0 = 0 and M a0 = -A_Theta(u0, .) (no contact at t = 0)
        self.u.interpolate(lambda x: 0.5 - x[0] / 2)
        phi = ufl.TestFunction(V)
        stiffness = ufl.inner(ufl.grad(self.u), ufl.grad(phi)) * self.dx
        stiffness -= THETA * self.gamma_h * self._sigma_n(self.u) * self._sigma_n(phi) * self.ds
        self._initial(mesh, self.dx, -stiffness, phi)

    def _sigma_n(self, u):
        """sigma_n(u) = (sigma(u) n) . n_c with sigma(u) = E grad u, E = 1."""
        return ufl.dot(ufl.dot(ufl.grad(u), self.n), self.n_c)

    def _P(self, u):
        """P_gamma(u) = u . n_c - g - gamma_h sigma_n(u), with g = x."""
        return ufl.dot(u, self.n_c) - self.x_0 - self.gamma_h * self._sigma_n(u)

    def _forms(self, dt) -> None:
        """The step's residual and Jacobian, the energies and the contact pressure."""

        def positive(y):
            return ufl.conditional(ufl.gt(y, 0), y, 0)

        w, u, v, P, gamma_h, dx, ds = (
            self.w,
            self.u,
            self.v,
            self._P,
            self.gamma_h,
            self.dx,
            self.ds,
        )
        phi = ufl.TestFunction(self.V)
        u1 = u + dt * v + dt**2 / 2 * w
        mid = (u + u1) / 2
        force = ufl.conditional(
            ufl.gt(P(u), 0), positive(P(mid)), (positive(P(u)) + positive(P(u1))) / 2
        )
        test = ufl.dot(phi, self.n_c) - THETA * gamma_h * self._sigma_n(phi)
        F = (
            ufl.inner(w, phi) * dx
            + ufl.inner(ufl.grad(mid), ufl.grad(phi)) * dx
            - THETA * gamma_h * self._sigma_n(mid) * self._sigma_n(phi) * ds
            + force / gamma_h * test * ds
        )
        self.F = fem.form(F)
        self.J = fem.form(ufl.derivative(F, w, ufl.TrialFunction(self.V)))
        energy = 0.5 * ufl.inner(v, v) * dx + 0.5 * ufl.inner(ufl.grad(u), ufl.grad(u)) * dx
        correction = gamma_h * self._sigma_n(u) ** 2 - positive(P(u)) ** 2 / gamma_h
        self.energy = fem.form(energy)
        self.correction = fem.form(-THETA / 2 * correction * ds)
        self.pressure = fem.form(-positive(P(u)) / gamma_h * ds)

    def _snes(self, comm, petsc_options) -> None:
        """SNES with the residual and the Jacobian assembled in full at each call."""
        self.A = fem_petsc.create_matrix(self.J)
        self.b, self.x = compat.create_vector(self.V), compat.create_vector(self.V)
        self.snes = PETSc.SNES().create(comm)
        self.snes.setFunction(self._residual, self.b)
        self.snes.setJacobian(self._jacobian, self.A)
        options = {
            "snes_type": "newtonls", "snes_linesearch_type": "basic", "snes_rtol": 1e-10,
            "snes_stol": 0.0, "snes_max_it": 50, "snes_divergence_tolerance": 1e300,
        }  # fmt: skip
        # the same direct solver as the package's for this problem (symmetric: Theta = 1)
        package = SolverSettings(comm, petsc_options, symmetric=True).options.options
        options.update({k: v for k, v in package.items() if k.startswith(("ksp_", "pc_"))})
        database = PETSc.Options()
        self.snes.setOptionsPrefix("overhead_minimal_")
        for key, value in options.items():
            database[f"overhead_minimal_{key}"] = value
        self.snes.setFromOptions()
        for key in options:
            database.delValue(f"overhead_minimal_{key}")

    def _initial(self, mesh, dx, rhs, phi) -> None:
        """Solve M a = rhs, a = 0 at the clamped end."""
        trial = ufl.TrialFunction(self.V)
        M = fem_petsc.assemble_matrix(fem.form(ufl.inner(trial, phi) * dx), self.bcs)
        M.assemble()
        rhs = fem_petsc.assemble_vector(fem.form(rhs))
        rhs.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        compat.set_bc(rhs, self.bcs)
        ksp = PETSc.KSP().create(mesh.comm)
        ksp.setOperators(M)
        ksp.setType("preonly")
        ksp.getPC().setType("lu")
        ksp.solve(rhs, compat.petsc_vector(self.a))
        self.a.x.scatter_forward()
        ksp.destroy()

    def _residual(self, snes, x, b) -> None:
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        x.copy(compat.petsc_vector(self.w))
        self.w.x.scatter_forward()
        with b.localForm() as local:
            local.set(0.0)
        fem_petsc.assemble_vector(b, self.F)
        compat.apply_lifting(b, self.J, self.bcs, x, -1.0)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        compat.set_bc(b, self.bcs, x, -1.0)

    def _jacobian(self, snes, x, A, P) -> None:
        A.zeroEntries()
        fem_petsc.assemble_matrix(A, self.J, self.bcs)
        A.assemble()

    def _row(self, t: float, comm, iterations: int) -> list:
        u0 = self.u.x.array[self.dofs_wall].sum() if len(self.dofs_wall) else 0.0
        v0 = self.v.x.array[self.dofs_wall].sum() if len(self.dofs_wall) else 0.0
        local = [u0, v0] + [fem.assemble_scalar(f) for f in (self.pressure, self.energy)]
        local.append(fem.assemble_scalar(self.correction))
        u0, v0, pressure, energy, correction = comm.allreduce(np.array(local), op=MPI.SUM)
        return [t, u0, v0, pressure, energy, energy + correction, iterations]

    def run(self, path: str) -> tuple[float, list]:
        """The time loop; returns its seconds and the rows written to ``path``."""
        comm = self.V.mesh.comm
        u, v, a, w = (f.x.array for f in (self.u, self.v, self.a, self.w))
        steps = round(self.t_end / DT)
        start = time.perf_counter()
        rows = [self._row(0.0, comm, 0)]
        with open(path, "w") if comm.rank == 0 else open(os.devnull, "w") as out:
            out.write(",".join(BAR_COLUMNS) + "\n")
            out.write(",".join(repr(float(x)) for x in rows[-1]) + "\n")
            for n in range(1, steps + 1):
                w[:] = a
                compat.petsc_vector(self.w).copy(self.x)
                self.snes.solve(None, self.x)
                if self.snes.getConvergedReason() <= 0:
                    reason = self.snes.getConvergedReason()
                    raise RuntimeError(f"the minimal loop's SNES failed at step {n}: {reason}")
                self.x.copy(compat.petsc_vector(self.w))
                self.w.x.scatter_forward()
                u1 = u + DT * v + DT**2 / 2 * w
                v1 = v + DT * w
                a[:] = 2 * w - a
                u[:], v[:] = u1, v1
                rows.append(self._row(n * DT, comm, self.snes.getIterationNumber()))
                out.write(",".join(repr(float(x)) for x in rows[-1]) + "\n")
                out.flush()
        return time.perf_counter() - start, rows


def package_loop(comm, t_end: float, path: str, petsc_options=None) -> tuple[float, list, object]:
    """The package's bar (``cases.bar_simulation``, as ``demos/bar_1d.py`` runs it), its
    history written to ``path/history.csv``."""
    simulation = bar_simulation(HybridScheme(), dt=DT, t_end=t_end, comm=comm, gamma0=GAMMA0)
    if petsc_options:  # (the probes are the bar's: a new simulation of the same problem)
        simulation = Simulation(
            simulation.problem, HybridScheme(), dt=DT, t_end=t_end, petsc_options=petsc_options
        )
        add_bar_probes(simulation)
    start = time.perf_counter()
    history = simulation.run(out=path, columns=BAR_COLUMNS)
    seconds = time.perf_counter() - start
    rows = [[row[name] for name in BAR_COLUMNS] for row in history]
    return seconds, rows, simulation


def measure(comm, args, options) -> tuple[list, list, float]:
    """``args.repeat`` pairs of loops, in turn: rows (repeat, loop, seconds, steps, Newton
    iterations, ms per step), the ratios package / minimal, and the largest difference of
    their histories relative to each column's largest value."""
    records, ratios, difference = [], [], 0.0
    for repeat in range(args.repeat):
        minimal = MinimalBar(comm, args.t_end, options)
        seconds, rows, simulation = package_loop(comm, args.t_end, args.out, options)
        minimal_seconds, minimal_rows = minimal.run(os.path.join(args.out, "minimal.csv"))
        steps = len(rows) - 1
        for name, s, r in (("package", seconds, rows), ("minimal", minimal_seconds, minimal_rows)):
            newton = sum(row[-1] for row in r[1:])
            records.append([repeat, name, s, steps, newton, 1e3 * s / steps])
        ratios.append(seconds / minimal_seconds)
        ours, theirs = np.array(rows, dtype=float), np.array(minimal_rows, dtype=float)
        scale = np.abs(theirs[:, 1:6]).max(axis=0)
        difference = max(difference, float((np.abs(ours[:, 1:6] - theirs[:, 1:6]) / scale).max()))
        simulation.solver.destroy()
        if comm.rank == 0:
            print(
                f"repeat {repeat}: package {seconds:.3f} s, minimal {minimal_seconds:.3f} s "
                f"({steps} steps), ratio {ratios[-1]:.2f}",
                flush=True,
            )
    return records, ratios, difference


def write(out: str, records: list, summary: dict) -> None:
    """``out/overhead.csv`` and ``out/summary.csv``, and the summary printed."""
    with open(os.path.join(out, "overhead.csv"), "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["repeat", "loop", "seconds", "steps", "newton", "ms_per_step"])
        writer.writerows(records)
    with open(os.path.join(out, "summary.csv"), "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(summary)
        writer.writerow(summary.values())
    print(
        f"median time loop: package {summary['package_median_s']:.3f} s "
        f"({summary['package_ms_per_step']:.3f} ms a step), minimal "
        f"{summary['minimal_median_s']:.3f} s ({summary['minimal_ms_per_step']:.3f} ms a "
        f"step); median ratio {summary['median_ratio']:.2f}; histories agree to "
        f"{summary['largest_relative_difference']:.1e} of each column's largest value"
    )


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=5, help="pairs of loops, in turn")
    parser.add_argument("--t-end", type=float, default=9.0, help="final time (600 steps)")
    parser.add_argument("--out", default=os.path.join("out", "overhead"))
    parser.add_argument(
        "--factorisation",
        choices=["package", "petsc"],
        default="package",
        help="package: both loops factorise as the package does for this problem (MUMPS's "
        "LDL^T where PETSc has MUMPS); petsc: both with PETSc's own LU",
    )
    args = parser.parse_args(argv)
    options = None
    if args.factorisation == "petsc":
        options = {"pc_type": "lu", "pc_factor_mat_solver_type": "petsc"}
    comm = MPI.COMM_WORLD
    if comm.rank == 0:
        os.makedirs(args.out, exist_ok=True)
    comm.barrier()
    records, ratios, difference = measure(comm, args, options)
    package = statistics.median(r[2] for r in records if r[1] == "package")
    minimal = statistics.median(r[2] for r in records if r[1] == "minimal")
    steps = records[0][3]
    summary = {
        "factorisation": args.factorisation,
        "ranks": comm.size,
        "steps": steps,
        "package_median_s": package,
        "minimal_median_s": minimal,
        "package_ms_per_step": 1e3 * package / steps,
        "minimal_ms_per_step": 1e3 * minimal / steps,
        "median_ratio": statistics.median(ratios),
        "largest_relative_difference": difference,
    }
    if comm.rank == 0:
        write(args.out, records, summary)
    return 0


if __name__ == "__main__":
    sys.exit(main())
