"""The values of a problem's data: body forces, tractions, Dirichlet values, initial fields
(docs/method.md section 13).

A value is one of

- a constant: a number (one component) or a vector;
- a Python function of t returning one, held in a ``fem.Constant`` that
  :meth:`ProblemValue.set_time` moves;
- a UFL expression of the problem's position ``problem.x`` (``ufl.SpatialCoordinate``) and
  time ``problem.t`` (a ``fem.Constant``), e.g. ``ufl.as_vector([0, -9.81 * problem.t])``;
- a list of numbers and texts of the expression language of
  :mod:`~nitsche_dolfinx.physics.expressions` (the TOML route), e.g. ``[0, "-9.81 * t"]``, turned
  into the same UFL.

The forms take :attr:`ProblemValue.ufl` whatever the kind; the values at dofs (Dirichlet
values, the explicit scheme's lumped load) are interpolated from it at the time asked for.
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from ufl.algorithms.analysis import extract_type

from ..common import compat
from ..common.keys import LARGEST
from .expressions import expression, has_text, vector_expression

__all__ = ["ProblemValue", "as_array"]


class ProblemValue:
    """A value of the problem's data of ``shape`` ((gdim,), or (1,) for one component).

    Args:
        mesh: The mesh.
        time: The problem's time, a scalar ``fem.Constant`` (the t of UFL values and texts).
        value: A constant, a function of t, a UFL expression or a list of numbers and texts.
        shape: The shape of the value.
        what: What it is, in words, for messages (e.g. ``"body force"``).
    """

    def __init__(self, mesh, time, value, shape: tuple[int, ...], what: str):
        self.shape, self.what, self._time = shape, what, time
        self._function = None  # a Python function of t
        #: The fem.Constant of a constant or of a function of t (None for UFL values).
        self.constant = None
        if isinstance(value, ufl.core.expr.Expr):
            self.ufl = _shaped(value, shape, what)
        elif has_text(value):
            texts = list(np.atleast_1d(np.asarray(value, dtype=object)))
            self.ufl = _shaped(_texts(texts, mesh, time, shape, what), shape, what)
        else:
            if callable(value):
                self._function = value
            initial = value(0.0) if callable(value) else value
            self.constant = fem.Constant(mesh, as_array(initial, shape, what))
            self.ufl = self.constant
        self._interpolation: dict[int, fem.Expression] = {}

    @property
    def time_dependent(self) -> bool:
        """Whether the value may change with t: a function of t, or a UFL value with a
        constant or a coefficient in it (the problem's t, or the user's own)."""
        if self.constant is not None:
            return self._function is not None
        return bool(extract_type(self.ufl, ufl.Constant) or extract_type(self.ufl, ufl.Coefficient))

    @property
    def space_dependent(self) -> bool:
        """Whether the value is a UFL value (which may vary in space)."""
        return self.constant is None

    def value_at(self, t: float) -> np.ndarray:
        """The value at time t of a value constant in space."""
        if self.space_dependent:
            raise ValueError(f"the {self.what} varies in space: interpolate it")
        if self._function is None:
            return np.asarray(self.constant.value)
        return as_array(self._function(t), self.shape, self.what)

    def set_time(self, t: float) -> None:
        """Move a function of t to time t (UFL values follow the problem's t)."""
        if self._function is not None:
            self.constant.value = self.value_at(t)

    def interpolate(self, target: fem.Function, t: float, cells=None) -> None:
        """Interpolate the value (a UFL one: :attr:`space_dependent`) at time t into
        ``target`` (a Function on a vector space of ``shape``'s size, or on the gdim-vector
        space for one component: the value goes to every component), on ``cells``
        (default: all). The problem's t is left as it was."""
        V = target.function_space
        expression = self._interpolation.get(id(V))
        if expression is None:
            size = V.dofmap.index_map_bs
            value = self.ufl if size == self.shape[0] else ufl.as_vector([self.ufl[0]] * size)
            expression = self._interpolation[id(V)] = compat.expression(value, V)
        before = float(self._time.value)
        self._time.value = t
        try:
            if cells is None:
                target.interpolate(expression)
            else:
                target.interpolate(expression, cells)
        finally:
            self._time.value = before


def _texts(texts, mesh, time, shape, what):
    """The UFL vector of the expression texts (and numbers) of a value of ``shape``."""
    if shape == (1,) and len(texts) == 1:  # one component: a scalar expression
        return ufl.as_vector([expression(texts[0], mesh, time, name=what)])
    return vector_expression(texts, mesh, time, name=what)


def _shaped(value, shape, what):
    """A UFL value of ``shape`` (a scalar for one component is made a vector of one)."""
    if value.ufl_shape == () and shape == (1,):
        return ufl.as_vector([value])
    if value.ufl_shape != shape:
        raise ValueError(f"{what} must have shape {shape}, got a UFL value of {value.ufl_shape}")
    return value


def as_array(value, shape, what) -> np.ndarray:
    """``value`` as an array of ``shape`` (a number for ``(1,)``), of finite numbers of
    magnitude at most :data:`~nitsche_dolfinx.common.keys.LARGEST`; ValueError naming ``what``."""
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be numbers, got {value!r}") from None
    if array.shape != shape:
        if array.size != 1 or shape != (1,):
            raise ValueError(f"{what} must have shape {shape}, got {array.tolist()!r}")
        array = array.reshape(shape)
    if not (np.all(np.isfinite(array)) and np.all(np.abs(array) <= LARGEST)):
        raise ValueError(
            f"{what} must be finite, of magnitude at most {LARGEST:g}, got {array.tolist()!r}"
        )
    return array
