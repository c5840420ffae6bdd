"""Named linear-solver presets for the step's Newton iterations (docs/method.md section 8).

``Simulation(..., linear_solver="cg-gamg")`` (and the demos' ``--linear-solver``
flag) picks one; ``petsc_options`` given with it win over the preset's.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from . import compat
from .parameters import require_choice

__all__ = ["LINEAR_SOLVERS", "LinearSolver", "linear_solver"]

#: The presets: name -> what it is.
LINEAR_SOLVERS = {
    "lu": "a direct factorisation at every change of the Jacobian (MUMPS when PETSc has "
    "it; its LDL^T when the Jacobian is symmetric: Theta = 1 without friction)",
    "lu-lagged": "the last factorisation as GMRES preconditioner, renewed past 10 iterations",
    "cg-gamg": "conjugate gradients, algebraic multigrid with the rigid-body near-nullspace",
    "gmres-gamg": "GMRES, algebraic multigrid with the rigid-body near-nullspace",
}


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


def linear_solver(name: str, comm) -> LinearSolver:
    """The preset ``name`` (a key of :data:`LINEAR_SOLVERS`) on the communicator ``comm``.

    The library's default is Newton with one direct LU solve per iteration; the
    direct presets only choose the factorisation package. The Krylov presets solve
    to a relative tolerance of 1e-12, so that Newton converges as with LU.
    """
    require_choice(name, LINEAR_SOLVERS, "linear_solver", "linear solver")
    if name in ("lu", "lu-lagged"):
        mumps = compat.has_mumps(comm)
        options = {"pc_factor_mat_solver_type": "mumps"} if mumps else {}
        package = "MUMPS" if mumps else "PETSc's own LU, serial only"
        if name == "lu":
            return LinearSolver(name, options, description=f"lu ({package})")
        return LinearSolver(name, options, 10, description=f"lu-lagged ({package}, GMRES, lag 10)")
    options = {
        "ksp_type": name.split("-")[0],
        "ksp_rtol": 1e-12,
        "ksp_atol": 1e-14,
        "ksp_max_it": 1000,
        "pc_type": "gamg",
    }
    return LinearSolver(name, options, 0, True, f"{name} (rigid-body near-nullspace)")
