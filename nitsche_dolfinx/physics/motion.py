"""Rigid obstacles that move: a shape of :mod:`~nitsche_dolfinx.physics.obstacles` carried by a
prescribed rigid motion (docs/method.md section 13).

The motion moves the shape's points X to ``x = p + c(t) + R(t) (X - p)``: a translation
c(t) and a rotation R(t) by an angle theta(t) about the pivot p (about the z axis in 2D,
about a fixed axis in 3D). The moved obstacle's signed distance and normal at x are the
shape's at ``X(x, t) = p + R(t)^T (x - p - c(t))``, the normal turned by R(t)::

    d(x, t) = d_0(X(x, t)),    n_c(x, t) = R(t) n_0(X(x, t))

A time scheme sees the obstacle at up to three times of a step (docs/method.md section
13): ``"old"`` (t^n), ``"mid"`` (t^{n+1/2}) and ``"new"`` (t^{n+1}), each a set of
runtime constants that :meth:`MovingObstacle.move` sets, so that the forms are compiled once.
The translation and the angle are functions of t: Python functions (numbers out) or texts
of the expression language of :mod:`~nitsche_dolfinx.physics.expressions` in t (the TOML route).

Example: a plane pushed down at speed 0.1::

    MovingObstacle(PlaneObstacle([0.0, 1.0], [0.0, -1.0]), translation=lambda t: [0.0, -0.1 * t])
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import ufl
from dolfinx import fem

from ..common.keys import Key
from ..common.parameters import ParameterError, require
from .expressions import has_text, parse_expression, to_ufl
from .obstacles import Obstacle, PlaneObstacle, _coordinates, _unit
from .problem_values import as_array

__all__ = ["LEVELS", "MOTION_KEYS", "MovingObstacle"]

#: The times of a step at which a scheme may see a moving obstacle.
LEVELS = ("old", "mid", "new")

#: The keys of an ``[[obstacle]]`` table that move it (any type): with ``translation`` or
#: ``angle``, the obstacle is a :class:`MovingObstacle`.
MOTION_KEYS = {
    "translation": Key("value in time", None, "moves the obstacle: its translation c(t), a "
                       "value in time (texts of t, a table, a profile)"),
    "angle": Key("scalar in time", None, "turns the obstacle: its angle theta(t) in radians "
                 "about the pivot (2D: about z; 3D: about rotation_axis)"),
    "pivot": Key("vector", None, "the point the angle turns the obstacle about (default: the "
                 "origin)"),
    "rotation_axis": Key("vector", None, "the axis of the angle's rotation, in 3D"),
}  # fmt: skip


class _LevelValue:
    """A function of t (a Python function, or texts of t) held at each level of a step
    as UFL: a ``fem.Constant`` that :meth:`set` fills for a Python function, the UFL of
    the texts with a time constant per level otherwise."""

    def __init__(self, value, shape: tuple[int, ...], what: str, name: str):
        self.value, self.shape, self.what, self.name = value, shape, what, name
        self.texts = has_text(value)
        if not (self.texts or callable(value)):
            raise ParameterError(
                name, value, f"the {what} must be a function of t or texts of t (a TOML "
                "value in time)",
            )  # fmt: skip
        self.levels: dict[str, object] = {}
        self._constants: dict[str, fem.Constant] = {}

    def bind(self, mesh) -> None:
        """Make the level values on ``mesh`` (checking the texts against its dimension)."""
        x = ufl.SpatialCoordinate(mesh)
        gdim = mesh.geometry.dim
        if self.texts:
            texts = [self.value] if isinstance(self.value, str) else list(self.value)
            size = 1 if self.shape == () else self.shape[0]
            require(len(texts) == size, self.name, self.value,
                    f"the {self.what} has {size} component{'s' * (size > 1)}")  # fmt: skip
            trees = []
            for i, text in enumerate(texts):
                name = self.name if len(texts) == 1 else f"{self.name}[{i}]"
                tree = parse_expression(text, name=name, gdim=gdim)
                require(not tree.uses_space, name, text, "a motion depends on t only")
                trees.append(tree)
            for level in LEVELS:
                t = self._constants[level] = fem.Constant(mesh, 0.0)
                values = [to_ufl(tree, x, t) for tree in trees]
                self.levels[level] = ufl.as_vector(values) if self.shape != () else values[0]
        else:
            for level in LEVELS:
                start = np.zeros(self.shape)
                self.levels[level] = self._constants[level] = fem.Constant(mesh, start)
        for level in LEVELS:
            self.set(level, 0.0)

    def set(self, level: str, t: float) -> None:
        """Move the level to time t."""
        if self.texts:
            self._constants[level].value = t
            return
        try:
            value = self.value(t)
        except Exception as error:  # the user's function: named, with its own words
            raise ParameterError(self.name, self.value, f"failed at t = {t!r}: {error}") from None
        shape = (1,) if self.shape == () else self.shape
        try:
            array = as_array(value, shape, f"the {self.what} at t = {t!r}")
        except ValueError as error:
            raise ParameterError(self.name, value, str(error)) from None
        self._constants[level].value = array.reshape(self.shape)


class MovingObstacle(Obstacle):
    """A rigid obstacle moved by a prescribed rigid motion (see the module docstring).

    Args:
        shape: The obstacle at t = 0 (:mod:`~nitsche_dolfinx.physics.obstacles`: a plane, a sphere,
            a cylinder, any signed distance).
        translation: c(t), a function of t returning the mesh's number of coordinates, or
            one text of t per coordinate (``["0", "-0.1 * t"]``); None: no translation.
        angle: theta(t) in radians, a function of t or a text of t; None: no rotation (2D
            and 3D only).
        pivot: The point p the rotation turns about (default: the origin).
        axis: The axis of the rotation in 3D (any non-zero length; right-handed).
    """

    moving = True

    def __init__(
        self,
        shape: Obstacle,
        translation: Callable | list | None = None,
        angle: Callable | str | None = None,
        pivot=None,
        axis=None,
    ):
        require(isinstance(shape, Obstacle) and not isinstance(shape, MovingObstacle), "shape",
                shape, "a rigid obstacle of nitsche_dolfinx.physics.obstacles")  # fmt: skip
        require(translation is not None or angle is not None, "translation", translation,
                "a moving obstacle needs a translation, an angle or both")  # fmt: skip
        self.shape = shape
        self._translation, self._angle = translation, angle
        self.pivot = None if pivot is None else _coordinates(pivot, "pivot", "the pivot")
        self.axis = None
        if axis is not None:
            self.axis = _unit(_coordinates(axis, "axis", "the axis"), "axis", "the axis")
        self.translation = self.angle = None  # _LevelValues, made by bind
        self.mesh = None

    @property
    def turns(self) -> bool:
        """Whether the normal at a point of the body changes in time: a rotation, or a shape
        other than a plane."""
        return self._angle is not None or not isinstance(self.shape, PlaneObstacle)

    def bind(self, mesh) -> None:
        """Make the motion's runtime constants on ``mesh`` (the problem calls it when the
        obstacle is added), checking the motion against the mesh's dimension."""
        gdim = mesh.geometry.dim
        if self._translation is not None:
            self.translation = _LevelValue(self._translation, (gdim,), "translation",
                                           "translation")  # fmt: skip
            self.translation.bind(mesh)
        if self._angle is not None:
            require(gdim > 1, "angle", self._angle, "a 1D obstacle can only translate")
            if gdim == 3:
                require(self.axis is not None, "axis", None,
                        "a rotation in 3D needs its axis")  # fmt: skip
                require(self.axis.size == 3, "axis", self.axis.tolist(), "3 coordinates")
            self.angle = _LevelValue(self._angle, (), "angle", "angle")
            self.angle.bind(mesh)
        pivot = np.zeros(gdim) if self.pivot is None else self.pivot
        require(pivot.size == gdim, "pivot", pivot.tolist(),
                f"the pivot has {gdim} coordinates on this mesh")  # fmt: skip
        self._pivot = fem.Constant(mesh, pivot)
        self.mesh = mesh

    def move(self, t_old: float, t_new: float | None = None) -> None:
        """Put the levels of a step from ``t_old`` to ``t_new`` (default: all at t_old)."""
        t_new = t_old if t_new is None else t_new
        times = {"old": t_old, "mid": (t_old + t_new) / 2, "new": t_new}
        for value in (self.translation, self.angle):
            if value is not None:
                for level, t in times.items():
                    value.set(level, t)

    # -- the shape at a level ---------------------------------------------------------------

    def _rotation(self, level: str):
        """R(t) at the level as a UFL matrix (None without rotation)."""
        if self.angle is None:
            return None
        theta = self.angle.levels[level]
        c, s = ufl.cos(theta), ufl.sin(theta)
        if self.mesh.geometry.dim == 2:
            return ufl.as_matrix([[c, -s], [s, c]])
        a = ufl.as_vector(self.axis.tolist())
        cross = ufl.as_matrix([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
        return c * ufl.Identity(3) + s * cross + (1 - c) * ufl.outer(a, a)

    def _shape_point(self, x, level: str):
        """X(x, t) = p + R^T (x - p - c) at the level: where the shape is asked."""
        relative = x - self._pivot
        if self.translation is not None:
            relative = relative - self.translation.levels[level]
        rotation = self._rotation(level)
        if rotation is not None:
            relative = ufl.dot(rotation.T, relative)
        return self._pivot + relative

    def distance(self, x, level: str = "new"):
        """d(x, t) = d_0(X(x, t)) at the level."""
        return self.shape.distance(self._shape_point(x, level))

    def gap(self, x, level: str = "new"):
        """The gap at the level: the distance."""
        return self.distance(x, level)

    def normal(self, x, level: str = "new"):
        """n_c(x, t) = R n_0(X(x, t)) at the level; for a shape with the generic normal
        (a signed distance), -grad d / norm(grad d) of the moved distance, which is the same."""
        if type(self.shape).normal is Obstacle.normal:
            grad_d = ufl.grad(self.distance(x, level))
            return -grad_d / ufl.sqrt(ufl.dot(grad_d, grad_d))
        normal = self.shape.normal(self._shape_point(x, level))
        rotation = self._rotation(level)
        return normal if rotation is None else ufl.dot(rotation, normal)

    def __repr__(self):
        return f"MovingObstacle({self.shape!r}, translation={self._translation!r}, " \
               f"angle={self._angle!r})"  # fmt: skip
