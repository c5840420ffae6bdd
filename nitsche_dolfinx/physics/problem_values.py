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

Texts are checked before a run where the problem evaluates them
(:meth:`ProblemValue.check_finite`, :func:`check_finite_texts`): a value that is not
finite there at t = 0 (``"1/t"``) is refused naming it, instead of a Newton solve that
fails on NaN.
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from ufl.algorithms.analysis import extract_type

from ..common import compat
from ..common.keys import LARGEST
from ..common.parameters import ParameterError
from .expressions import evaluate, expression, has_text, parse_expression, vector_expression

__all__ = ["ProblemValue", "as_array", "check_finite_texts"]


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
        #: The value as given (for messages), and its texts (None: no text).
        self.given, self.texts = value, None
        self._function = None  # a Python function of t
        #: The fem.Constant of a constant or of a function of t (None for UFL values).
        self.constant = None
        if isinstance(value, ufl.core.expr.Expr):
            self.ufl = _shaped(value, shape, what)
        elif has_text(value):
            texts = list(np.atleast_1d(np.asarray(value, dtype=object)))
            self.ufl = _shaped(_texts(texts, mesh, time, shape, what), shape, what)
            self.texts, self._gdim = texts, mesh.geometry.dim
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

    def check_finite(self, points, comm, t: float = 0.0, name: str = "value") -> None:
        """Refuse texts whose value at time t is not finite at ``points`` (see
        :func:`check_finite_texts`); other values are checked when made."""
        if self.texts is not None:
            check_finite_texts(self.texts, self._gdim, points, comm, t, name, self.given,
                               self.what)  # fmt: skip

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


def check_finite_texts(texts, gdim: int, points, comm, t, name: str, given, what: str) -> None:
    """Refuse expression texts (numbers and texts, one per component) whose value at time
    ``t`` (None: a value in space only) is not finite, or above
    :data:`~nitsche_dolfinx.common.keys.LARGEST` in magnitude, at ``points``: the points of this
    rank where the problem evaluates them (shape (gdim or 3, N), or a function that gives
    them, called only for a text of the position). A text of t alone is checked once.
    Collective: every rank raises the same :class:`~nitsche_dolfinx.common.parameters.
    ParameterError`, naming ``name`` with the value ``given``.
    """
    found = None
    for index, text in enumerate(texts):
        tree = parse_expression(text, name=name, gdim=gdim)
        if tree.uses_space:
            points = points() if callable(points) else np.asarray(points, dtype=float)
            where = points
        else:
            where = np.zeros((gdim, 1))
        values = evaluate(tree, where, t) if where.shape[1] else np.zeros(0)
        bad = np.flatnonzero(~(np.isfinite(values) & (np.abs(values) <= LARGEST)))
        if bad.size:
            at = where[:gdim, bad[0]].tolist() if tree.uses_space else None
            found = (index, float(values[bad[0]]), at)
            break
    found = next((each for each in comm.allgather(found) if each is not None), None)
    if found is None:
        return
    index, value, at = found
    text = texts[index] if isinstance(texts[index], str) else repr(texts[index])
    which = f"component {index} ({text!r})" if len(texts) > 1 else repr(text)
    when = "" if t is None else f" at t = {t:g}"
    where = "" if at is None else f" at x = [{', '.join(f'{c:g}' for c in at)}]"
    raise ParameterError(
        name, given,
        f"{which} is {value:g}{when}{where}: the {what} must be finite (of magnitude at most "
        f"{LARGEST:g}) where the body is",
    )  # fmt: skip


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
