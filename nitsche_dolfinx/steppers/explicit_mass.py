"""The mass the explicit Verlet steps divide by (docs/method.md section 12).

- :class:`DiagonalMass`: the lumped mass (P1 row sums, P2 HRZ) or the redistributed one;
  a division a dof.
- :class:`ConsistentMass`: the consistent mass, one conjugate-gradient solve a step,
  preconditioned by its diagonal (the mass matrix is well conditioned whatever the mesh
  size: a few tens of iterations).
- :class:`MasslessNodes`: with the redistributed mass, the nodes of Gamma_C carry no mass.
  Their displacement is not stepped: at each level it makes their own rows of the force
  zero, a quasi-static equilibrium of those nodes with the contact (docs/method.md section
  12), solved by semismooth Newton on those rows alone.

Each mass gives ``a = M^-1 F`` with ``a = 0`` at the dofs without an acceleration of
their own (Dirichlet, massless), ``M x`` and the start of the stable-step estimate.
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc

from ..common import compat
from ..physics.mass import density
from ..solvers.linear_solvers import direct_options, has_mumps
from ..solvers.solver import SolverError

__all__ = [
    "ConsistentMass",
    "DiagonalMass",
    "MasslessNodes",
    "MasslessNotConverged",
    "explicit_mass",
    "unit_density_mass",
]

#: The consistent mass's conjugate gradients: relative residual, iterations.
CG_RTOL, CG_MAX_IT = 1e-12, 1000
#: The massless nodes' Newton: largest number of iterations; it stops at a residual of their
#: rows below MASSLESS_RTOL times the largest elastic force |K u|, or after a correction
#: below MASSLESS_STEP_RTOL times the largest displacement (the force is piecewise affine
#: in u: once the contact status is right, a step lands on the solution to round-off, so
#: the next correction is round-off, whatever the size of K u; a body at rest has none).
MASSLESS_MAX_IT, MASSLESS_RTOL, MASSLESS_STEP_RTOL = 50, 1e-10, 1e-12


class DiagonalMass:
    """A diagonal mass (lumped or redistributed), ``diagonal`` a PETSc vector with ghosts;
    ``fixed`` the local dofs without an acceleration of their own (Dirichlet)."""

    def __init__(self, diagonal: PETSc.Vec, fixed: np.ndarray):
        with diagonal.localForm() as local:
            self.diagonal = local.array.copy()
        self.inverse = np.zeros_like(self.diagonal)
        massive = self.diagonal > 0
        self.inverse[massive] = 1.0 / self.diagonal[massive]
        self.inverse[fixed] = 0.0

    def divide(self, force: PETSc.Vec, a: fem.Function) -> None:
        """``a`` = M^-1 ``force`` (its ghosts up to date), ghosts included."""
        with force.localForm() as local:
            a.x.array[:] = local.array * self.inverse

    def mult(self, x: PETSc.Vec, y: PETSc.Vec) -> None:
        """y = M x (owned entries)."""
        n = x.getLocalSize()
        np.multiply(self.diagonal[:n], x.array_r, out=y.array_w)

    def solve(self, x: PETSc.Vec, y: PETSc.Vec) -> None:
        """y = M^-1 x (owned entries; zero at the dofs without acceleration)."""
        n = x.getLocalSize()
        y.array[:] = self.inverse[:n] * x.array

    def start_scaling(self, n: int) -> np.ndarray:
        """The power iterations' start is a smooth function of x times this (owned): the
        iterations then run as on the symmetric M^-1/2 K M^-1/2 from that function."""
        return np.sqrt(self.inverse[:n])

    def destroy(self) -> None:
        """Nothing to free: the diagonal is a NumPy array."""


class ConsistentMass:
    """The consistent mass ``int rho u . v`` on ``V``, solved by CG with Jacobi; its rows
    and columns of the ``fixed`` dofs (local, Dirichlet) replaced by the identity, so that
    their acceleration is zero."""

    def __init__(self, V, rho, fixed: np.ndarray):
        u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
        form = fem.form(density(V.mesh, rho) * ufl.inner(u, v) * ufl.dx)
        self.matrix = compat.create_matrix(form)
        fem_petsc.assemble_matrix(self.matrix, form)
        self.matrix.assemble()
        bs = V.dofmap.index_map_bs
        n = V.dofmap.index_map.size_local * bs
        self._fixed = fixed[fixed < n]
        rows = (self._fixed + V.dofmap.index_map.local_range[0] * bs).astype(PETSc.IntType)
        self._solving = self.matrix.duplicate(copy=True)
        self._solving.zeroRowsColumns(rows, diag=1.0)
        ksp = self.ksp = PETSc.KSP().create(V.mesh.comm)
        ksp.setOperators(self._solving)
        ksp.setType("cg")
        ksp.getPC().setType("jacobi")
        ksp.setTolerances(rtol=CG_RTOL, atol=0.0, max_it=CG_MAX_IT)
        ksp.setErrorIfNotConverged(True)
        self._rhs, self._solution = self._solving.createVecs()

    def divide(self, force: PETSc.Vec, a: fem.Function) -> None:
        """``a`` = M^-1 ``force`` by :meth:`solve`, ghosts included."""
        self.solve(force, self._solution)
        n = self._solution.getLocalSize()
        a.x.array[:n] = self._solution.array_r
        a.x.scatter_forward()

    def mult(self, x: PETSc.Vec, y: PETSc.Vec) -> None:
        """y = M x (owned entries) by the mass as assembled (not the identity at the fixed
        dofs)."""
        self.matrix.mult(x, y)

    def solve(self, x: PETSc.Vec, y: PETSc.Vec) -> None:
        """y = M^-1 x (owned entries; zero at the fixed dofs) by conjugate gradients to a
        relative residual of 1e-12; PETSc raises an error if they do not converge."""
        n = x.getLocalSize()
        self._rhs.array[:] = x.array_r[:n]
        self._rhs.array[self._fixed] = 0.0
        self.ksp.solve(self._rhs, y)

    def start_scaling(self, n: int) -> np.ndarray:
        """One at each of the ``n`` owned dofs, zero at the fixed ones: the power
        iterations start from the smooth function itself."""
        scaling = np.ones(n)
        scaling[self._fixed] = 0.0
        return scaling

    def destroy(self) -> None:
        """Free the PETSc objects (collective)."""
        for obj in (self.ksp, self._solving, self.matrix, self._rhs, self._solution):
            obj.destroy()


def explicit_mass(problem, fixed: np.ndarray):
    """The mass the steps of ``problem`` divide by: consistent (CG), or its diagonal
    (lumped, redistributed); ``fixed`` the local dofs without an acceleration of their own."""
    if problem.mass == "consistent":
        return ConsistentMass(problem.V, problem.material_constants.rho, fixed)
    return DiagonalMass(problem.mass_diagonal(), fixed)


def unit_density_mass(problem, fixed: np.ndarray):
    """The mass of density 1 of the problem's kind (diagonal, or consistent)."""
    if problem.mass == "consistent":
        return ConsistentMass(problem.V, 1.0, fixed)
    return DiagonalMass(problem.mass_matrix.of_unit_density().diagonal(), fixed)


