"""The optional parts of a step: what a stepper carries besides its state, one object each,
in one list (:class:`StepParts`).

A part is called at three moments of a step: :meth:`StepPart.step` once the new state is
known (:class:`StepEnds`: u^n and u^{n+1}, v^n and v^{n+1}, the step's size, its
equation's reactions and loads), :meth:`StepPart.accept` once the step is accepted and the
clock moved, and, should the step be refused, :meth:`StepPart.put_back` with what
:meth:`StepPart.running` kept before it. It gives its history columns, what a checkpoint
keeps of it and its share of the energy balance (docs/method.md section 13): the work done
on the body and the energy dissipated since t = 0.

The parts: the friction's work (:class:`~nitsche_dolfinx.steppers.friction.FrictionWork`),
the damping's dissipation (:mod:`~nitsche_dolfinx.steppers.damping_work`), the work of
moving obstacles and the contact dissipation
(:class:`~nitsche_dolfinx.steppers.obstacle_work.ObstacleWork`), the work of the loads and
supports (:class:`~nitsche_dolfinx.steppers.work.ExternalWork`), and the change of E_Theta
that pairings make (:class:`PairingEnergy`, docs/method.md section 11).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["PairingEnergy", "StepEnds", "StepPart", "StepParts"]


@dataclass
class StepEnds:
    """The two ends of a step, as the parts see it (arrays of the local dofs; the stepper
    may fill those of the new level in place after :meth:`StepPart.step`).

    Attributes:
        u, u1: u^n and u^{n+1}.
        v, v1: v^n and v^{n+1}.
        dt: The step's size.
        reactions: The supports' reactions of the step's equation, at the owned
            Dirichlet dofs (called once, by the part that needs them).
        loads: The loads' vector of the step's equation (owned dofs), or None.
    """

    u: np.ndarray
    u1: np.ndarray
    v: np.ndarray
    v1: np.ndarray
    dt: float
    reactions: Callable[[], np.ndarray]
    loads: Callable[[], np.ndarray | None]


class StepPart:
    """A part of a step, with the hooks it does nothing in by default."""

    #: The work done on the body since t = 0, and the energy dissipated since t = 0.
    work = 0.0
    dissipated = 0.0
    #: The energy the last accepted step dissipated (``energy_balance_residual``).
    step_dissipation = 0.0

    def step(self, ends: StepEnds) -> None:
        """The step's share, once its new state is known (not yet accepted)."""

    def accept(self, level: int, ends: StepEnds) -> None:
        """The step is accepted: the clock is at its new ``level``."""

    def running(self) -> Any:
        """What :meth:`put_back` needs to undo :meth:`step`."""
        return None

    def put_back(self, running: Any) -> None:
        """Undo :meth:`step` after a refused step."""

    def columns(self) -> dict[str, float]:
        """The history columns of the current level."""
        return {}

    def saved(self) -> dict[str, float]:
        """What a checkpoint keeps."""
        return {}

    def restore(self, saved: dict[str, Any]) -> None:
        """The values of a loaded checkpoint (its functions already loaded, the data and
        the obstacles at its time)."""

    def functions(self) -> dict:
        """The Functions a checkpoint keeps, by name."""
        return {}


class PairingEnergy(StepPart):
    """The change of E_Theta the pairings of contact pairs made since t = 0
    (``pairing_energy``, docs/method.md section 11): a pair follows its partner's surface
    at each accepted level (:meth:`~nitsche_dolfinx.output.diagnostics.Diagnostics.
    follow_pairs`)."""

    def __init__(self, problem, diagnostics):
        self._pairs, self._diagnostics = bool(problem.pairs), diagnostics
        self.energy = 0.0

    def accept(self, level: int, ends: StepEnds) -> None:
        self.energy += self._diagnostics.follow_pairs(level)

    def columns(self) -> dict[str, float]:
        return {"pairing_energy": self.energy}

    def saved(self) -> dict[str, float]:
        return {"pairing_energy": self.energy} if self._pairs else {}

    def restore(self, saved: dict[str, Any]) -> None:
        self.energy = float(saved.get("pairing_energy", 0.0))


class StepParts:
    """The parts of a stepper's steps, called in the order of the list."""

    def __init__(self, parts: list[StepPart]):
        self.parts = [part for part in parts if part is not None]

    def step(self, ends: StepEnds) -> None:
        """:meth:`StepPart.step` of each part."""
        for part in self.parts:
            part.step(ends)

    def accept(self, level: int, ends: StepEnds) -> None:
        """:meth:`StepPart.accept` of each part."""
        for part in self.parts:
            part.accept(level, ends)

    def running(self) -> list:
        """What each part needs to undo its step."""
        return [part.running() for part in self.parts]

    def put_back(self, running: list) -> None:
        """Undo the parts' step (``running``: :meth:`running` before it)."""
        for part, kept in zip(self.parts, running):
            part.put_back(kept)

    def columns(self) -> dict[str, float]:
        """The parts' history columns."""
        return {name: value for part in self.parts for name, value in part.columns().items()}

    def saved(self) -> dict[str, float]:
        """What a checkpoint keeps of the parts."""
        return {name: value for part in self.parts for name, value in part.saved().items()}

    def restore(self, saved: dict[str, Any]) -> None:
        """The parts of a loaded checkpoint."""
        for part in self.parts:
            part.restore(saved)

    def functions(self) -> dict:
        """The Functions a checkpoint keeps for the parts."""
        return {name: f for part in self.parts for name, f in part.functions().items()}

    def totals(self) -> tuple[float, float, float]:
        """The work done on the body and the energy dissipated since t = 0, and the energy
        the last step dissipated, summed over the parts in their order."""
        work, dissipated, step = 0.0, 0.0, 0.0
        for part in self.parts:
            work += part.work
            dissipated += part.dissipated
            step += part.step_dissipation
        return work, dissipated, step
