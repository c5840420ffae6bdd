"""The energy Rayleigh damping dissipates, step by step (docs/method.md section 14), as a part
of the steps (:class:`~nitsche_dolfinx.steppers.parts.StepPart`): ``damping_dissipation``,
the running total, and the last step's share of ``energy_balance_residual``.

- :class:`ImplicitDamping`: tau (v_m, C v_m) with v_m = (v^n + v^{n+1}) / 2, the
  trapezoidal rule of the power of the levels' forces C v^n and C v^{n+1} for theta and
  Newmark, the midpoint force C v^{n+1/2} of the hybrid scheme.
- :class:`ExplicitDamping`: the Verlet steps' damping force C v at each level,
  alpha M v^n + beta K v^{n-1/2}, and their dissipation tau/4 (F^n + F^{n+1}) .
  (v^n + v^{n+1}).
"""

from __future__ import annotations

from typing import Any

from petsc4py import PETSc

from ..common.collective import sum_over_ranks
from ..physics.damping import DampingPower
from .parts import StepEnds, StepPart

__all__ = ["ExplicitDamping", "ImplicitDamping"]


class ImplicitDamping(StepPart):
    """The damping's dissipation of the implicit steps.

    Args:
        power: The damping's power (v, C v) (a
            :class:`~nitsche_dolfinx.physics.damping.DampingPower`).
    """

    def __init__(self, power: DampingPower):
        self.power = power
        self._pending = 0.0  # the step's, until it is accepted

    def step(self, ends: StepEnds) -> None:
        # (the kinematic v^{n+1}: the equation's, before massless nodes are set)
        mean = (ends.v + ends.v1) / 2
        self._pending = ends.dt * self.power(mean)

    def accept(self, level: int, ends: StepEnds) -> None:
        self.step_dissipation = self._pending
        self.dissipated += self._pending

    def columns(self) -> dict[str, float]:
        return {"damping_dissipation": self.dissipated}

    def saved(self) -> dict[str, float]:
        return {"damping_dissipation": self.dissipated}

    def restore(self, saved: dict[str, Any]) -> None:
        self.dissipated = float(saved.get("damping_dissipation", 0.0))
        self.step_dissipation = 0.0


class ExplicitDamping(StepPart):
    """The damping force of the Verlet steps and its dissipation.

    Args:
        problem: The damped problem.
        mass: The explicit steps' mass (its ``mult``).
        stiffness: The bulk's stiffness matrix K.
        stepper: The stepper: its state ``v``, ``a``, ``comm`` and ``last_dt``.
        template: A vector of the problem's layout (ghosted), for the levels' forces.
    """

    def __init__(self, problem, mass, stiffness: PETSc.Mat, stepper, template: PETSc.Vec):
        self.power = DampingPower(problem.damping, mass.mult, stiffness, stepper.comm)
        self.alpha = problem.damping.values[0]
        self._stepper, self._template = stepper, template
        #: C v at the current level: alpha M v^n + beta K v^{n-1/2} (C v0 at t = 0)
        self.level_force = None

    def force(self, velocity, out: PETSc.Vec) -> PETSc.Vec:
        """C ``velocity`` into ``out``."""
        return self.power.force(velocity, out)

    def start(self) -> None:
        """The force of the first level, C v0."""
        self.level_force = self._force_of_level(0.0)

    def _force_of_level(self, dt: float) -> PETSc.Vec:
        """C v at the current level as the steps take it, alpha M v^n + beta K v^{n-1/2}
        with v^{n-1/2} = v^n - ``dt``/2 a^n, ``dt`` the last step's size (0 at t = 0: C v0);
        from the level's own arrays, so that a restart computes it to the bit."""
        v, a = self._stepper.v.x.array, self._stepper.a.x.array
        half_step = v - dt / 2 * a
        return self.power.force(half_step, self._template.duplicate(), v)

    def accept(self, level: int, ends: StepEnds) -> None:
        """The step's dissipation, tau/4 (F^n + F^{n+1}) . (v^n + v^{n+1}): the damping's
        share of the kinetic energy's change in the velocity update; added to the total."""
        dt = ends.dt
        force = self._force_of_level(dt)
        n = force.getLocalSize()
        total = self.level_force.array_r + force.array_r
        local = dt / 4 * float(total @ (ends.v[:n] + ends.v1[:n]))
        self.step_dissipation = float(sum_over_ranks(self._stepper.comm, [local])[0])
        self.dissipated += self.step_dissipation
        self.level_force.destroy()
        self.level_force = force

    def columns(self) -> dict[str, float]:
        return {"damping_dissipation": self.dissipated}

    def saved(self) -> dict[str, float]:
        """The running total and the last step's size (the level's force lags by half of
        it)."""
        return {"damping_dissipation": self.dissipated, "damping_last_dt": self._stepper.last_dt}

    def restore(self, saved: dict[str, Any]) -> None:
        """The total and the level's force F^n (v^{n-1/2} = v^n - tau/2 a^n)."""
        self.dissipated = float(saved.get("damping_dissipation", 0.0))
        self.step_dissipation = 0.0
        self.level_force.destroy()
        self.level_force = self._force_of_level(saved.get("damping_last_dt", 0.0))