class MasslessNotConverged(SolverError):
    """The massless nodes' Newton did not converge (a smaller step gives it a better start)."""

    def __init__(self, iterations: int, residual: float):
        super().__init__(0, iterations, residual)
        self.reason_name = "MASSLESS_NEWTON"

    def _message(self) -> str:
        where = "" if self.step is None else f"at step {self.step} (t = {self.t:.6g}): "
        return (
            f"{where}the equilibrium of the massless contact nodes did not converge in "
            f"{self.iterations} Newton iterations (residual {self.residual_norm:.6e})"
        )


class MasslessNodes:
    """The dofs without mass of the redistributed mass, not prescribed: their rows of the
    force F(u) = L - K u - C(u) are solved for their displacement, the others fixed.

    Args:
        problem: The :class:`~nitsche_dolfinx.model.problem.ContactProblem`.
        u: The displacement the force is assembled at.
        contact_forces: The UFL form of the contact's force terms C(u) (linear in the test
            function), whose derivative in ``u`` is assembled at each Newton iteration.
        stiffness: The matrix K of the affine terms.
        fixed: Local dofs that are prescribed (Dirichlet).
    """

    def __init__(self, problem, u: fem.Function, contact_forces, stiffness: PETSc.Mat,
                 fixed: np.ndarray):  # fmt: skip
        V, comm = problem.V, problem.mesh.comm
        self.u = u
        bs = V.dofmap.index_map_bs
        n = V.dofmap.index_map.size_local * bs
        local = np.setdiff1d(problem.massless_dofs(), fixed)
        self.dofs = local[local < n].astype(np.int32)  # owned
        #: whether any rank has massless dofs
        self.active = comm.allreduce(self.dofs.size) > 0
        #: the local massless dofs, ghosts included (none when no rank has any): their
        #: velocity is a backward difference
        self.local = local if self.active else local[:0]
        if not self.active:
            return
        rows = PETSc.IS().createGeneral(
            (self.dofs + V.dofmap.index_map.local_range[0] * bs).astype(PETSc.IntType), comm
        )
        self._rows = rows
        general = stiffness.convert("aij", PETSc.Mat())  # blocked: blocked index sets only
        self._stiffness = general.createSubMatrix(rows, rows)
        general.destroy()
        du = ufl.TrialFunction(V)
        self._jacobian_form = fem.form(ufl.derivative(contact_forces, u, du))
        self._contact = compat.create_matrix(self._jacobian_form)
        self._jacobian = self._stiffness.duplicate(copy=True)
        self._contact_rows = None
        self.ksp = PETSc.KSP().create(comm)
        if comm.size == 1 or has_mumps(comm):
            options = direct_options(comm)
            self.ksp.setType(options["ksp_type"])
            self.ksp.getPC().setType(options["pc_type"])
            if "pc_factor_mat_solver_type" in options:
                self.ksp.getPC().setFactorSolverType(options["pc_factor_mat_solver_type"])
        else:  # no parallel LU: GMRES with block Jacobi, to round-off
            self.ksp.setType("gmres")
            self.ksp.getPC().setType("bjacobi")
            self.ksp.setTolerances(rtol=1e-14, atol=0.0, max_it=1000)
        self._residual, self._delta = self._stiffness.createVecs()
        self.comm = comm
        self.iterations = 0
        #: the Jacobians factorised so far (one per change of the contact status)
        self.factorisations = 0
        self._factored = None  # the values of C'(u)_cc in the factorised Jacobian

    def solve(self, force) -> PETSc.Vec:
        """Newton on the massless rows, from the current ``u``; ``force()`` assembles F(u)
        (ghosts up to date) and returns it with the elastic force K u. Returns the last F."""
        F, Ku = force()
        correction = np.inf
        for iteration in range(MASSLESS_MAX_IT + 1):
            residual = F.array_r[self.dofs]
            mine = np.array([np.abs(residual).max(initial=0.0),
                             np.abs(Ku.array_r).max(initial=0.0),
                             correction, np.abs(self.u.x.array).max(initial=0.0)])  # fmt: skip
            largest = np.empty(4)
            self.comm.Allreduce(mine, largest, op=MPI.MAX)
            if (largest[0] <= MASSLESS_RTOL * largest[1]
                    or largest[2] <= MASSLESS_STEP_RTOL * largest[3]):  # fmt: skip
                self.iterations = iteration
                return F
            if iteration == MASSLESS_MAX_IT:
                break
            correction = self._newton_update(residual)
            F, Ku = force()
        raise MasslessNotConverged(MASSLESS_MAX_IT, float(largest[0]))

    def _newton_update(self, residual: np.ndarray) -> float:
        """(K + C'(u))_cc delta = F_c, u_c += delta; returns this rank's largest |delta|."""
        contact = self._contact
        contact.zeroEntries()
        fem_petsc.assemble_matrix(contact, self._jacobian_form)
        contact.assemble()
        self._contact_rows = contact.createSubMatrix(self._rows, self._rows, self._contact_rows)
        if self._status_changed():  # else the factorisation of the last status serves
            self._stiffness.copy(self._jacobian, structure=PETSc.Mat.Structure.SAME)
            # C's pattern (the cells on Gamma_C) lies within K's
            self._jacobian.axpy(1.0, self._contact_rows, structure=PETSc.Mat.Structure.SUBSET)
            self.ksp.setOperators(self._jacobian)
            self.factorisations += 1
        self._residual.array[:] = residual
        self.ksp.solve(self._residual, self._delta)
        delta = self._delta.array_r
        self.u.x.array[self.dofs] += delta
        self.u.x.scatter_forward()
        return float(np.abs(delta).max(initial=0.0))

    def _status_changed(self) -> bool:
        """Whether C'(u)_cc differs from that of the last factorised Jacobian. C' depends
        on u only through the contact status of each quadrature point (the force is
        piecewise affine), so the same status assembles the same values to the bit."""
        values = self._contact_rows.getValuesCSR()[2]
        mine = self._factored is None or not np.array_equal(values, self._factored)
        if self.comm.allreduce(mine, op=MPI.LOR):
            self._factored = values.copy()
            return True
        return False

    def destroy(self) -> None:
        """Free the PETSc objects, if any rank has massless dofs (collective)."""
        if self.active:
            objects = [self.ksp, self._rows, self._stiffness, self._contact, self._jacobian,
                       self._residual, self._delta, self._contact_rows]  # fmt: skip
            for obj in objects:
                if obj is not None:
                    obj.destroy()
