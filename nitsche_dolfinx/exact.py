"""The exact solution of the 1D bar with multiple impacts (SPEC section 5).

Omega = (0, 1), E = rho = 1, clamped at x = 1, wall at x = 0 (u(t, 0) >= 0),
u0(x) = 1/2 - x/2, v0 = 0. Periodic with period 3 and energy 1/8.
(Dabaghi, Petrov, Pousin & Renard 2014.)
"""

from __future__ import annotations

import numpy as np

__all__ = ["BAR_ENERGY", "BAR_PERIOD", "bar_contact_values", "bar_displacement"]

BAR_PERIOD = 3.0
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
