"""The Newton policy of a step's solve (docs/method.md section 8): when Newton has
converged, and how exactly each linear solve must be solved on the way.

- :data:`NEWTON_OPTIONS`: Newton with a full step, the semismooth Newton of the talk;
- :class:`ConvergenceTest`: ||F|| below a tolerance that follows the scale of the step's
  equation, or an iterate exact up to round-off, or no progress (cycling);
- :class:`InexactSolves`: the tolerances of the Krylov solves of a Newton solve.

What a failed solve means (a line search, smaller steps) is decided by the callers:
:class:`~nitsche_dolfinx.solvers.solver.SNESSolver` and the time loop of
:class:`~nitsche_dolfinx.simulation.Simulation`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from petsc4py import PETSc

__all__ = ["NEWTON_OPTIONS", "ConvergenceTest", "InexactSolves"]

#: Newton with a full step: the semismooth Newton of the talk (its linear solver is the
#: solver's, a direct LU by default). ``snes_rtol`` is relative to the scale of the step's
#: equation (:class:`ConvergenceTest`); ``snes_atol`` is not set: an absolute tolerance has
#: units, and one that suits a problem in scaled units is below the round-off of the same
#: problem in SI units (a user's ``snes_atol`` is still obeyed).
NEWTON_OPTIONS: dict[str, Any] = {
    "snes_type": "newtonls",
    "snes_linesearch_type": "basic",
    "snes_rtol": 1.0e-10,
    "snes_stol": 0.0,
    "snes_max_it": 50,
}

_SMALLEST = float(np.finfo(float).tiny)  # an absolute tolerance that 0 passes and no norm


class InexactSolves:
    """When the Krylov solve of a Newton iteration may stop (docs/method.md section 8).

    The unpreconditioned residual r = F + J dx of a linear solve is the next Newton
    residual wherever the contact status stays: a solve stops at :attr:`safety` times
    the Newton solve's absolute tolerance (at 10^-12 of its right-hand side if that is
    below round-off). A solve whose iterate will mostly move the contact set stops
    at :attr:`forcing` times its right-hand side: the next solve, from a residual that
    much smaller, ends the job. The last Newton solve tells which: solve k (from 0) of
    a Newton solve with active facet (contact) terms is such a solve if the contact set
    of the last Newton solve moved after its iterate k, and, from the second solve
    on, the set moved at this one's iterate k too. Where the set stays (a step in free
    flight, or in steady contact) every solve is a full one, so Newton takes the
    iterations it takes with a direct solve.

    Args:
        enabled: Whether the solves are Krylov solves with these tolerances (False: a
            direct solve, or tolerances of the user's; every solve counts as full).
    """

    #: The relative tolerance of a full solve whose absolute one is below round-off.
    floor = 1.0e-12

    def __init__(self, enabled: bool):
        self.enabled = bool(enabled)
        self.safety = 0.1
        self.forcing = 1.0e-3
        self._full: list[bool] = []  # per linear solve of the Newton solve under way
        #: The last iterate (from 1) of the last Newton solve at which the contact set
        #: moved, 0 if it did not after the first iterate (part of a checkpoint: a
        #: restart then solves as the uninterrupted run).
        self.last_move = 0

    def start(self) -> None:
        """A Newton solve begins."""
        self._full = []

    def finish(self, jacobian_changes: list[bool]) -> None:
        """A Newton solve ended; ``jacobian_changes[k]``: whether the Jacobian at iterate
        k differed from the one before (the contact set moved)."""
        moves = [k for k, changed in enumerate(jacobian_changes) if k and changed]
        self.last_move = max(moves, default=0)

    def set(self, ksp, index: int, moved: bool, active: bool, atol: float) -> None:
        """Set ``ksp``'s tolerances for solve ``index`` (from 0) of its Newton solve, whose
        contact set ``moved`` at this iterate, with ``active`` facet terms, Newton's
        absolute tolerance ``atol``."""
        expected = self.last_move > index and (index == 0 or moved)
        loose = self.enabled and active and expected
        self._full.append(not loose)
        if self.enabled:
            ksp.setTolerances(rtol=self.forcing if loose else self.floor, atol=self.safety * atol)

    def full(self, index: int) -> bool:
        """Whether linear solve ``index`` of the Newton solve under way was a full one."""
        return 0 <= index < len(self._full) and self._full[index]


class ConvergenceTest:
    """SNES's convergence test of a Newton solve (docs/method.md section 8).

    The solve has converged when ||F|| <= its absolute tolerance: ``snes_rtol`` times the
    scale of the step's equation, the larger of ||F(0)|| and ||F(u_0)|| (u_0 the initial
    guess; F(0) holds the loads and the forces of the last state), so that the same
    physical problem in other units takes the same iterations; or when ||F|| is below
    ``snes_rtol`` times the first residual. It has also converged when an iterate solved
    the equation exactly up to round-off (:meth:`exact_before`) and ||F|| is at most
    :attr:`roundoff_bound` times the scale: at rest, F(0) and F(u_0) are both round-off,
    and no residual tolerance is reachable. Full Newton steps stop after
    :attr:`stall_limit` iterations without a new smallest residual (semismooth Newton
    cycling between contact states; a line search takes over).

    Args:
        linear_tolerances: The :class:`InexactSolves` of the solver (which linear solves
            were full ones).
        user_atol: An absolute tolerance the user set (``snes_atol``), obeyed as given;
            None: the tolerance follows the scale of each solve's equation.
    """

    def __init__(self, linear_tolerances: InexactSolves, user_atol: float | None = None):
        self.linear_tolerances = linear_tolerances
        self.user_atol = user_atol
        #: How far above round-off an exact iterate's residual may be, relative to the
        #: scale of the equation.
        self.roundoff_bound = 1.0e-6
        #: Full Newton steps stop after this many iterations without a new smallest residual.
        self.stall_limit = 12
        #: Whether the Jacobian at each iterate of the solve under way differed from the
        #: one before (the solver appends to it).
        self.jacobian_changes: list[bool] = []
        self.atol = 0.0
        self._roundoff, self._full_steps = 0.0, True
        self._first_norm, self._best = 0.0, (0.0, 0)
        self._zero_norm, self._given_atol = 0.0, None

    def start(self, zero_norm: float, atol: float | None, full_steps: bool) -> None:
        """A Newton solve begins: ||F(0)|| is ``zero_norm``; ``atol``, an absolute
        tolerance for this solve (e.g. one shared by several solves of a step; the user's
        ``snes_atol`` wins over it); ``full_steps``: without a line search."""
        self._zero_norm = zero_norm
        self._given_atol = self.user_atol if self.user_atol is not None else atol
        self._full_steps = full_steps

    def restart(self) -> None:
        """A SNES solve begins (the first, or again after a fallback)."""
        self.jacobian_changes = []

    def __call__(self, snes, iteration: int, norms) -> int:
        fnorm = norms[2]
        reasons = PETSc.SNES.ConvergedReason
        if not np.isfinite(fnorm):
            return reasons.DIVERGED_FNORM_NAN
        if iteration == 0:  # one Newton step at least: the guess is not the solution
            self._first_norm, self._best = fnorm, (fnorm, 0)
            self._set_tolerances(max(fnorm, self._zero_norm), snes.getTolerances()[0])
            return reasons.CONVERGED_FNORM_ABS if fnorm == 0.0 else reasons.ITERATING
        if fnorm < self._best[0]:
            self._best = (fnorm, iteration)
        if fnorm <= self.atol:
            return reasons.CONVERGED_FNORM_ABS
        if fnorm <= snes.getTolerances()[0] * self._first_norm:
            return reasons.CONVERGED_FNORM_RELATIVE
        if iteration >= 2 and self.exact_before(iteration) and fnorm <= self._roundoff:
            return reasons.CONVERGED_SNORM_RELATIVE
        if iteration >= snes.getTolerances()[3]:
            return reasons.DIVERGED_MAX_IT
        if self._full_steps and iteration - self._best[1] >= self.stall_limit:
            return reasons.DIVERGED_MAX_IT  # cycling between contact states: no progress
        return reasons.ITERATING

    def _set_tolerances(self, scale: float, rtol: float) -> None:
        """The absolute tolerance and the round-off bound of the solve under way, from
        the scale of its equation."""
        atol = self._given_atol if self._given_atol is not None else rtol * scale
        self.atol = max(atol, _SMALLEST)
        self._roundoff = self.roundoff_bound * scale

    def exact_before(self, iteration: int) -> bool:
        """Whether iterate ``iteration - 1`` solved the step's equation exactly (up to
        round-off): it came from a full Newton step with the Jacobian that it has itself.
        The bulk is affine and the contact terms piecewise affine, so with the same
        Jacobian (the same contact status at every quadrature point) at both ends of a
        full step, that step landed on the solution, if its linear solve was exact: a
        direct one, or a full Krylov solve (:class:`InexactSolves`)."""
        changes, k = self.jacobian_changes, iteration - 1
        full = self.linear_tolerances.full(k - 1)
        return k < len(changes) and not changes[k] and self._full_steps and full
