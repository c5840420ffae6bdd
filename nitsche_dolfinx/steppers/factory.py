"""The stepper of a problem and its scheme, and the linear solver of its steps: what
:class:`~nitsche_dolfinx.simulation.Simulation` builds before a run. An explicit scheme
is stepped by :class:`~nitsche_dolfinx.steppers.explicit.ExplicitStepper`, the mixed
method by :class:`~nitsche_dolfinx.steppers.mixed.MixedStepper`, Nitsche's and the
penalty method by :class:`~nitsche_dolfinx.steppers.implicit.NitscheStepper`.
"""

from __future__ import annotations

from typing import Any

from ..common.parameters import TimeStepping
from ..model.problem import ContactProblem
from ..solvers.linear_solvers import LinearSolver, linear_solver
from .base import Stepper
from .explicit import ExplicitStepper
from .implicit import NitscheStepper
from .mixed import MixedStepper
from .schemes import TimeScheme

__all__ = ["make_stepper", "step_linear_solver"]


def step_linear_solver(
    problem: ContactProblem, scheme: TimeScheme, dt, preset: str | None,
    petsc_options: dict[str, Any] | None = None, preconditioner_lag: int = 0,
) -> LinearSolver:  # fmt: skip
    """The linear solver of the steps (see the ``linear_solver`` argument of
    :class:`~nitsche_dolfinx.simulation.Simulation`): none for an explicit scheme; the
    default direct solve with the user's options when ``preset`` is None, or ``"auto"``
    while ``petsc_options`` name a ``ksp_type`` or ``pc_type`` or ``preconditioner_lag`` is
    given (the solver is then the user's); else the preset
    (:func:`~nitsche_dolfinx.solvers.linear_solvers.linear_solver`)."""
    chosen = {"ksp_type", "pc_type"} & set(petsc_options or {}) or preconditioner_lag
    if preset == "auto" and chosen:
        preset = None  # the user chose the linear solver: no preset
    if scheme.explicit:
        return LinearSolver("none", {}, 0, description="none (explicit)")
    if preset is None:  # the default direct solve with the user's options
        return LinearSolver("default", {}, int(preconditioner_lag), description="default")
    return linear_solver(preset, problem.mesh.comm, problem, dt)


def make_stepper(
    problem: ContactProblem, scheme: TimeScheme, time_stepping: TimeStepping,
    petsc_options: dict[str, Any] | None = None, solver: LinearSolver | None = None,
    reuse_jacobian: bool = True, guard_friction: bool = True,
) -> Stepper:  # fmt: skip
    """The stepper of ``problem`` by ``scheme`` (the arguments are those of
    :class:`~nitsche_dolfinx.simulation.Simulation`, ``solver`` from
    :func:`step_linear_solver`)."""
    if scheme.explicit:
        return ExplicitStepper(problem, scheme, time_stepping)
    if problem.method == "mixed":
        return MixedStepper(problem, scheme, time_stepping, petsc_options, solver)
    return NitscheStepper(
        problem, scheme, time_stepping, petsc_options, solver, reuse_jacobian, guard_friction
    )
