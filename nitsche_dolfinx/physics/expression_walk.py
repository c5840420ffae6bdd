"""The walk of a parsed expression of the language of :mod:`nitsche_dolfinx.physics.expressions`:
the whitelist of node types, operators, names and functions it knows, and the value it
computes from them.

The same walk checks an expression and builds its UFL: with :data:`RUNTIME` standing for x
and t it only checks (floats fold, and every constant is checked: a constant exponent at
most :data:`MAX_EXPONENT` in magnitude, every constant finite and at most
:data:`~nitsche_dolfinx.common.keys.LARGEST` in magnitude, no ``1/0``, ``log(-1)`` or
``exp(1000)``); with UFL objects for them it builds the expression. Any other node type
(attribute access, indexing, calls of anything but :data:`FUNCTIONS`, other names) is
refused with a :class:`~nitsche_dolfinx.common.parameters.ParameterError` naming it: no
user text ever runs as Python.
"""

from __future__ import annotations

import ast
import functools
import math
import operator
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import ufl

from ..common.keys import LARGEST
from ..common.parameters import ParameterError

__all__ = [
    "CONSTANTS",
    "COORDINATES",
    "FUNCTIONS",
    "MAX_EXPONENT",
    "RUNTIME",
    "ExpressionWalk",
    "scope",
]

#: The largest magnitude of a constant exponent (``x**100`` is fine, ``2**1000`` is not).
MAX_EXPONENT = 100
#: The names of coordinates, by component.
COORDINATES = ("x", "y", "z")
#: The named constants.
CONSTANTS = {"pi": math.pi, "e": math.e}


@dataclass(frozen=True)
class _Function:
    arity: int | None  # the number of arguments; None: two or more, folded
    number: Callable  # on floats (constant folding)
    form: Callable  # on UFL
    array: Callable  # on numpy arrays (the values at points: evaluate)


def _fold(pair: Callable) -> Callable:
    return lambda *args: functools.reduce(pair, args)


#: The functions an expression may call.
FUNCTIONS = {
    "sin": _Function(1, math.sin, ufl.sin, np.sin),
    "cos": _Function(1, math.cos, ufl.cos, np.cos),
    "tan": _Function(1, math.tan, ufl.tan, np.tan),
    "exp": _Function(1, math.exp, ufl.exp, np.exp),
    "log": _Function(1, math.log, ufl.ln, np.log),
    "sqrt": _Function(1, math.sqrt, ufl.sqrt, np.sqrt),
    "abs": _Function(1, abs, abs, np.abs),
    "min": _Function(None, min, _fold(ufl.min_value), _fold(np.minimum)),
    "max": _Function(None, max, _fold(ufl.max_value), _fold(np.maximum)),
}

_ARITHMETIC = {
    ast.Add: ("+", operator.add),
    ast.Sub: ("-", operator.sub),
    ast.Mult: ("*", operator.mul),
    ast.Div: ("/", operator.truediv),
    ast.Pow: ("**", operator.pow),
}
_COMPARISONS = {
    ast.Lt: ("<", operator.lt, ufl.lt),
    ast.LtE: ("<=", operator.le, ufl.le),
    ast.Gt: (">", operator.gt, ufl.gt),
    ast.GtE: (">=", operator.ge, ufl.ge),
    ast.Eq: ("==", operator.eq, ufl.eq),
    ast.NotEq: ("!=", operator.ne, ufl.ne),
}
#: The tokens of the operators the language refuses, to name them.
_REFUSED_OPERATORS = {
    ast.FloorDiv: "//",
    ast.Mod: "%",
    ast.MatMult: "@",
    ast.BitAnd: "&",
    ast.BitOr: "|",
    ast.LShift: "<<",
    ast.RShift: ">>",
    ast.Invert: "~",
    ast.Not: "not",
    ast.In: "in",
    ast.NotIn: "not in",
    ast.Is: "is",
    ast.IsNot: "is not",
}
#: What the refused node types are, in the user's words.
_REFUSED_NODES = {
    ast.Attribute: "'.' (attribute access)",
    ast.Subscript: "'[...]' (indexing)",
    ast.Lambda: "'lambda'",
    ast.NamedExpr: "':=' (assignment)",
    ast.Starred: "'*' (unpacking)",
    ast.JoinedStr: "an f-string",
    ast.FormattedValue: "an f-string",
    ast.ListComp: "a comprehension ('for')",
    ast.SetComp: "a comprehension ('for')",
    ast.DictComp: "a comprehension ('for')",
    ast.GeneratorExp: "a generator ('for')",
    ast.Tuple: "a tuple (',' or '()')",
    ast.List: "a list ('[...]')",
    ast.Set: "a set ('{...}')",
    ast.Dict: "a dict ('{...}')",
    ast.Await: "'await'",
    ast.Yield: "'yield'",
    ast.YieldFrom: "'yield'",
}


