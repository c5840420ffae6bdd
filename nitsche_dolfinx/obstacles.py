"""Rigid obstacles, described by a signed distance d(x) (d > 0 on the admissible side).

The obstacle normal is ``n_c = -grad d / |grad d|``: it points from the body
into the obstacle. The initial gap is ``g(x) = d(x)`` in the reference
configuration (docs/method.md section 1).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import ufl
from dolfinx import fem

__all__ = ["Obstacle", "PlaneObstacle", "SignedDistanceObstacle"]


class Obstacle:
    """A rigid obstacle: subclasses define :meth:`distance`."""

    def distance(self, x):
        """Signed distance d(x) as a UFL expression of the spatial coordinate ``x``."""
        raise NotImplementedError

    def gap(self, x):
        """Initial gap g(x) = d(x)."""
        return self.distance(x)

    def normal(self, x):
        """Obstacle normal n_c = -grad d / |grad d| (from the body into the obstacle)."""
        grad_d = ufl.grad(self.distance(x))
        return -grad_d / ufl.sqrt(ufl.dot(grad_d, grad_d))


class PlaneObstacle(Obstacle):
    """The half-space bounded by the plane through ``point`` with unit normal ``normal``.

    Args:
        point: A point of the plane.
        normal: Normal of the plane pointing to the admissible side (towards the
            body). For the ground ``z = 0`` under a body: ``(0, 0, 1)``; for the
            wall of the 1D bar at ``x = 0``: ``(1,)``. Any non-zero length.
    """

    def __init__(self, point: Sequence[float], normal: Sequence[float]):
        self.point = np.asarray(point, dtype=float).reshape(-1)
        if not np.all(np.isfinite(self.point)):
            raise ValueError(f"obstacle point must be finite, got {self.point.tolist()}")
        normal = np.asarray(normal, dtype=float).reshape(-1)
        length = float(np.linalg.norm(normal))
        if not np.isfinite(length) or length == 0.0:
            raise ValueError(f"obstacle normal must have a non-zero length, got {normal.tolist()}")
        if normal.shape != self.point.shape:
            raise ValueError(
                f"obstacle point {self.point.tolist()} and normal {normal.tolist()} "
                "have different dimensions"
            )
        self.unit_normal = normal / length

    def distance(self, x):
        return ufl.dot(
            x - ufl.as_vector(self.point.tolist()), ufl.as_vector(self.unit_normal.tolist())
        )

    def normal(self, x):
        # a Constant rather than literals: FFCx 0.5 cannot generate the friction terms'
        # tangential projection I - n_c n_c^T when its entries are literal numbers
        return fem.Constant(x.ufl_domain(), -self.unit_normal)

    def __repr__(self):
        return f"PlaneObstacle(point={self.point.tolist()}, normal={self.unit_normal.tolist()})"


class SignedDistanceObstacle(Obstacle):
    """An obstacle given by its signed distance, a function from x to a UFL expression.

    Example:
        A rigid cylinder of radius 5 around the axis ``x = 0, y = -5`` (the body is outside):

        >>> obstacle = SignedDistanceObstacle(
        ...     lambda x: ufl.sqrt(x[0] ** 2 + (x[1] + 5) ** 2) - 5)
    """

    def __init__(self, distance: Callable):
        self._distance = distance

    def distance(self, x):
        return self._distance(x)
