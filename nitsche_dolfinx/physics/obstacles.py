"""Rigid obstacles, described by a signed distance d(x) (d > 0 on the admissible side).

The obstacle normal is ``n_c = -grad d / |grad d|``: it points from the body
into the obstacle. The initial gap is ``g(x) = d(x)`` in the reference
configuration (docs/method.md section 1).

:data:`OBSTACLES` names the obstacles a configuration can place (``[[obstacle]] type =
NAME``), with their keys (the keyword arguments of their class) and the dimensions they
exist in: the TOML schema, its checks, the builder and ``nitsche-dolfinx schema`` read
them there, so that a new shape is a class and an entry of that table.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import ufl
from dolfinx import fem
from ufl.domain import extract_unique_domain

from ..common.keys import LARGEST, REQUIRED, Key, is_number
from ..common.parameters import require, require_positive

__all__ = [
    "OBSTACLES",
    "CylinderObstacle",
    "Obstacle",
    "ObstacleType",
    "PlaneObstacle",
    "SignedDistanceObstacle",
    "SphereObstacle",
]


class Obstacle:
    """A rigid obstacle: subclasses define :meth:`distance`."""

    #: Whether it moves in time (:class:`~nitsche_dolfinx.physics.motion.MovingObstacle`).
    moving = False

    def distance(self, x):
        """Signed distance d(x) as a UFL expression of the spatial coordinate ``x``."""
        raise NotImplementedError

    def gap(self, x):
        """Initial gap g(x) = d(x)."""
        return self.distance(x)

    def normal(self, x):
        """Obstacle normal n_c = -grad d / norm(grad d) (from the body into the obstacle)."""
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
        self.point = _coordinates(point, "point", "the plane's point")
        self.unit_normal = _direction(normal, "normal", "the plane's normal", self.point)

    def distance(self, x):
        return ufl.dot(
            x - ufl.as_vector(self.point.tolist()), ufl.as_vector(self.unit_normal.tolist())
        )

    def normal(self, x):
        # a Constant rather than literals: FFCx 0.5 cannot generate the friction terms'
        # tangential projection I - n_c n_c^T when its entries are literal numbers
        return fem.Constant(_domain(x), -self.unit_normal)

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


def _coordinates(value, name: str, what: str) -> np.ndarray:
    """``value``, a number or a list of 1 to 3 numbers, finite and of magnitude at most
    :data:`~nitsche_dolfinx.common.keys.LARGEST` (the distances square them), as an array;
    :class:`~nitsche_dolfinx.common.parameters.ParameterError` naming ``name`` otherwise."""
    items = value.tolist() if isinstance(value, np.ndarray) else value
    items = [items] if is_number(items) else items
    fits = isinstance(items, (list, tuple)) and 1 <= len(items) <= 3
    require(
        fits and all(is_number(x) for x in items), name, value, f"{what} must be 1 to 3 numbers"
    )
    array = np.asarray(items, dtype=float)
    require(np.all(np.isfinite(array)), name, array.tolist(), f"{what} must be finite")
    require(
        np.all(np.abs(array) <= LARGEST),
        name,
        array.tolist(),
        f"{what} must have coordinates of magnitude at most {LARGEST:g}",
    )
    return array


def _unit(vector: np.ndarray, name: str, what: str) -> np.ndarray:
    length = float(np.linalg.norm(vector))
    require(length > 0.0, name, vector.tolist(), f"{what} must have a non-zero length")
    return vector / length


def _direction(values, name: str, what: str, point: np.ndarray) -> np.ndarray:
    """A direction given with as many coordinates as ``point``, made unit."""
    direction = _coordinates(values, name, what)
    require(
        direction.shape == point.shape,
        name,
        direction.tolist(),
        f"the {name} must have as many coordinates as the point {point.tolist()}",
    )
    return _unit(direction, name, what)


def _check_side(side: str) -> str:
    require(side in ("outside", "inside"), "side", side, "where the body is: 'outside' or 'inside'")
    return side


def _constants(obstacle, x, *values) -> tuple:
    """``values`` as fem.Constants on the mesh of ``x``, made once per obstacle and mesh
    (the gap and the normal share them)."""
    domain = _domain(x)
    cached = obstacle.__dict__.get("_constants")
    if cached is None or cached[0] is not domain:
        cached = obstacle._constants = (domain, tuple(fem.Constant(domain, v) for v in values))
    return cached[1]


def _domain(x):
    """The mesh of a UFL expression of the position (the position itself, or a moved one:
    :mod:`~nitsche_dolfinx.physics.motion`)."""
    return extract_unique_domain(x)


def _check_dimension(array: np.ndarray, x, what: str) -> None:
    if array.size != x.ufl_shape[0]:
        raise ValueError(
            f"{what} {array.tolist()} has {array.size} coordinates, the mesh has {x.ufl_shape[0]}"
        )


class _RadialObstacle(Obstacle):
    """An obstacle at ``radius`` from a centre (sphere) or an axis (cylinder): d and n
    from the radial vector r that :meth:`_radial` gives with the radius, d = norm(r) - R
    outside (-d inside) and n = -r / norm(r) outside (r / norm(r) inside)."""

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
        side: Where the body is: ``"outside"`` (a rigid ball, d = norm(x - c) - R) or
            ``"inside"`` (a spherical cavity, d = R - norm(x - c)).
    """

    def __init__(self, center: Sequence[float], radius: float, side: str = "outside"):
        self.center = _coordinates(center, "center", "the sphere's centre")
        self.radius = require_positive(radius, "radius", "the radius")
        self.side = _check_side(side)

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
        self.point = _coordinates(point, "point", "the cylinder's point")
        self.axis = _direction(axis, "axis", "the cylinder's axis", self.point)
        self.radius = require_positive(radius, "radius", "the radius")
        self.side = _check_side(side)

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


@dataclass(frozen=True)
class ObstacleType:
    """An obstacle of a configuration: what it is, the class that makes it (its keys are
    the class's keyword arguments), its keys and the dimensions of the meshes it exists in.
    """

    meaning: str
    make: Callable[..., Obstacle]
    keys: dict[str, Key]
    dimensions: tuple[int, ...]


_SIDE = Key("string", "outside", "where the body is (inside: a cavity)", ("outside", "inside"))
_RADIUS = Key("number", REQUIRED, "the radius")

#: The obstacles of ``[[obstacle]] type = NAME``, by name.
OBSTACLES: dict[str, ObstacleType] = {
    "plane": ObstacleType(
        "the half-space bounded by the plane through point",
        PlaneObstacle,
        {
            "point": Key("vector", REQUIRED, "a point of the plane"),
            "normal": Key("vector", REQUIRED, "the normal of the plane, towards the body"),
        },
        (1, 2, 3),
    ),
    "circle": ObstacleType(
        "a circle",
        SphereObstacle,
        {"center": Key("vector", REQUIRED, "the centre"), "radius": _RADIUS, "side": _SIDE},
        (2,),
    ),
    "sphere": ObstacleType(
        "a sphere",
        SphereObstacle,
        {"center": Key("vector", REQUIRED, "the centre"), "radius": _RADIUS, "side": _SIDE},
        (3,),
    ),
    "cylinder": ObstacleType(
        "a circular cylinder",
        CylinderObstacle,
        {
            "point": Key("vector", REQUIRED, "a point of the axis"),
            "axis": Key("vector", REQUIRED, "the direction of the axis"),
            "radius": _RADIUS,
            "side": _SIDE,
        },
        (3,),
    ),
}
