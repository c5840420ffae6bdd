"""The time levels of a run: a grid of steps tau up to t_end, reached exactly, with cut steps
in between when Newton needs them (docs/method.md section 8).

Every scheme of the package is a one-step scheme, so each step may have its own size.
The nominal levels are t_k = t_origin + k tau, the last one t_end itself (a shorter last
step when t_end is not a multiple of tau). A step that fails may be replaced by two
half steps, and those again (see :class:`~nitsche_dolfinx.simulation.Simulation`); after
them the run is back on the grid. The grid is computed, never summed, so that times do
not drift, and a run restarted with the same tau continues on the same grid (its origin
and index are in the checkpoint); a restart with another tau starts a grid of its own at
the restart time.
"""

from __future__ import annotations

from typing import Any

from ..common.parameters import TimeStepping

__all__ = ["TimeLevels"]

#: A nominal level this close to t_end (relative to tau) is t_end: round-off of k tau.
_SNAP = 1e-9


class TimeLevels:
    """The time of a stepper and the size of its steps (a base of every stepper).

    Attributes:
        dt: The nominal step tau.
        t_end: The final time.
        t: The current time t^n.
        step_index: Steps made (cut steps count one each).
        last_dt: The size of the last step (0 before the first).
        step_cuts: How many times the last step was halved (0: a step of the grid).
        time_origin, grid_index: The current level's place on the grid: the last
            nominal level reached is ``time_origin + grid_index * dt``.
    """

    def _start_levels(self, time_stepping: TimeStepping) -> None:
        self.dt, self.t_end = time_stepping.dt, time_stepping.t_end
        self.t, self.step_index = 0.0, 0
        self.time_origin, self.grid_index = 0.0, 0
        self.last_dt, self.step_cuts = 0.0, 0
        self._on_grid = True  # at a nominal level

    @property
    def num_steps(self) -> int:
        """The number of steps of tau from t = 0 to t_end, the last one shorter when
        t_end is not a multiple of tau (:attr:`TimeStepping.num_steps`)."""
        return TimeStepping(self.dt, self.t_end).num_steps

    def next_time(self) -> float:
        """The next nominal level: the next point of the grid, or t_end."""
        t = self.time_origin + (self.grid_index + 1) * self.dt
        return self.t_end if t >= self.t_end - _SNAP * self.dt else t

    @property
    def finished(self) -> bool:
        """Whether t_end is reached."""
        return self.t >= self.t_end

    def _step_to(self, t_new: float | None) -> tuple[float, float]:
        """The time a step heads for (``t_new``, or the next nominal level) and its size:
        tau itself from a nominal level to the next (not a difference of times, which
        differs from tau by round-off)."""
        nominal = self.next_time()
        t_new = nominal if t_new is None else float(t_new)
        if not self.t < t_new <= self.t_end:
            raise ValueError(f"a step from t = {self.t!r} cannot end at t = {t_new!r}")
        dt = t_new - self.t
        if self._on_grid and t_new == nominal and abs(dt - self.dt) <= _SNAP * self.dt:
            dt = self.dt
        return t_new, dt

    def _arrive(self, t_new: float, dt: float, cuts: int) -> None:
        """Move the clock to ``t_new`` after a converged step of size ``dt``, halved
        ``cuts`` times."""
        self._on_grid = t_new == self.next_time()
        if self._on_grid:
            self.grid_index += 1
        self.last_dt, self.step_cuts = dt, cuts
        self.t = t_new
        self.step_index += 1

    def levels(self) -> dict[str, Any]:
        """The clock, for a checkpoint."""
        return {"time_origin": self.time_origin, "grid_index": self.grid_index}

    def _restore_levels(self, t: float, step_index: int, saved: dict[str, Any]) -> None:
        """Move the clock to a loaded level: on the saved grid when tau is the saved one,
        else on a new grid from ``t``."""
        self.t, self.step_index = t, step_index
        self.last_dt, self.step_cuts = 0.0, 0
        if saved.get("dt") == self.dt and "grid_index" in saved:
            self.time_origin, self.grid_index = saved["time_origin"], saved["grid_index"]
        elif saved.get("dt") == self.dt:  # a checkpoint without a clock: the grid from 0
            self.time_origin, self.grid_index = 0.0, step_index
        else:
            self.time_origin, self.grid_index = t, 0
        if self.time_origin + self.grid_index * self.dt > t + _SNAP * self.dt:
            self.grid_index -= 1  # a short last step reached t_end before its grid level
        # t_end of the run saved is the grid level k tau but for round-off: on the grid, so
        # that an extended run steps tau from there as a run straight to the new t_end does
        self._on_grid = abs(t - self.time_origin - self.grid_index * self.dt) <= _SNAP * self.dt
