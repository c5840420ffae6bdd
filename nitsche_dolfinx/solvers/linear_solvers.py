"""Named linear-solver presets for the step's Newton iterations (docs/method.md section 8).

``Simulation(..., linear_solver="cg-jacobi")`` (and the demos' ``--linear-solver``
flag) picks one; ``petsc_options`` given with it win over the preset's. ``"auto"``
chooses one from the problem and the time step (:func:`choose_linear_solver`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc

from ..common import compat
from ..common.parameters import require_choice

__all__ = [
    "AUTO_CONTACT_STIFFNESS",
    "AUTO_COURANT",
    "AUTO_GAMG_DOFS",
    "LINEAR_SOLVERS",
    "LinearSolver",
    "choose_linear_solver",
    "contact_stiffness",
    "courant_number",
    "direct_options",
    "linear_solver",
    "rigid_body_modes",
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
#: ... and up to this contact stiffness tau^2 / (rho gamma_h h) (:func:`contact_stiffness`;
#: measured, docs/method.md section 8: on the disk cg-jacobi gives lu's history to 2e-11
#: at 10, 2e-9 at 62 and 1e-7 at 625; two bars at 2.5e5 differ by 5e-4).
AUTO_CONTACT_STIFFNESS = 100.0
#: Beyond the Courant number above, ``"auto"`` takes cg-gamg from this many DOFs (lu below).
AUTO_GAMG_DOFS = 200_000

#: The Krylov options: the residual's norm unpreconditioned, as Newton's; the tolerances
#: follow Newton's (:class:`~nitsche_dolfinx.solvers.newton.InexactSolves`, docs/method.md section
#: 8).
_KRYLOV_OPTIONS = {"ksp_norm_type": "unpreconditioned", "ksp_max_it": 1000}
#: GMRES on a lagged factorisation (``preconditioner_lag`` > 0): right preconditioning, so
#: that it minimises the true residual, to a tight tolerance of its own.
LAGGED_OPTIONS = {
    "ksp_type": "gmres",
    "ksp_pc_side": "right",
    "ksp_max_it": 200,
    "ksp_rtol": 1e-12,
    "ksp_atol": 1e-14,
}
_MUMPS: dict = {}


def has_mumps(comm) -> bool:
    """Whether PETSc factorises with MUMPS (asked once per process)."""
    if "found" not in _MUMPS:
        _MUMPS["found"] = compat.has_mumps(comm)
    return _MUMPS["found"]


def direct_options(comm) -> dict[str, Any]:
    """The default linear solver, a direct LU: one factorisation, one solve (MUMPS's where
    PETSc has it: it is parallel, and uses the BLAS)."""
    options = {"ksp_type": "preonly", "pc_type": "lu"}
    if has_mumps(comm):
        options["pc_factor_mat_solver_type"] = "mumps"
    return options


@dataclass(frozen=True)
class LinearSolver:
    """A preset: PETSc options beyond the default direct solve (:func:`direct_options`), the
    preconditioner lag (> 0: GMRES preconditioned by the last factorisation, renewed when a
    solve needs more iterations than the lag), whether algebraic multigrid needs the
    rigid-body near-nullspace (:meth:`near_nullspace_of`), and a description for
    summaries."""

    name: str
    petsc_options: dict[str, Any] = field(default_factory=dict)
    preconditioner_lag: int = 0
    near_nullspace: bool = False
    description: str = ""

    def near_nullspace_of(self, V) -> PETSc.NullSpace | None:
        """The near-nullspace of a Jacobian on ``V``: the rigid-body modes when the preset
        asks for it and ``V`` is a displacement space (None otherwise)."""
        if not self.near_nullspace or V.dofmap.index_map_bs != V.mesh.geometry.dim:
            return None
        return PETSc.NullSpace().create(vectors=rigid_body_modes(V), comm=V.mesh.comm)


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
    if name in ("lu", "lu-lagged"):  # the default direct solve (direct_options)
        package = "MUMPS" if has_mumps(comm) else "PETSc's own LU, serial only"
        if name == "lu":
            return LinearSolver(name, description=f"lu ({package})")
        return LinearSolver(name, {}, 10, description=f"lu-lagged ({package}, GMRES, lag 10)")
    if name == "cg-jacobi":  # 3 x 3 blocks: products about three times faster than AIJ
        options = {"ksp_type": "cg", "pc_type": "jacobi", "mat_type": "baij", **_KRYLOV_OPTIONS}
        return LinearSolver(name, options, description="cg-jacobi (diagonal preconditioner)")
    options = {"ksp_type": name.split("-")[0], "pc_type": "gamg", **_KRYLOV_OPTIONS}
    if name == "gmres-gamg":  # right preconditioning: GMRES then minimises the true residual
        options["ksp_pc_side"] = "right"
    return LinearSolver(name, options, 0, True, f"{name} (rigid-body near-nullspace)")


def _smallest_cell(problem) -> float:
    """h_min, the smallest h_T (largest vertex distance of a cell) over all ranks."""
    local = problem.h.x.array
    return problem.mesh.comm.allreduce(float(local.min()) if local.size else math.inf, MPI.MIN)


def courant_number(problem, dt: float) -> float:
    """c tau / h_min: the time step over the time a pressure wave, of speed
    c = sqrt((lambda + 2 mu) / rho) (the fastest material's), takes to cross the smallest
    cell (h_T its largest vertex distance; collective). Below about 1 the mass dominates
    the step's Jacobian. With stiffness damping beta the Jacobian weighs the stiffness by
    tau^2 + 2 beta tau instead of tau^2 (Crank-Nicolson and hybrid: tau^2/4 K + beta tau/2 K;
    docs/method.md section 14): tau is then sqrt(tau^2 + 2 beta tau)."""
    speed = max(math.sqrt((m.lmbda + 2.0 * m.mu) / m.rho) for m in problem.materials)
    dt = float(dt)
    if problem.damping is not None and problem.damping.values[1] > 0.0:
        dt = math.sqrt(dt * dt + 2.0 * problem.damping.values[1] * dt)
    return speed * dt / _smallest_cell(problem)


def contact_stiffness(problem, dt: float) -> float:
    """tau^2 / (rho gamma_h h) on the smallest cell: the contact terms of the step's
    Jacobian, about (tau^2 / gamma_h) h^(d-1) on a contact node, against its mass
    rho h^d (collective; 0 without contact). Large, the contact rows dominate the
    Jacobian and the scale of the step's equation, and a Krylov solve to Newton's
    tolerance no longer gives a direct solve's states."""
    if not problem.contacts:
        return 0.0
    h_min = _smallest_cell(problem)
    gamma_h = float(np.asarray(problem.gamma0.value)) * h_min

    def stiffness(material) -> float:  # the largest over the materials
        scaled = gamma_h / material.E if problem.gamma0_scaling == "E" else gamma_h
        return float(dt) ** 2 / (material.rho * scaled * h_min)

    return max(stiffness(material) for material in problem.materials)


def choose_linear_solver(problem, dt: float) -> str:
    """The preset ``"auto"`` stands for (docs/method.md section 8; collective).

    cg-jacobi when the Jacobian is symmetric and positive definite with the mass
    dominating it: Nitsche or penalty with Theta = 1, no friction, every node with mass
    (not the redistributed mass), :func:`courant_number` at most :data:`AUTO_COURANT`
    and :func:`contact_stiffness` at most :data:`AUTO_CONTACT_STIFFNESS`. Otherwise
    lu, or from :data:`AUTO_GAMG_DOFS` DOFs on (except for the mixed method) cg-gamg,
    gmres-gamg for a non-symmetric Jacobian.
    """
    massive = problem.mass != "redistributed"
    if problem.method != "mixed" and problem.symmetric_jacobian and massive:
        soft = contact_stiffness(problem, dt) <= AUTO_CONTACT_STIFFNESS
        if soft and courant_number(problem, dt) <= AUTO_COURANT:
            return "cg-jacobi"
    if problem.method == "mixed":
        return "lu"  # a saddle point: no multigrid of ours for it
    index_map = problem.V.dofmap.index_map
    if index_map.size_global * problem.V.dofmap.index_map_bs < AUTO_GAMG_DOFS:
        return "lu"
    return "cg-gamg" if problem.symmetric_jacobian else "gmres-gamg"


def rigid_body_modes(V) -> list[PETSc.Vec]:
    """The rigid motions on the vector space ``V`` as orthonormal PETSc vectors.

    gdim translations and the rotations about the coordinate axes: one in 2D,
    three in 3D. Interpolation is exact for these linear fields, also on curved cells.
    """
    gdim = V.mesh.geometry.dim

    def translation(i):
        return lambda x: np.stack([np.full(x.shape[1], float(j == i)) for j in range(gdim)])

    def zero(x):
        return np.zeros(x.shape[1])

    modes = [translation(i) for i in range(gdim)]
    if gdim == 2:
        modes.append(lambda x: np.stack((-x[1], x[0])))
    else:
        modes.append(lambda x: np.stack((-x[1], x[0], zero(x))))
        modes.append(lambda x: np.stack((zero(x), -x[2], x[1])))
        modes.append(lambda x: np.stack((x[2], zero(x), -x[0])))
    function = fem.Function(V)
    vectors = []
    for mode in modes:
        function.interpolate(mode)
        vector = compat.petsc_vector(function).copy()
        for other in vectors:  # Gram-Schmidt
            vector.axpy(-vector.dot(other), other)
        vector.normalize()
        vectors.append(vector)
    return vectors
