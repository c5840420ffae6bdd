"""Piecewise-linear tables of problem data: a value given at increasing points of time or of
a coordinate, interpolated linearly between them and constant beyond the ends, checked once
(:func:`check_table`) and built into UFL as nested conditionals (:func:`table_expression`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import ufl

from ..common.keys import LARGEST, is_number
from ..common.parameters import ParameterError

__all__ = ["MAX_TABLE_POINTS", "check_table", "is_list", "table_expression"]


#: The most points of a piecewise-linear table.
MAX_TABLE_POINTS = 1000


def check_table(points: Sequence[float], values: Sequence[float], *, name: str):
    """Check a piecewise-linear table: points strictly increasing, values, all finite.

    Args:
        points: The abscissae, at least one, strictly increasing.
        values: The values at the points, as many as points.
        name: The key naming the table in messages.

    Returns:
        ``(points, values)`` as tuples of floats.

    Raises:
        ParameterError: Naming the offending entry.
    """
    points, values = _numbers(points, f"{name}.points"), _numbers(values, f"{name}.values")
    if len(points) != len(values):
        requirement = f"one value per point: {len(values)} values for {len(points)} points"
        raise ParameterError(f"{name}.values", list(values), requirement)
    for i in range(1, len(points)):
        if not points[i] > points[i - 1]:
            requirement = (
                f"points must increase strictly: points[{i}] = {points[i]!r} is not greater "
                f"than points[{i - 1}] = {points[i - 1]!r}"
            )
            raise ParameterError(f"{name}.points", list(points), requirement)
    for i in range(1, len(points)):
        if not math.isfinite(_slope(points, values, i)):
            requirement = f"the slope between points[{i - 1}] and points[{i}] is not finite"
            raise ParameterError(f"{name}.points", list(points), requirement)
    return points, values


def table_expression(points: Sequence[float], values: Sequence[float], variable, *, name: str):
    """The piecewise-linear interpolation of a table, constant beyond its ends.

    Args:
        points: The abscissae, strictly increasing (see :func:`check_table`).
        values: The values at the points.
        variable: The scalar UFL expression the table is a function of, e.g. the time ``t``
            (a ``fem.Constant``) or a coordinate ``x[0]``.
        name: The key naming the table in messages.

    Returns:
        A scalar UFL expression: nested ``ufl.conditional``, balanced so that their depth
        grows as log2 of the number of points.

    Raises:
        ParameterError: The table is not valid (:func:`check_table`).
    """
    points, values = check_table(points, values, name=name)
    if len(points) == 1:
        return ufl.as_ufl(values[0])

    def piece(k: int):  # between points[k - 1] and points[k]; 0 and n: beyond the ends
        if k == 0 or k == len(points):
            return ufl.as_ufl(values[max(k - 1, 0)])
        return values[k - 1] + _slope(points, values, k) * (variable - points[k - 1])

    def pieces(low: int, high: int):
        if low == high:
            return piece(low)
        middle = (low + high) // 2
        below = ufl.lt(variable, points[middle])
        return ufl.conditional(below, pieces(low, middle), pieces(middle + 1, high))

    return pieces(0, len(points))


def _numbers(numbers, name: str) -> tuple[float, ...]:
    if not is_list(numbers):
        raise ParameterError(name, numbers, "must be a list of numbers")
    if not 1 <= len(numbers) <= MAX_TABLE_POINTS:
        requirement = f"must have from 1 to {MAX_TABLE_POINTS} entries, has {len(numbers)}"
        raise ParameterError(name, list(numbers), requirement)
    for i, number in enumerate(numbers):
        if not (is_number(number) and math.isfinite(number) and abs(number) <= LARGEST):
            requirement = f"entry [{i}] = {number!r} is not a finite number of size <= {LARGEST:g}"
            raise ParameterError(name, list(numbers), requirement)
    return tuple(float(number) for number in numbers)


def is_list(value) -> bool:
    """Whether ``value`` is a list of entries (a sequence or an array, not a text)."""
    return isinstance(value, (Sequence, np.ndarray)) and not isinstance(value, (str, bytes))


def _slope(points, values, k: int) -> float:
    try:
        return (values[k] - values[k - 1]) / (points[k] - points[k - 1])
    except (OverflowError, ZeroDivisionError):
        return math.inf
