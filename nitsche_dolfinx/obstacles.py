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

__all__ = [
    "CylinderObstacle",
    "Obstacle",
    "PlaneObstacle",
    "SignedDistanceObstacle",
    "SphereObstacle",
]


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


def _finite_vector(value, what: str) -> np.ndarray:
    array = np.asarray(value, dtype=float).reshape(-1)
    if array.size == 0 or not np.all(np.isfinite(array)):
        raise ValueError(f"{what} must be finite, got {array.tolist()}")
    return array


def _check_radius(radius: float, side: str) -> float:
    if not (np.isfinite(radius) and radius > 0):
        raise ValueError(f"the radius must be positive, got {radius!r}")
    if side not in ("outside", "inside"):
        raise ValueError(f"side must be 'outside' or 'inside', got {side!r}")
    return float(radius)


def _constants(obstacle, x, *values) -> tuple:
    """``values`` as fem.Constants on the mesh of ``x``, made once per obstacle and mesh
    (the gap and the normal share them)."""
    domain = x.ufl_domain()
    cached = obstacle.__dict__.get("_constants")
    if cached is None or cached[0] is not domain:
        cached = obstacle._constants = (domain, tuple(fem.Constant(domain, v) for v in values))
    return cached[1]


def _check_dimension(array: np.ndarray, x, what: str) -> None:
    if array.size != x.ufl_shape[0]:
        raise ValueError(
            f"{what} {array.tolist()} has {array.size} coordinates, the mesh has {x.ufl_shape[0]}"
        )


class _RadialObstacle(Obstacle):
    """An obstacle at ``radius`` from a centre (sphere) or an axis (cylinder): d and n
    from the radial vector r that :meth:`_radial` gives with the radius, d = |r| - R
    outside (-d inside) and n = -r / |r| outside (r / |r| inside)."""

    side: str

    def _radial(self, x):
        raise NotImplementedError

    def distance(self, x):
        r, radius = self._radial(x)
        d = ufl.sqrt(ufl.dot(r, r)) - radius
        return d if self.side == "outside" else -d

    def normal(self, x):
        # -grad d / |grad d| written out: the radius, a constant that the gradient drops,
        # would be left out of the compiled expression's constants (FFCx 0.5)
        r, _ = self._radial(x)
        unit = r / ufl.sqrt(ufl.dot(r, r))
        return -unit if self.side == "outside" else unit


class SphereObstacle(_RadialObstacle):
    """A rigid sphere (a circle in 2D) of ``radius`` around ``center``.

    Args:
        center: The centre, of the mesh's dimension.
        radius: The radius (> 0).
        side: Where the body is: ``"outside"`` (a rigid ball, d = |x - c| - R) or
            ``"inside"`` (a spherical cavity, d = R - |x - c|).
    """

    def __init__(self, center: Sequence[float], radius: float, side: str = "outside"):
        self.center = _finite_vector(center, "the sphere's centre")
        self.radius = _check_radius(radius, side)
        self.side = side

    def _radial(self, x):
        """x - c, and the radius, with the centre and the radius as constants (another
        sphere compiles no new form)."""
        _check_dimension(self.center, x, "the sphere's centre")
        center, radius = _constants(self, x, self.center, self.radius)
        return x - center, radius

    def __repr__(self):
        return (
            f"SphereObstacle(center={self.center.tolist()}, radius={self.radius!r}, "
            f"side={self.side!r})"
        )


class CylinderObstacle(_RadialObstacle):
    """A rigid circular cylinder in 3D: the points at ``radius`` from the axis through
    ``point`` along ``axis``.

    Args:
        point: A point of the axis (3 coordinates).
        axis: The direction of the axis (any non-zero length).
        radius: The radius (> 0).
        side: Where the body is: ``"outside"`` (a rigid pillar) or ``"inside"`` (a pipe).
    """

    def __init__(
        self, point: Sequence[float], axis: Sequence[float], radius: float, side: str = "outside"
    ):
        self.point = _finite_vector(point, "the cylinder's point")
        axis = _finite_vector(axis, "the cylinder's axis")
        length = float(np.linalg.norm(axis))
        if length == 0.0 or axis.size != self.point.size:
            raise ValueError(
                f"the cylinder's axis {axis.tolist()} must be non-zero, with as many "
                f"coordinates as its point {self.point.tolist()}"
            )
        self.axis = axis / length
        self.radius = _check_radius(radius, side)
        self.side = side

    def _radial(self, x):
        """The component of x - point normal to the axis, and the radius (constants)."""
        _check_dimension(self.point, x, "the cylinder's point")
        point, radius, axis = _constants(self, x, self.point, self.radius, self.axis)
        r = x - point
        return r - ufl.dot(r, axis) * axis, radius

    def __repr__(self):
        return (
            f"CylinderObstacle(point={self.point.tolist()}, axis={self.axis.tolist()}, "
            f"radius={self.radius!r}, side={self.side!r})"
        )
