"""Values of a configuration that vary in time or in space, as small tables: never code.

A value in time (loads, Dirichlet values) is one of

- a constant: a number (1D) or a vector, ``[0.0, -1.0]``;
- a piecewise-linear table ``[[t0, v...], [t1, v...], ...]``: times increasing, the value
  linear in between and held constant before the first time and after the last;
- a named profile, an inline table: ``{ profile = "ramp", value = [0.0, -1.0],
  duration = 2.0 }`` (from 0 at t = 0 to ``value`` at ``duration``, then held) or
  ``{ profile = "sine", amplitude = [0.0, 1.0], frequency = 0.5, phase = 0.0 }``
  (amplitude sin(2 pi frequency t + phase)).

A value in time may also vary in space: a vector whose components are numbers or texts of
the expression language of :mod:`~nitsche_dolfinx.physics.expressions` (x, y, z, t, numbers,
``+ - * / ^``, sin, cos, tan, exp, log, sqrt, abs, min, max, pi, e and ``a if condition
else b``), e.g. ``["0", "-9.81 * (1 + 0.1 * sin(pi * x))"]``, or one text for one component;
the text is parsed, never evaluated as Python.

A value in space (initial displacement and velocity) is a constant, a vector of numbers and
expression texts of x, y, z (no t), or a polynomial of
degree at most 2 in x, ``{ constant = c, gradient = G, hessian = H }`` (each optional):
u_i(x) = c_i + G_ij x_j + 1/2 H_ijk x_j x_k. The bar's u0 = 1/2 - x/2 is
``{ constant = [0.5], gradient = [[-0.5]] }``.

:func:`check_time_value` and :func:`check_field_value` check the form (finite numbers,
consistent rows, increasing times) and return its number of components;
:func:`time_value` and :func:`field_value` turn a checked form into what
:class:`~nitsche_dolfinx.model.problem.ContactProblem` takes: a constant vector or a function.
A bad form raises ``ValueError`` with what it must be.
"""

from __future__ import annotations

import math

import numpy as np

from ..common.keys import LARGEST, is_number, shown
from ..common.parameters import ParameterError
from .expressions import has_text, parse_expression

__all__ = [
    "FIELD_KEYS",
    "PROFILES",
    "PiecewiseLinear",
    "PolynomialField",
    "Ramp",
    "Sine",
    "check_field_value",
    "check_time_value",
    "field_value",
    "time_value",
]


class PiecewiseLinear:
    """The value of a table ``[[t0, v...], [t1, v...], ...]`` at time t: linear between the
    rows, constant outside them."""

    def __init__(self, rows):
        table = np.asarray(rows, dtype=float)
        self.times, self.values = table[:, 0], table[:, 1:]

    def __call__(self, t: float) -> np.ndarray:
        return np.array([np.interp(t, self.times, column) for column in self.values.T], dtype=float)


class Ramp:
    """From 0 at t = 0 to ``value`` at t = ``duration``, then held."""

    def __init__(self, value, duration: float):
        self.value, self.duration = np.asarray(value, dtype=float).reshape(-1), float(duration)

    def __call__(self, t: float) -> np.ndarray:
        return self.value * min(max(t / self.duration, 0.0), 1.0)


class Sine:
    """``amplitude`` sin(2 pi ``frequency`` t + ``phase``)."""

    def __init__(self, amplitude, frequency: float, phase: float = 0.0):
        self.amplitude = np.asarray(amplitude, dtype=float).reshape(-1)
        self.frequency, self.phase = float(frequency), float(phase)

    def __call__(self, t: float) -> np.ndarray:
        return self.amplitude * math.sin(2.0 * math.pi * self.frequency * t + self.phase)


#: Named profiles: name -> (class, its keys: required (True) or not).
PROFILES = {
    "ramp": (Ramp, {"value": True, "duration": True}),
    "sine": (Sine, {"amplitude": True, "frequency": True, "phase": False}),
}


class PolynomialField:
    """u_i(x) = c_i + G_ij x_j + 1/2 H_ijk x_j x_k on the points x (shape (3, N)) of dolfinx's
    interpolation; missing terms are zero."""

    def __init__(self, size: int, constant=None, gradient=None, hessian=None):
        self.size = size
        self.constant = np.zeros(size) if constant is None else _array(constant, (size,))
        self.gradient = None if gradient is None else _array(gradient, (size, size))
        self.hessian = None if hessian is None else _array(hessian, (size, size, size))

    def __call__(self, x: np.ndarray) -> np.ndarray:
        points = x[: self.size]
        values = np.repeat(self.constant[:, None], points.shape[1], axis=1)
        if self.gradient is not None:
            values = values + self.gradient @ points
        if self.hessian is not None:
            values = values + 0.5 * np.einsum("ijk,jn,kn->in", self.hessian, points, points)
        return values


#: The keys of a polynomial value in space, with the shape each has for a mesh of dimension d.
FIELD_KEYS = {"constant": "d", "gradient": "d x d", "hessian": "d x d x d"}


def _array(value, shape) -> np.ndarray:
    array = np.asarray(value, dtype=float)
    if array.shape != shape:
        raise ValueError(f"must have the shape {' x '.join(map(str, shape))}")
    return array