class _Runtime:
    """A value known only when the expression runs (x, t): what the check computes with."""

    def _same(self, *_):
        return self

    __add__ = __radd__ = __sub__ = __rsub__ = __mul__ = __rmul__ = _same
    __truediv__ = __rtruediv__ = __pow__ = __rpow__ = __neg__ = __pos__ = __abs__ = _same


#: The stand-in for x and t while an expression is only checked.
RUNTIME = _Runtime()


def _runtime(*values) -> bool:
    return any(value is RUNTIME for value in values)


def scope(gdim: int, coordinates: list, t) -> dict:
    """The names an expression on a mesh of dimension gdim may use, and their values."""
    return {**dict(zip(COORDINATES[:gdim], coordinates)), "t": t, **CONSTANTS}


def _number(value: float) -> str:
    """A constant as a user would write it: ``1000000``, not ``1e+06``."""
    return str(int(value)) if value.is_integer() and abs(value) < 1e30 else repr(value)


class ExpressionWalk:
    """Walks a parsed expression, node types from a whitelist only, and computes its value
    from ``names``: floats fold, :data:`RUNTIME` stands for x and t when checking, UFL
    objects when building. Conditions are Python bools when constant."""

    def __init__(self, text: str, source: str, name: str, names: dict, numeric: bool = False):
        self.text, self.source, self.name, self.names = text, source, name, names
        self.numeric = numeric  # numpy arrays for x and t (evaluate), not UFL
        self.used: set[str] = set()

    def fail(self, requirement: str):
        """Refuse the expression: a ParameterError naming its key, its text and why."""
        raise ParameterError(self.name, self.text, requirement)

    def segment(self, node: ast.AST) -> str:
        """The text of ``node`` as the user wrote it, to name it in a message."""
        return ast.get_source_segment(self.source, node) or type(node).__name__

    def value(self, node: ast.AST):
        """The value of the expression ``node`` (a float, :data:`RUNTIME` or UFL)."""
        walk = {
            ast.Constant: self._constant,
            ast.Name: self._name,
            ast.UnaryOp: self._unary,
            ast.BinOp: self._binary,
            ast.Call: self._call,
            ast.IfExp: self._if,
        }.get(type(node))
        if walk is None:
            self._refuse(node)
        return walk(node)

    def _refuse(self, node: ast.AST):
        if isinstance(node, ast.Compare):  # name 'in' or 'is' before 'a condition'
            for op in node.ops:
                self._operator(op, _COMPARISONS)
        if isinstance(node, (ast.Compare, ast.BoolOp)):
            self.fail(
                f"'{self.segment(node)}' is a condition, not a number: use it in "
                "'a if condition else b'"
            )
        what = _REFUSED_NODES.get(type(node), type(node).__name__)
        self.fail(f"{what} is not allowed: '{self.segment(node)}'")

    def _constant(self, node: ast.Constant) -> float:
        literal = self.segment(node)
        if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
            self.fail(f"{literal} is not a number (only numbers, names and functions)")
        try:
            number = float(node.value)
        except OverflowError:
            number = math.inf
        return self._checked(number, literal)

    def _checked(self, number: float, what: str) -> float:
        if not (math.isfinite(number) and abs(number) <= LARGEST):
            self.fail(f"'{what}' is {number:g}: not finite or larger than {LARGEST:g}")
        return number

    def _name(self, node: ast.Name):
        if node.id not in self.names:
            self._unknown(node.id)
        self.used.add(node.id)
        return self.names[node.id]

    def _unknown(self, name: str):
        allowed = ", ".join(self.names)
        if name in COORDINATES:
            gdim = sum(c in self.names for c in COORDINATES)
            self.fail(
                f"coordinate '{name}' does not exist on a mesh of dimension {gdim} "
                f"(allowed: {allowed})"
            )
        if name in FUNCTIONS:
            self.fail(f"'{name}' is a function: call it as {name}(...)")
        self.fail(f"unknown name '{name}' (allowed: {allowed})")

    def _operator(self, op: ast.AST, table: dict):
        if type(op) not in table:
            token = _REFUSED_OPERATORS.get(type(op), type(op).__name__)
            self.fail(f"operator '{token}' is not allowed")
        return table[type(op)]

    def _unary(self, node: ast.UnaryOp):
        self._operator(node.op, {ast.USub: None, ast.UAdd: None})
        operand = self.value(node.operand)
        return -operand if isinstance(node.op, ast.USub) else operand

    def _binary(self, node: ast.BinOp):
        token, apply = self._operator(node.op, _ARITHMETIC)
        left, right = self.value(node.left), self.value(node.right)
        if isinstance(node.op, ast.Pow) and isinstance(right, float):
            right = self._exponent(right, node)
        if isinstance(node.op, ast.Div) and isinstance(right, float) and right == 0.0:
            self.fail(f"division by zero in '{self.segment(node)}'")
        if isinstance(left, float) and isinstance(right, (float, int)):
            apply = math.pow if token == "**" else apply
            return self._folded(apply, (left, right), node)
        return apply(left, right)

    def _exponent(self, exponent: float, node: ast.BinOp):
        if abs(exponent) > MAX_EXPONENT:
            self.fail(
                f"exponent {_number(exponent)} is too large (at most {MAX_EXPONENT}) "
                f"in '{self.segment(node)}'"
            )
        return int(exponent) if exponent.is_integer() else exponent

    def _folded(self, apply: Callable, args: tuple, node: ast.AST) -> float:
        try:
            number = float(apply(*args))
        except (ValueError, ZeroDivisionError):
            number = math.nan
        except OverflowError:
            number = math.inf
        if math.isnan(number):
            self.fail(f"'{self.segment(node)}' is undefined")
        return self._checked(number, self.segment(node))

    def _call(self, node: ast.Call):
        function = self._function(node)
        args = [self.value(arg) for arg in node.args]
        if all(isinstance(arg, float) for arg in args):
            return self._folded(function.number, args, node)
        if _runtime(*args):
            return RUNTIME
        return function.array(*args) if self.numeric else function.form(*args)

    def _function(self, node: ast.Call) -> _Function:
        listed = ", ".join(FUNCTIONS)
        if isinstance(node.func, tuple(_REFUSED_NODES)):
            self._refuse(node.func)
        if not isinstance(node.func, ast.Name):
            self.fail(f"calling '{self.segment(node.func)}' is not allowed (only {listed})")
        name = node.func.id
        if name not in FUNCTIONS:
            self.fail(f"function '{name}' is not in the list ({listed})")
        for keyword in node.keywords:
            written = f"{keyword.arg}=" if keyword.arg else "**"
            self.fail(f"keyword argument '{written}' is not allowed in '{name}(...)'")
        function, count = FUNCTIONS[name], len(node.args)
        if count != function.arity and not (function.arity is None and count >= 2):
            wanted = "two or more arguments" if function.arity is None else "one argument"
            self.fail(f"function '{name}' takes {wanted}, got {count}")
        return function

    def _if(self, node: ast.IfExp):
        condition = self.condition(node.test)
        chosen, other = self.value(node.body), self.value(node.orelse)
        if isinstance(condition, bool):
            return chosen if condition else other
        if _runtime(condition, chosen, other):
            return RUNTIME
        if self.numeric:
            return np.where(condition, chosen, other)
        return ufl.conditional(condition, chosen, other)

    def condition(self, node: ast.AST):
        """The value of the condition ``node`` of a conditional (a bool when constant)."""
        if isinstance(node, ast.BoolOp):
            combine = self._operator(node.op, {ast.And: _and, ast.Or: _or})
            return functools.reduce(combine, [self.condition(v) for v in node.values])
        if not isinstance(node, ast.Compare):
            self.fail(
                f"the condition '{self.segment(node)}' of 'a if condition else b' must be a "
                "comparison (< <= > >= == !=)"
            )
        operands = [self.value(node.left)] + [self.value(c) for c in node.comparators]
        tests = [
            _compare(self._operator(op, _COMPARISONS), left, right)
            for op, left, right in zip(node.ops, operands, operands[1:])
        ]
        return functools.reduce(_and, tests)


def _compare(comparison: tuple, left, right):
    _, number, form = comparison
    if isinstance(left, float) and isinstance(right, float):
        return number(left, right)
    if isinstance(left, np.ndarray) or isinstance(right, np.ndarray):  # evaluate's
        return number(left, right)
    if _runtime(left, right):
        return RUNTIME
    return form(left, right)


def _and(left, right):
    if isinstance(left, bool) or isinstance(right, bool):
        constant, other = (left, right) if isinstance(left, bool) else (right, left)
        return other if constant else False
    if isinstance(left, np.ndarray):  # evaluate's
        return np.logical_and(left, right)
    return RUNTIME if _runtime(left, right) else ufl.And(left, right)


def _or(left, right):
    if isinstance(left, bool) or isinstance(right, bool):
        constant, other = (left, right) if isinstance(left, bool) else (right, left)
        return True if constant else other
    if isinstance(left, np.ndarray):  # evaluate's
        return np.logical_or(left, right)
    return RUNTIME if _runtime(left, right) else ufl.Or(left, right)
