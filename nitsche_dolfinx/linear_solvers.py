"""Named linear-solver presets for the step's Newton iterations (docs/method.md section 8).

``Simulation(..., linear_solver="cg-jacobi")`` (and the demos' ``--linear-solver``
flag) picks one; ``petsc_options`` given with it win over the preset's. ``"auto"``
chooses one from the problem and the time step (:func:`choose_linear_solver`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from mpi4py import MPI

from . import compat
from .parameters import require_choice

__all__ = [
    "AUTO_COURANT",
    "AUTO_GAMG_DOFS",
    "LINEAR_SOLVERS",
    "LinearSolver",
    "choose_linear_solver",
    "courant_number",
    "linear_solver",
]

#: The presets: name -> what it is.
LINEAR_SOLVERS = {
    "auto": "cg-jacobi when tau is below the time a pressure wave takes to cross the "
    "smallest cell (the mass dominates the Jacobian) and the Jacobian is symmetric; "
    "else lu, or algebraic multigrid (cg-gamg, gmres-gamg) on large meshes",
    "lu": "a direct factorisation at every change of the Jacobian (MUMPS when PETSc has "
    "it; its LDL^T when the Jacobian is symmetric: Theta = 1 without friction)",
    "lu-lagged": "the last factorisation as GMRES preconditioner, renewed past 10 iterations",
    "cg-jacobi": "conjugate gradients with the diagonal as preconditioner: nothing to set up "
    "when the contact set changes (symmetric Jacobians, small tau)",
    "cg-gamg": "conjugate gradients, algebraic multigrid with the rigid-body near-nullspace",
    "gmres-gamg": "GMRES, algebraic multigrid with the rigid-body near-nullspace",
}

#: ``"auto"`` takes cg-jacobi up to this Courant number c tau / h_min (measured on the
#: ball, docs/method.md section 8: about 13 iterations per free step up to 1, 375 at 3).
AUTO_COURANT = 1.0
#: Beyond the Courant number above, ``"auto"`` takes cg-gamg from this many DOFs (lu below).
AUTO_GAMG_DOFS = 200_000

#: The Krylov options: the residual's norm unpreconditioned, as Newton's; the tolerances
#: follow Newton's (:class:`~nitsche_dolfinx.solver.SNESSolver`, docs/method.md section 8).
_KRYLOV_OPTIONS = {"ksp_norm_type": "unpreconditioned", "ksp_max_it": 1000}


@dataclass(frozen=True)
class LinearSolver:
    """A preset: PETSc options, the preconditioner lag of
    :class:`~nitsche_dolfinx.solver.SNESSolver`, whether algebraic multigrid needs the
    rigid-body near-nullspace, and a description for summaries."""

    name: str
    petsc_options: dict[str, Any] = field(default_factory=dict)
    preconditioner_lag: int = 0
    near_nullspace: bool = False
    description: str = ""


def linear_solver(name: str, comm, problem=None, dt: float | None = None) -> LinearSolver:
    """The preset ``name`` (a key of :data:`LINEAR_SOLVERS`) on the communicator ``comm``.

    The direct presets only choose the factorisation package. The Krylov presets solve
    as inexactly as Newton allows (docs/method.md section 8). ``"auto"``
    needs the ``problem`` and the time step ``dt`` (see :func:`choose_linear_solver`).
    """
    require_choice(name, LINEAR_SOLVERS, "linear_solver", "linear solver")
    if name == "auto":
        if problem is None or dt is None:
            raise ValueError("linear_solver='auto' needs the problem and the time step")
        chosen = linear_solver(choose_linear_solver(problem, dt), comm)
        return LinearSolver(
            chosen.name,
            chosen.petsc_options,
            chosen.preconditioner_lag,
            chosen.near_nullspace,
            f"auto: {chosen.description}",
        )
    if name in ("lu", "lu-lagged"):
        mumps = compat.has_mumps(comm)
        options = {"pc_factor_mat_solver_type": "mumps"} if mumps else {}
        package = "MUMPS" if mumps else "PETSc's own LU, serial only"
        if name == "lu":
            return LinearSolver(name, options, description=f"lu ({package})")
        return LinearSolver(name, options, 10, description=f"lu-lagged ({package}, GMRES, lag 10)")
    if name == "cg-jacobi":  # 3 x 3 blocks: products about three times faster than AIJ
        options = {"ksp_type": "cg", "pc_type": "jacobi", "mat_type": "baij", **_KRYLOV_OPTIONS}
        return LinearSolver(name, options, description="cg-jacobi (diagonal preconditioner)")
    options = {"ksp_type": name.split("-")[0], "pc_type": "gamg", **_KRYLOV_OPTIONS}
    if name == "gmres-gamg":  # right preconditioning: GMRES then minimises the true residual
        options["ksp_pc_side"] = "right"
    return LinearSolver(name, options, 0, True, f"{name} (rigid-body near-nullspace)")


def courant_number(problem, dt: float) -> float:
    """c tau / h_min: the time step over the time a pressure wave, of speed
    c = sqrt((lambda + 2 mu) / rho), takes to cross the smallest cell (h_T its largest
    vertex distance; collective). Below about 1 the mass dominates the step's Jacobian."""
    material = problem.material
    speed = math.sqrt((material.lmbda + 2.0 * material.mu) / material.rho)
    comm = problem.mesh.comm
    local = problem.h.x.array
    h_min = comm.allreduce(float(local.min()) if local.size else math.inf, op=MPI.MIN)
    return speed * float(dt) / h_min


def choose_linear_solver(problem, dt: float) -> str:
    """The preset ``"auto"`` stands for (docs/method.md section 8; collective).

    cg-jacobi when the Jacobian is symmetric and positive definite with the mass
    dominating it: Nitsche or penalty with Theta = 1, no friction, every node with mass
    (not the redistributed mass), and :func:`courant_number` at most
    :data:`AUTO_COURANT`. Otherwise lu, or from :data:`AUTO_GAMG_DOFS` DOFs on
    (except for the mixed method) cg-gamg, gmres-gamg for a non-symmetric Jacobian.
    """
    massive = problem.mass != "redistributed"
    if problem.method != "mixed" and problem.symmetric_jacobian and massive:
        if courant_number(problem, dt) <= AUTO_COURANT:
            return "cg-jacobi"
    if problem.method == "mixed":
        return "lu"  # a saddle point: no multigrid of ours for it
    index_map = problem.V.dofmap.index_map
    if index_map.size_global * problem.V.dofmap.index_map_bs < AUTO_GAMG_DOFS:
        return "lu"
    return "cg-gamg" if problem.symmetric_jacobian else "gmres-gamg"