def _finite(numbers) -> bool:
    """Finite numbers of magnitude at most :data:`~nitsche_dolfinx.common.keys.LARGEST`."""
    return all(math.isfinite(x) and abs(x) <= LARGEST for x in numbers)


#: What the numbers of a value must be.
_FINITE = f"must be finite (no nan or inf), of magnitude at most {LARGEST:g}"


def _vector(value, what: str = "a number or a list of numbers") -> list[float]:
    """``value`` as a list of finite floats (a number is a list of one)."""
    items = [value] if is_number(value) else value
    if not isinstance(items, list) or not items or not all(is_number(x) for x in items):
        raise ValueError(f"must be {what}")
    if not _finite(items):
        raise ValueError(_FINITE)
    return [float(x) for x in items]


def check_time_value(value) -> int:
    """Check a value in time (see the module docstring); its number of components."""
    if has_text(value):
        return _check_texts(value, time=True)
    if isinstance(value, dict):
        return _check_profile(value)
    if isinstance(value, list) and value and all(isinstance(row, list) for row in value):
        rows = [_vector(row, "a row [t, value...] of numbers") for row in value]
        if any(len(row) < 2 for row in rows) or len({len(row) for row in rows}) > 1:
            raise ValueError("must have rows [t, value...] of one length (a time and the value)")
        times = [row[0] for row in rows]
        if any(b <= a for a, b in zip(times, times[1:])):
            raise ValueError(f"must have increasing times, got {shown(times)}")
        return len(rows[0]) - 1
    return len(
        _vector(value, "a number, a list of numbers, a table [[t, value...], ...] or a profile")
    )


def _check_profile(value: dict) -> int:
    name = value.get("profile")
    if name not in PROFILES:
        raise ValueError(f"needs profile = one of {', '.join(PROFILES)} (got {name!r})")
    _, keys = PROFILES[name]
    for key in value:
        if key != "profile" and key not in keys:
            raise ValueError(f"has {key!r}, not a key of the {name!r} profile ({', '.join(keys)})")
    for key, required in keys.items():
        if required and key not in value:
            raise ValueError(f"misses {key!r} (the {name!r} profile takes {', '.join(keys)})")
    scalars = {key: v for key, v in value.items() if key not in ("profile", "value", "amplitude")}
    for key, number in scalars.items():
        if not is_number(number) or not _finite([number]):
            raise ValueError(f"{key} must be a finite number, at most {LARGEST:g}, got {number!r}")
    for key in ("duration", "frequency"):
        if key in scalars and scalars[key] <= 0:
            raise ValueError(f"{key} must be positive, got {scalars[key]!r}")
    return len(_vector(value["value" if name == "ramp" else "amplitude"]))


def check_field_value(value) -> int:
    """Check a value in space (see the module docstring); its number of components."""
    if has_text(value):
        return _check_texts(value, time=False)
    if not isinstance(value, dict):
        return len(_vector(value, "a number, a list of numbers or {constant, gradient, hessian}"))
    unknown = [key for key in value if key not in FIELD_KEYS]
    if unknown or not value:
        raise ValueError(f"takes the keys {', '.join(FIELD_KEYS)} (u_i = c_i + G_ij x_j + ...)")
    sizes = set()
    for key, array in value.items():
        numbers = np.asarray(array, dtype=object)
        flat = numbers.ravel().tolist()
        rank = len(FIELD_KEYS[key].split(" x "))
        if numbers.ndim != rank or not all(is_number(x) for x in flat):
            raise ValueError(f"{key} must be an array of numbers of shape {FIELD_KEYS[key]}")
        if len(set(numbers.shape)) != 1:
            raise ValueError(f"{key} must be of shape {FIELD_KEYS[key]}")
        if not _finite(flat):
            raise ValueError(f"{key} {_FINITE}")
        sizes.add(numbers.shape[0])
    if len(sizes) != 1:
        raise ValueError("constant, gradient and hessian must be of one dimension d")
    return sizes.pop()


def _check_texts(value, time: bool) -> int:
    """Check a vector of numbers and expression texts (or one text); its number of
    components. The names are checked for three dimensions here, and against the mesh's
    when the problem is built; ``t`` only in a value in time."""
    items = [value] if isinstance(value, str) else value
    for index, item in enumerate(items):
        name = f"component {index}" if len(items) > 1 else "the expression"
        try:
            tree = parse_expression(item, name=name, gdim=3)
        except ParameterError as error:
            raise ValueError(f"{name}: {error.requirement}") from None
        if tree.uses_time and not time:
            raise ValueError(f"{name}: 't' (time) is not available in an initial value")
    return len(items)


def time_value(value):
    """A checked value in time as a constant list or a function of t."""
    if isinstance(value, dict):
        cls, _ = PROFILES[value["profile"]]
        return cls(**{key: v for key, v in value.items() if key != "profile"})
    if has_text(value):  # made UFL by the problem (problem_values.ProblemValue)
        return value
    if isinstance(value, list) and value and isinstance(value[0], list):
        return PiecewiseLinear(value)
    return _vector(value)


def field_value(value, size: int):
    """A checked value in space as a constant list or a function of x (texts as they are:
    the problem makes them UFL)."""
    if has_text(value):
        return value
    if isinstance(value, dict):
        return PolynomialField(size, **value)
    return _vector(value)
