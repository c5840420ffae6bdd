"""Exact solutions and the errors of runs against them.

The 1D bar with multiple impacts (docs/method.md section 5): Omega = (0, 1),
E = rho = 1, clamped at x = 1, wall at x = 0 (u(t, 0) >= 0), u0(x) = 1/2 - x/2,
v0 = 0; periodic with period 3 and energy 1/8 (Dabaghi, Petrov, Pousin & Renard
2014). Two bars colliding (docs/method.md section 11): in contact for 2L/c = 2 from
their first touch, then apart with their velocities exchanged.
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI

from ..common import compat

__all__ = [
    "BAR_ENERGY",
    "BAR_PERIOD",
    "BarSpaceTimeErrors",
    "bar_contact_errors",
    "bar_contact_values",
    "bar_displacement",
    "bar_kinks",
    "bar_strain",
    "observed_orders",
    "two_bars_errors",
]

#: The period in time of the bar's exact solution.
BAR_PERIOD = 3.0
#: The bar's energy, kinetic + elastic, the same at every time (all elastic at t = 0).
BAR_ENERGY = 1.0 / 8.0


def bar_displacement(t, x):
    """u(t, x), vectorised over arrays ``t`` and ``x`` (broadcast together)."""
    t, x = np.broadcast_arrays(np.asarray(t, dtype=float), np.asarray(x, dtype=float))
    s = np.mod(t, BAR_PERIOD)
    flight = (1.0 - np.maximum(x, s)) / 2.0

    r = s - 1.0
    low, high = np.minimum(r, 1.0 - r), np.maximum(r, 1.0 - r)
    middle = np.where(r <= 0.5, -r / 2.0, (r - 1.0) / 2.0)
    contact = np.where(x <= low, -x / 2.0, np.where(x >= high, (x - 1.0) / 2.0, middle))

    release = np.minimum(s - 2.0, 1.0 - x) / 2.0
    return np.where(s <= 1.0, flight, np.where(s <= 2.0, contact, release))


def bar_contact_values(t):
    """``(u, v, sigma)`` at x = 0 at times ``t``: u = (1-s)/2, 0, (s-2)/2; v = -1/2, 0, 1/2;
    sigma = 0, -1/2, 0 in flight, contact and release."""
    s = np.mod(np.asarray(t, dtype=float), BAR_PERIOD)
    u = np.where(s <= 1.0, (1.0 - s) / 2.0, np.where(s <= 2.0, 0.0, (s - 2.0) / 2.0))
    v = np.where(s < 1.0, -0.5, np.where(s < 2.0, 0.0, 0.5))
    sigma = np.where((s > 1.0) & (s < 2.0), -0.5, 0.0)
    return u, v, sigma


def bar_contact_errors(history, dt: float) -> dict[str, float]:
    """The errors at x = 0 of a bar run (a :class:`~nitsche_dolfinx.output.history.History` with
    the columns of :data:`~nitsche_dolfinx.cases.one_body.BAR_COLUMNS`), in l2(0, T) over its time
    levels, e.g. (sum_n tau abs(u_h(t^n, 0) - u(t^n, 0))^2)^(1/2): ``error_u_contact``,
    ``error_v_contact``, ``error_sigma_contact`` (the recorded pressure against sigma);
    ``energy_error_max``, max_n abs(E^n - 1/8); ``penetration_max``, max_n -u_h(t^n, 0) (or 0)."""
    u, v, sigma = bar_contact_values(history["t"])
    return {
        "error_u_contact": np.sqrt(dt * np.sum((history["u_contact"] - u) ** 2)),
        "error_v_contact": np.sqrt(dt * np.sum((history["v_contact"] - v) ** 2)),
        "error_sigma_contact": np.sqrt(dt * np.sum((history["sigma_contact"] - sigma) ** 2)),
        "energy_error_max": np.max(np.abs(history["energy"] - BAR_ENERGY)),
        "penetration_max": max(-np.min(history["u_contact"]), 0.0),
    }


def observed_orders(h, errors) -> list[float]:
    """log(e_{k-1} / e_k) / log(h_{k-1} / h_k) between consecutive levels of mesh sizes
    ``h`` (NaN for the first level, and where an error is zero)."""
    errors, h = np.asarray(errors, dtype=float), np.asarray(h, dtype=float)
    ratios = h[:-1] / h[1:]
    with np.errstate(divide="ignore", invalid="ignore"):
        return [np.nan, *(np.log(errors[:-1] / errors[1:]) / np.log(ratios))]


def two_bars_errors(history, v0: float, gap: float) -> dict[str, float]:
    """The relative errors of a run of two bars colliding (speeds +-v0, ``gap`` apart; the
    columns of ``demos/two_bars_1d.py``) against the exact pair: it touches at
    t0 = gap / (2 v0) and separates at t0 + 2, the left bar then at -v0, the right at +v0
    (checked from 0.2 after), the energy unchanged. Also the largest abs(momentum) / v0 and
    the mean Newton iterations."""
    touching = history["t"][history["contact_force"] > 0]
    start = gap / (2 * v0)
    duration = (touching.max() - touching.min()) if len(touching) else 0.0
    after = history["t"] > start + 2.0 + 0.2
    exit_error = np.nan
    if after.any():
        right = np.abs(history["v_right"][after] - v0).max()
        exit_error = max(right, np.abs(history["v_left"][after] + v0).max()) / v0
    energy = history["energy"]
    return {
        "contact_start": touching.min() if len(touching) else np.nan,
        "duration_error": abs(duration - 2.0) / 2.0,
        "exit_velocity_error": exit_error,
        "energy_error": abs(energy[-1] - energy[0]) / energy[0],
        "momentum_max": np.abs(history["momentum"]).max() / v0,
        "newton": history.mean_newton_iterations(),
    }


def bar_strain(t, x):
    """du/dx (t, x) of the exact solution (at a kink: either side)."""
    t, x = np.broadcast_arrays(np.asarray(t, dtype=float), np.asarray(x, dtype=float))
    s = np.mod(t, BAR_PERIOD)
    flight = np.where(x > s, -0.5, 0.0)
    r = s - 1.0
    low, high = np.minimum(r, 1.0 - r), np.maximum(r, 1.0 - r)
    contact = np.where(x < low, -0.5, np.where(x > high, 0.5, 0.0))
    release = np.where(x > 3.0 - s, -0.5, 0.0)
    return np.where(s <= 1.0, flight, np.where(s <= 2.0, contact, release))


def bar_kinks(t: float) -> np.ndarray:
    """Every x where u(t, .) may have a kink (extra points do no harm)."""
    s = t % BAR_PERIOD
    return np.array([s, s - 1.0, 2.0 - s, 3.0 - s])


GAUSS_POINTS, GAUSS_WEIGHTS = np.polynomial.legendre.leggauss(4)  # exact up to degree 7


class BarSpaceTimeErrors:
    """sum_n tau ||e^n||^2_L2 and sum_n tau ||grad e^n||^2_L2 of a bar simulation (the H1 seminorm).

    Call it at t = 0 and after every step (``run(callback=errors)``). Each cell is cut
    at the kinks of the exact solution and integrated exactly by Gauss quadrature on
    each piece; u_h is evaluated with ``Function.eval`` and du_h/dx interpolated into
    DG(p - 1), on the cells this rank owns, summed over the ranks.
    """

    def __init__(self, simulation):
        u = simulation.u
        mesh = u.function_space.mesh
        tdim = mesh.topology.dim
        num_owned = mesh.topology.index_map(tdim).size_local
        self.cells = np.arange(num_owned, dtype=np.int32)
        x = mesh.geometry.x[compat.geometry_dofmap(mesh)[:num_owned], 0]
        self.left, self.right = x.min(axis=1), x.max(axis=1)
        degree = simulation.problem.degree
        self.gradient = fem.Function(compat.function_space(mesh, "DG", degree - 1))
        self._gradient_expression = compat.expression(
            ufl.grad(u)[0, 0], self.gradient.function_space
        )
        self.comm = mesh.comm
        self.l2_squared = 0.0
        self.h1_squared = 0.0

    def __call__(self, simulation) -> None:
        t, dt = simulation.t, simulation.dt
        # each cell cut at the kinks: pieces [a, b] on which u(t, .) is linear
        cuts = np.clip(bar_kinks(t)[None, :], self.left[:, None], self.right[:, None])
        ends = np.sort(np.column_stack([self.left, cuts, self.right]), axis=1)
        a, b = ends[:, :-1, None], ends[:, 1:, None]
        x = 0.5 * (a + b) + 0.5 * (b - a) * GAUSS_POINTS
        weights = 0.5 * (b - a) * GAUSS_WEIGHTS
        points = np.zeros((x.size, 3))
        points[:, 0] = x.ravel()
        cells = np.repeat(self.cells, x.size // max(len(self.cells), 1))
        self.gradient.interpolate(self._gradient_expression)
        u_h = simulation.u.eval(points, cells)[:, 0].reshape(x.shape)
        du_h = self.gradient.eval(points, cells)[:, 0].reshape(x.shape)
        # the exact gradient at the middle of each piece: no doubt about the side of a kink
        du = np.broadcast_to(bar_strain(t, 0.5 * (a + b)), x.shape)
        local = np.array(
            [
                np.sum(weights * (u_h - bar_displacement(t, x)) ** 2),
                np.sum(weights * (du_h - du) ** 2),
            ]
        )
        total = self.comm.allreduce(local, op=MPI.SUM)
        self.l2_squared += dt * total[0]
        self.h1_squared += dt * total[1]
