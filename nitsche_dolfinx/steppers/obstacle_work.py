"""The work moving obstacles do on the body, and the energy the contact terms dissipate, step
by step (docs/method.md section 13).

Over a step from (u^n, t^n) to (u^{n+1}, t^{n+1}), with F the normal force the scheme's
energy identity sees and P(u; t) the Nitsche projection with the obstacle at t:

- the hybrid scheme: F = Phi (its switch), the test terms with the obstacle at t^{n+1/2};
- the other schemes: F = ([P(u^n; t^n)]_+ + [P(u^{n+1}; t^{n+1})]_+) / 2, the trapezoid of
  the forces at the two levels (Crank-Nicolson and Newmark (1/4, 1/2) are the trapezoidal
  rule on the force: their energy identity holds with it).

The obstacle's work is what the change of P owes to the motion, not to the displacement::

    W = int_Gamma_C (1/gamma_h) (F (P(u^{n+1}; t^{n+1}) - P(u^n; t^n)) - F_u)

with F_u the force times the change of P made by the displacement, P(u^{n+1}) - P(u^n)
with the obstacle where the test terms see it: the middle of the step for the hybrid, and
each end for the others, ([P^n]_+ D P^n + [P^{n+1}]_+ D P^{n+1}) / 2. The contact
dissipation is::

    D = int_Gamma_C (1/gamma_h) (F (P(u^{n+1}; t^{n+1}) - P(u^n; t^n))
                                 - ([P(u^{n+1}; t^{n+1})]_+^2 - [P(u^n; t^n)]_+^2) / 2) >= 0

A normal that turns with the obstacle (a rotation, or a translated sphere) also changes
E_Theta's -Theta/2 gamma_h sigma_n(u)^2 at a fixed displacement: W holds that change too.
With Theta = 1, the hybrid scheme, Crank-Nicolson and Newmark (1/4, 1/2) then satisfy
E_Theta^{n+1} - E_Theta^n = W - D (+ the loads' work) to the solver's tolerance.
"""

from __future__ import annotations

from typing import Any

from dolfinx import fem

from ..contact.nitsche import PenaltyContact, hybrid_contact_force, positive_part
from ..output.probes import assemble_global
from .parts import StepEnds, StepPart

__all__ = ["ObstacleWork"]


def _turned_normal(contact, u_old, u_new, hybrid: bool):
    """What the obstacle's turning normal adds to the change of E_Theta's
    -Theta/2 gamma_h sigma_n(u)^2 beyond what the step's consistency term does
    (docs/method.md section 13): zero when n_c does not change."""
    old, mid = contact.at_level("old"), contact.at_level("mid")
    weight = contact.nitsche_theta * contact.gamma_h / 2
    if hybrid:  # the term at the middle: -Theta gamma_h sigma_n(u_mid) sigma_n(delta), at mid
        return -weight * (
            contact.sigma_n(u_new) ** 2 - mid.sigma_n(u_new) ** 2
            - old.sigma_n(u_old) ** 2 + mid.sigma_n(u_old) ** 2
        )  # fmt: skip
    # the trapezoid of the term at the two ends, each with its own normal
    return weight * (
        old.sigma_n(u_old) * old.sigma_n(u_new) - contact.sigma_n(u_new) * contact.sigma_n(u_old)
    )


class ObstacleWork(StepPart):
    """The work of the moving obstacles and the contact dissipation over a step, summed
    since t = 0: a part of the steps (:class:`~nitsche_dolfinx.steppers.parts.StepPart`).

    Args:
        problem: The :class:`~nitsche_dolfinx.model.problem.ContactProblem`.
        midpoint: Whether the scheme's forces are those of the step's middle
            (:attr:`~nitsche_dolfinx.steppers.schemes.TimeScheme.midpoint`).
        state: The stepper's displacement, u^n when :meth:`step` is called, or u^{n+1}
            with ``state_is_new``; the other level is copied into a Function of its own.

    Attributes:
        work: The work of the moving obstacles since t = 0 (``obstacle_work``).
        dissipation: The contact terms' dissipation since t = 0 (``contact_dissipation``),
            of every obstacle's (contact pairs left out).
    """

    def __init__(self, problem, midpoint: bool, state: fem.Function, state_is_new: bool = False):
        hybrid = midpoint
        self._other, self._state_is_new = fem.Function(problem.V), state_is_new
        u_old, u_new = (self._other, state) if state_is_new else (state, self._other)
        work, dissipation = 0, 0
        pairs = problem.pairs  # their partners are not those of u_old and u_new: left out
        for contact in (c for c in problem.contacts if c not in pairs):
            old, mid = contact.at_level("old"), contact.at_level("mid")
            P_old, P_new = old.projection(u_old), contact.projection(u_new)
            if hybrid:
                force = hybrid_contact_force(P_old, (P_old + P_new) / 2, P_new)
                moved = force * (mid.projection(u_new) - mid.projection(u_old))
            else:  # the trapezoid: each end's force on the increment with its obstacle
                force = (positive_part(P_old) + positive_part(P_new)) / 2
                moved = (
                    positive_part(P_old) * (old.projection(u_new) - P_old)
                    + positive_part(P_new) * (P_new - contact.projection(u_old))
                ) / 2  # fmt: skip
            change = P_new - P_old
            if contact.moving:  # an obstacle that stands still does no work
                work = work + (force * change - moved) / contact.gamma_h * contact.ds
                if not isinstance(contact, PenaltyContact):  # its normal turns in E_Theta too
                    work = work + _turned_normal(contact, u_old, u_new, hybrid) * contact.ds
            stored = (positive_part(P_new) ** 2 - positive_part(P_old) ** 2) / 2
            dissipation = dissipation + (force * change - stored) / contact.gamma_h * contact.ds
        # (no work without a moving obstacle: no form)
        self._forms = (None if work == 0 else fem.form(work), fem.form(dissipation))
        self._comm = problem.mesh.comm
        self.work, self.dissipation = 0.0, 0.0

    @property
    def dissipated(self) -> float:
        """The contact dissipation since t = 0."""
        return self.dissipation

    def step(self, ends: StepEnds) -> None:
        """Add the step's work and dissipation (the obstacles are at the step's levels)."""
        self._other.x.array[:] = ends.u if self._state_is_new else ends.u1
        if self._forms[0] is not None:
            self.work += assemble_global(self._forms[0], self._comm)
        self.dissipation += assemble_global(self._forms[1], self._comm)

    def columns(self) -> dict[str, float]:
        """The history columns."""
        return {"obstacle_work": self.work, "contact_dissipation": self.dissipation}

    def saved(self) -> dict[str, float]:
        """What a checkpoint keeps (the sums since t = 0)."""
        return self.columns()

    def running(self) -> dict[str, float]:
        return self.saved()

    def put_back(self, running: dict[str, float]) -> None:
        self.restore(running)

    def restore(self, saved: dict[str, Any]) -> None:
        """The sums of a loaded checkpoint (0 for a checkpoint without them)."""
        self.work = float(saved.get("obstacle_work", 0.0))
        self.dissipation = float(saved.get("contact_dissipation", 0.0))
