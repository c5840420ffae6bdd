"""Solving: a solver's PETSc options under its prefix (`options`), the linear-solver presets
(`linear_solvers`), PETSc's SNES (`petsc_snes`), the Newton policy (`newton`) and the Newton
solve with its fallbacks (`solver`).
"""

from .linear_solvers import (
    AUTO_CONTACT_STIFFNESS,
    AUTO_COURANT,
    LINEAR_SOLVERS,
    LinearSolver,
    choose_linear_solver,
    contact_stiffness,
    courant_number,
    direct_options,
    has_mumps,
    linear_solver,
)
from .petsc_snes import SolverSettings
from .solver import SNESSolver, SolverError

__all__ = [
    "AUTO_CONTACT_STIFFNESS",
    "AUTO_COURANT",
    "LINEAR_SOLVERS",
    "LinearSolver",
    "SNESSolver",
    "SolverError",
    "SolverSettings",
    "choose_linear_solver",
    "contact_stiffness",
    "courant_number",
    "direct_options",
    "has_mumps",
    "linear_solver",
]
