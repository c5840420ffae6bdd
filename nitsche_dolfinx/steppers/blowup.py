"""The stops of the explicit steps when they blow up (docs/method.md section 12): an unstable
explicit step grows the energy geometrically, which no smaller step from there undoes.

- the growth: kinetic + elastic energy above :data:`BLOWUP_FACTOR` times its largest value
  up to :data:`BLOWUP_WINDOW` steps before (or not finite);
- the drift: when nothing feeds the body energy, the energy drifted from its initial value
  by more than :data:`BLOWUP_FACTOR` times its initial scale (a slow geometric growth,
  which the window lets through, stops there).
"""

from __future__ import annotations

from collections import deque

import numpy as np

from ..solvers.solver import SolverError

__all__ = ["BLOWUP_FACTOR", "BLOWUP_WINDOW", "BlowUpWatch", "UnstableStep"]

#: A blow-up: kinetic + elastic energy above this many times its largest value up to
#: :data:`BLOWUP_WINDOW` steps before (an unstable explicit step grows geometrically).
BLOWUP_FACTOR = 100.0
#: How many steps back the largest energy of a blow-up's test is taken from.
BLOWUP_WINDOW = 100


class UnstableStep(SolverError):
    """The explicit steps blew up: the energy grew geometrically or is no longer finite.
    Smaller steps from here would not undo it: the run stops (``cut_may_help`` False)."""

    cut_may_help = False

    def __init__(self, energy: float, reference: float, dt: float, stable_dt: float,
                 drift: bool = False):  # fmt: skip
        self.energy, self.reference = energy, reference
        self.dt, self.stable_dt, self.drift = dt, stable_dt, drift
        super().__init__(0, 0, float("nan"))
        self.reason_name = "UNSTABLE"

    def _message(self) -> str:
        where = "" if self.step is None else f"at step {self.step} (t = {self.t:.6g}): "
        grown = (
            f"the energy drifted by {self.energy:.6g} from its initial value, more than "
            f"{BLOWUP_FACTOR:g} times its initial scale {self.reference:.6g} (no load or "
            "Dirichlet value depends on t)"
            if self.drift
            else f"kinetic + elastic energy {self.energy:.6g}, against at most "
            f"{self.reference:.6g} until {BLOWUP_WINDOW} steps before"
        )
        return (
            f"{where}the verlet steps blew up: {grown}; "
            f"dt = {self.dt:.6g} for an estimated stable step of {self.stable_dt:.6g}: take a "
            "smaller dt (or safety); a growth at every step whatever dt is gamma0 beyond the "
            "stability limit of the mesh (gamma0 * E near 1): a smaller gamma0"
        )


class BlowUpWatch:
    """The energies the blow-up stops compare with (see the module docstring).

    Args:
        scale: The energy scale (kinetic + abs(elastic)) at t = 0.
        initial: The diagnostics' energies at t = 0.
        autonomous: Whether nothing feeds the body energy
            (:attr:`~nitsche_dolfinx.model.problem.ContactProblem.autonomous`).
        stable_dt: The estimated stable step, for the messages.
    """

    def __init__(self, scale: float, initial: dict[str, float], autonomous: bool,
                 stable_dt: float):  # fmt: skip
        self.stable_dt = stable_dt
        #: the largest energy scale up to the window
        self.settled = max(scale, abs(initial["potential"]))
        #: the initial energy and its scale, for :meth:`check_drift` (None: the loads or
        #: the Dirichlet values depend on t)
        self.initial = (
            (initial["energy"], max(self.settled, abs(initial["energy"])))
            if autonomous and self.settled > 0
            else None
        )
        self.recent: deque[float] = deque()  # kinetic + elastic of the last levels

    def check_drift(self, energy: float, dt: float, step: int, t: float) -> None:
        """Raise :class:`UnstableStep` at a level (``step``, ``t``) whose energy drifted
        from its initial value by more than :data:`BLOWUP_FACTOR` times its initial scale."""
        if self.initial is None:
            return
        initial, scale = self.initial
        drift = abs(energy - initial)
        if not drift <= BLOWUP_FACTOR * scale:  # (NaN too)
            error = UnstableStep(drift, scale, dt, self.stable_dt, drift=True)
            error.add_context(step=step, t=t)
            raise error

    def growth(self, energy: float, dt: float, obstacle_work: float | None) -> UnstableStep | None:
        """The error of a blow-up (None: none): the energy scale ``energy`` not finite, or
        above :data:`BLOWUP_FACTOR` times its largest value up to :data:`BLOWUP_WINDOW`
        steps before, the loads' potential at t = 0 (a body at rest may start moving), or
        ``obstacle_work``, the work moving obstacles did before the step (None: none)."""
        reference = self.settled  # up to the window before: a blow-up cannot raise it
        if obstacle_work is not None:  # what moving obstacles put in
            reference = max(reference, abs(obstacle_work))
        if np.isfinite(energy) and (reference == 0.0 or energy <= BLOWUP_FACTOR * reference):
            self.recent.append(energy)
            if len(self.recent) > BLOWUP_WINDOW:
                self.settled = max(self.settled, self.recent.popleft())
            return None
        return UnstableStep(energy, reference, dt, self.stable_dt)

    def restart(self, scale: float) -> None:
        """Start the window again at a loaded level of energy scale ``scale``."""
        self.settled, self.recent = max(self.settled, scale), deque()
