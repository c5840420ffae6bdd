"""What the Nitsche (and penalty) steppers share, implicit or explicit: the diagnostics of a
level with the energy balance (docs/method.md section 13), the parts a step carries
(:class:`~nitsche_dolfinx.steppers.parts.StepParts`), their checkpoint and restore, and
the output fields on Gamma_C.
"""

from __future__ import annotations

from typing import Any

from dolfinx import fem

from ..output.fields import ContactFields, LevelRefresh, OnBoundary, body_fields
from .base import StepperBase

__all__ = ["BalancedStepper"]


class BalancedStepper(StepperBase):
    """A stepper with :class:`~nitsche_dolfinx.output.diagnostics.Diagnostics`
    (``diagnostics``) and the parts of its steps (``parts``), whose energy balance it keeps:
    the work done on the body, what friction, damping and the contact terms dissipated, the
    internal energy at t = 0 (``_internal_energy0``) and E_Theta before the last step
    (``_energy_before``)."""

    #: Whether every dissipation is summed (no obstacle whose contact dissipation is left
    #: out): ``energy_balance`` is reported only then.
    _dissipation_known = True
    _internal_energy0 = 0.0
    _energy_before = None  # E_Theta^n of the last step
    _contact_fields = None  # ContactFields, once the output asks for them
    _friction_output = None  # the friction fields (a FrictionOutput), with friction

    def _keeps_accounts(self, problem) -> bool:
        """Whether the contact terms' dissipation is summed: with an obstacle, when the
        problem's energy is not kept by itself (supports, data or obstacles that move,
        damping). An autonomous problem's E_Theta is its own balance, and the two
        assemblies on Gamma_C a step would cost it some 6% of a free step (the talk's
        ball), and Verlet as much as a step."""
        obstacles = any(contact not in problem.pairs for contact in problem.contacts)
        needed = bool(problem.dirichlet) or not problem.autonomous
        needed = needed or problem.damping is not None
        self._dissipation_known = not obstacles or needed
        return obstacles and needed

    def _internal_energy(self) -> float:
        """E_Theta without the loads' potential at the current level: what the work of the
        loads changes."""
        values = self.diagnostics.of_level(self.step_index)
        return values["energy_theta"] - values["potential"]

    def state(self, columns=None) -> dict[str, float]:
        """Diagnostics at the current time level, identical on every rank: those of every
        level, and the optional ones (:class:`~nitsche_dolfinx.output.diagnostics.Diagnostics`)
        that ``columns`` name (None: all); the parts' columns; the work of the loads,
        supports and moving obstacles since t = 0 (``work``) and ``energy_balance``: the
        change of the internal energy, plus what friction, damping and the contact terms
        dissipated, less that work (zero to the solver's tolerance for the hybrid scheme,
        Crank-Nicolson and Newmark (1/4, 1/2) with Theta = 1); and
        ``energy_balance_residual``, the last step's E_Theta change plus what it
        dissipated."""
        values = {"t": self.t, **self.diagnostics.of_level(self.step_index, columns)}
        values.update(self.parts.columns())
        work, dissipated, step_dissipation = self.parts.totals()
        values["work"] = work
        if self._dissipation_known:
            change = self._internal_energy() - self._internal_energy0
            values["energy_balance"] = change + dissipated - work
        values.setdefault("friction_dissipation", 0.0)
        values["energy_balance_residual"] = (
            0.0
            if self._energy_before is None
            else values["energy_theta"] - self._energy_before + step_dissipation
        )
        values.update(self._clock_columns())
        return values

    def levels(self) -> dict[str, Any]:
        """The clock, the internal energy at t = 0 and the parts' sums, for a checkpoint."""
        return {**super().levels(), "internal_energy0": self._internal_energy0,
                **self.parts.saved()}  # fmt: skip

    def restore(self, t: float, step_index: int, saved: dict[str, Any]) -> None:
        """Move to a time level whose functions were just loaded (``saved``: the
        checkpoint's description and :meth:`levels`): the clock, the pairings, the data
        and the obstacles at ``t``, the parts' sums; the level's diagnostics are computed
        anew."""
        super().restore(t, step_index, saved)
        self.problem.restore_pairs()
        self.problem.move_obstacles(t)
        self.diagnostics.remember(step_index, None)  # the loaded state's are computed anew
        self._internal_energy0 = float(saved.get("internal_energy0", self._internal_energy0))
        self.parts.restore(saved)

    def checkpoint_functions(self) -> dict[str, fem.Function]:
        """Everything the next step depends on, by name: the state, the parts' Functions
        (the supports' reactions) and the displacements the contact pairs were paired in."""
        return {**self._state_functions(), **self.parts.functions(),
                **self.problem.pairing_state()}  # fmt: skip

    def contact_pressure(self):
        """The contact pressure lambda_h = -(1/gamma_h) [P_gamma(u)]_+ of the first contact
        term (an obstacle or a pair's half), as a UFL expression on its Gamma_C
        (docs/method.md section 2)."""
        return self.problem.contacts[0].pressure(self.u)

    def output_fields(self) -> dict:
        """Displacement, velocity, von Mises stress, the contact fields on Gamma_C
        (:class:`~nitsche_dolfinx.output.fields.ContactFields`: contact pressure, gap, contact
        status) and with friction the slip velocity and the friction traction
        (:class:`~nitsche_dolfinx.steppers.friction.FrictionOutput`)."""
        shape = (self.problem.gdim,)
        fields = body_fields(self.problem, self.u, self.v)
        if self.problem.contacts:
            if self._contact_fields is None:  # compiled when first asked for
                self._contact_fields = ContactFields(self.problem, self.u)
            on_contact = dict(self._contact_fields.fields())
            if self._friction_output is not None:
                for field in self._friction_output.fields:
                    source = OnBoundary(field.function, self._contact_fields.facets)
                    on_contact[field.function.name] = (source, shape)
            refresh = LevelRefresh(self._update_projections, lambda: (self.step_index, self.t))
            fields.update({name: (refresh.wrap(f), s) for name, (f, s) in on_contact.items()})
        return fields

    def _update_projections(self) -> None:
        """The boundary projections of the contact and friction fields at the state."""
        self._contact_fields.update()
        if self._friction_output is not None:
            self._friction_output.update_fields()
