"""Problem data written as text: a small expression language of position x and time t.

Body forces, tractions, Dirichlet values and initial fields may be given in a TOML file as
formulas such as ``"-9.81 * (1 if t < 0.5 else 0)"`` or ``"sin(pi * x) * exp(-t)"``. This
module turns such text into UFL, so that the forms are compiled once and the time ``t`` (a
``fem.Constant``) changes their value without compiling them again. The grammar::

    expr      := number | name | expr op expr | ('-' | '+') expr | '(' expr ')'
               | function '(' expr (',' expr)* ')' | expr 'if' condition 'else' expr
    op        := '+' | '-' | '*' | '/' | '**' | '^'        ('^' is a power, as '**')
    condition := expr cmp expr (cmp expr)* | condition ('and' | 'or') condition
    cmp       := '<' | '<=' | '>' | '>=' | '==' | '!='
    name      := 'x' | 'y' (gdim >= 2) | 'z' (gdim 3) | 't' | 'pi' | 'e'
    function  := sin | cos | tan | exp | log | sqrt | abs | min | max (min, max: 2 or more)

Numbers are written as in Python (``1``, ``2.5``, ``1e-3``); ``and`` binds tighter than
``or``. ``^`` is replaced by ``**`` before parsing, so that it binds as a power (``-x^2`` is
``-(x^2)``), never as Python's exclusive or. ``//``, ``%``, ``not``, bitwise operators and
everything else are refused: floor division and remainder are not smooth and UFL has no
floor. A chained comparison ``0.2 < x < 0.4`` means ``0.2 < x and x < 0.4``.

Why ``ast`` and a whitelist: the text is parsed by Python's own parser, which only reads it,
and the tree is walked by a builder that knows a few node types and refuses all others
(attribute access, indexing, calls of anything but the functions above, names other than
those above), so no user text ever runs as Python. The walk folds constant parts in floats
and checks them: a constant exponent is at most :data:`MAX_EXPONENT` in magnitude, every
constant is finite and at most :data:`~nitsche_dolfinx.keys.LARGEST` in magnitude, and
``1/0``, ``log(-1)`` or ``exp(1000)`` are refused. A mistake raises
:class:`~nitsche_dolfinx.parameters.ParameterError` naming the key, the text and the
offending token, before any UFL is built.
"""

from __future__ import annotations

import ast
import functools
import math
import operator
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import ufl

from .keys import LARGEST, is_number
from .parameters import ParameterError

__all__ = [
    "FUNCTIONS",
    "MAX_DEPTH",
    "MAX_EXPONENT",
    "MAX_LENGTH",
    "MAX_TABLE_POINTS",
    "ExpressionTree",
    "check_table",
    "evaluate",
    "has_text",
    "expression",
    "parse_expression",
    "parse_vector",
    "table_expression",
    "to_ufl",
    "vector_expression",
]

#: The longest text of one expression, in characters.
MAX_LENGTH = 1000
#: The deepest nesting of operations (each operation, call or conditional counts one level,
#: parentheses none).
MAX_DEPTH = 100
#: The largest magnitude of a constant exponent (``x**100`` is fine, ``2**1000`` is not).
MAX_EXPONENT = 100
#: The most points of a piecewise-linear table.
MAX_TABLE_POINTS = 1000
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


_RUNTIME = _Runtime()


def _runtime(*values) -> bool:
    return any(value is _RUNTIME for value in values)


@dataclass(frozen=True)
class ExpressionTree:
    """A checked expression, not yet UFL: :func:`to_ufl` builds it on a mesh.

    Attributes:
        text: The text as given (a number given as a number becomes its ``repr``).
        name: The key that names it in messages, e.g. ``"load.body_force[1]"``.
        gdim: The geometric dimension it was checked for.
        names: The names it uses (``x``, ``y``, ``z``, ``t``, ``pi``, ``e``).
        value: Its value when it uses neither position nor time, else None.
    """

    text: str
    name: str
    gdim: int
    names: frozenset[str]
    value: float | None
    _tree: ast.Expression = field(repr=False, compare=False)
    _source: str = field(repr=False, compare=False)

    @property
    def uses_time(self) -> bool:
        """Whether it depends on the time t."""
        return "t" in self.names

    @property
    def uses_space(self) -> bool:
        """Whether it depends on the position (x, y or z)."""
        return not self.names.isdisjoint(COORDINATES)


def parse_expression(text: str | float, *, name: str, gdim: int) -> ExpressionTree:
    """Check an expression without a mesh (a configuration can be checked before one exists).

    Args:
        text: The expression, or a number (an int or a float).
        name: The key naming it in messages.
        gdim: The geometric dimension of the mesh it will live on (1, 2 or 3).

    Returns:
        The checked expression.

    Raises:
        ParameterError: The text is not an expression of the language, naming the
            offending token.
    """
    if gdim not in (1, 2, 3):
        raise ValueError(f"gdim must be 1, 2 or 3, got {gdim!r}")
    text = _text(text, name)
    source = text.replace("^", "**")  # '^' means nothing else: no strings in the language
    tree = _parse(text, source, name)
    _check_depth(tree, text, name)
    names = _names(gdim, [_RUNTIME] * gdim, _RUNTIME)
    builder = _Builder(text, source, name, names)
    value = builder.value(tree.body)
    number = None if value is _RUNTIME else float(value)
    return ExpressionTree(text, name, gdim, frozenset(builder.used), number, tree, source)


def to_ufl(tree: ExpressionTree, x, t=None):
    """The UFL expression of a checked expression.

    Args:
        tree: The checked expression (:func:`parse_expression`).
        x: The position, ``ufl.SpatialCoordinate(mesh)`` (``tree.gdim`` components).
        t: The time, a scalar ``fem.Constant``: changing its value changes the expression's
            without compiling it again. None where no time exists (then ``t`` is refused).

    Returns:
        A scalar UFL expression.

    Raises:
        ParameterError: The expression uses t and ``t`` is None.
    """
    if x.ufl_shape != (tree.gdim,):
        raise ValueError(f"x has shape {x.ufl_shape}, the expression is for gdim={tree.gdim}")
    if t is None and tree.uses_time:
        raise ParameterError(tree.name, tree.text, "'t' (time) is not available here")
    names = _names(tree.gdim, [x[i] for i in range(tree.gdim)], t)
    builder = _Builder(tree.text, tree._source, tree.name, names)
    return ufl.as_ufl(builder.value(tree._tree.body))


def evaluate(tree: ExpressionTree, points: np.ndarray, t: float | None = None) -> np.ndarray:
    """The values of a checked expression at ``points`` (shape (gdim or 3, N)) and time
    ``t``, in floating point as the compiled form computes them: nan or inf where it is
    undefined or infinite there (``1/t`` at t = 0), no error. A check of the data before
    a run (:class:`~nitsche_dolfinx.problem_values.ProblemValue`), not a way to compute them.

    Returns:
        An array of N values.
    """
    points = np.asarray(points, dtype=float)
    count = points.shape[1]
    if t is None and tree.uses_time:
        raise ParameterError(tree.name, tree.text, "'t' (time) is not available here")
    time = np.full(count, 0.0 if t is None else float(t))
    names = _names(tree.gdim, [points[i] for i in range(tree.gdim)], time)
    builder = _Builder(tree.text, tree._source, tree.name, names, numeric=True)
    with np.errstate(all="ignore"):
        value = builder.value(tree._tree.body)
        return np.broadcast_to(np.asarray(value, dtype=float), (count,)).copy()


def expression(text: str | float, mesh, t=None, *, name: str):
    """The UFL expression of ``text`` on ``mesh`` (:func:`parse_expression`, :func:`to_ufl`).

    Args:
        text: The expression, or a number.
        mesh: The dolfinx mesh: x is its ``ufl.SpatialCoordinate``.
        t: The time, a scalar ``fem.Constant`` (or None where no time exists).
        name: The key naming it in messages.

    Returns:
        A scalar UFL expression.

    Raises:
        ParameterError: The text is not an expression of the language.
    """
    tree = parse_expression(text, name=name, gdim=mesh.geometry.dim)
    return to_ufl(tree, ufl.SpatialCoordinate(mesh), t)


def parse_vector(texts: Sequence[str | float], *, name: str, gdim: int):
    """Check the gdim components of a vector (texts or numbers) without a mesh.

    Args:
        texts: One expression or number per component.
        name: The key naming the vector; component i is named ``name[i]``.
        gdim: The geometric dimension: the number of components.

    Returns:
        A tuple of :class:`ExpressionTree`, one per component.

    Raises:
        ParameterError: Not a list of gdim components, or a component is not an expression.
    """
    if not _is_list(texts):
        raise ParameterError(name, texts, f"must be a list of {gdim} components")
    if len(texts) != gdim:
        requirement = f"wrong dimension: {len(texts)} components for a mesh of dimension {gdim}"
        raise ParameterError(name, texts, requirement)
    return tuple(
        parse_expression(text, name=f"{name}[{i}]", gdim=gdim) for i, text in enumerate(texts)
    )


def vector_expression(texts: Sequence[str | float], mesh, t=None, *, name: str):
    """The UFL vector of gdim components (texts or numbers) on ``mesh``.

    Args:
        texts: One expression or number per component (a TOML array may mix them).
        mesh: The dolfinx mesh.
        t: The time, a scalar ``fem.Constant`` (or None where no time exists).
        name: The key naming the vector; component i is named ``name[i]``.

    Returns:
        ``ufl.as_vector`` of the components.

    Raises:
        ParameterError: Not a list of gdim components, or a component is not an expression.
    """
    trees = parse_vector(texts, name=name, gdim=mesh.geometry.dim)
    x = ufl.SpatialCoordinate(mesh)
    return ufl.as_vector([to_ufl(tree, x, t) for tree in trees])


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


def has_text(value) -> bool:
    """Whether ``value`` is a text or a list holding a text (the expression language)."""
    if isinstance(value, str):
        return True
    return isinstance(value, (list, tuple)) and any(isinstance(item, str) for item in value)


# -- checks of the text ------------------------------------------------------------------


def _text(text, name: str) -> str:
    if is_number(text):
        if not (math.isfinite(text) and abs(text) <= LARGEST):
            raise ParameterError(name, text, f"must be finite and at most {LARGEST:g} in size")
        return repr(float(text))
    if not isinstance(text, str):
        kind = type(text).__name__
        raise ParameterError(name, text, f"must be an expression (text) or a number, got {kind}")
    if not text.strip():
        raise ParameterError(name, text, "an empty expression")
    if len(text) > MAX_LENGTH:
        requirement = f"the text has {len(text)} characters, more than {MAX_LENGTH}"
        raise ParameterError(name, text, requirement)
    return text


def _parse(text: str, source: str, name: str) -> ast.Expression:
    """``ast.parse`` only reads the text: it runs nothing (its warnings, about escapes in
    strings say, are not the user's concern: strings are refused anyway)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return ast.parse(source, mode="eval")
    except SyntaxError as error:
        raise ParameterError(name, text, _syntax_error(text, error)) from None
    except (ValueError, RecursionError, MemoryError) as error:
        raise ParameterError(name, text, f"not an expression: {error}") from None


def _syntax_error(text: str, error: SyntaxError) -> str:
    """``syntax error at column C (message): 'text from there'``, in the user's text (where
    each '^' was one character, not the two of '**')."""
    lines = text.splitlines() or [""]
    line = lines[min(max(error.lineno or 1, 1), len(lines)) - 1]
    column, written = 0, 0
    while column < len(line) and written < (error.offset or 1) - 1:
        written += 2 if line[column] == "^" else 1
        column += 1
    where = f"column {column + 1}"
    where = f"line {error.lineno}, {where}" if len(lines) > 1 else where
    near = line[column : column + 12].strip() or "end of text"
    return f"syntax error at {where} ({error.msg}): '{near}'"


def _check_depth(tree: ast.Expression, text: str, name: str) -> None:
    """Refuse deep nesting before the recursive walk (and UFL's, and FFCx's) meet it."""
    deepest, stack = 0, [(tree.body, 1)]
    while stack:
        node, depth = stack.pop()
        deepest = max(deepest, depth)
        children = ast.iter_child_nodes(node)  # operators and contexts count no level
        stack.extend((child, depth + isinstance(child, ast.expr)) for child in children)
        if deepest > MAX_DEPTH:
            requirement = f"operations nested deeper than {MAX_DEPTH} levels"
            raise ParameterError(name, text, requirement)


def _names(gdim: int, coordinates: list, t) -> dict:
    """The names an expression on a mesh of dimension gdim may use, and their values."""
    return {**dict(zip(COORDINATES[:gdim], coordinates)), "t": t, **CONSTANTS}


def _numbers(numbers, name: str) -> tuple[float, ...]:
    if not _is_list(numbers):
        raise ParameterError(name, numbers, "must be a list of numbers")
    if not 1 <= len(numbers) <= MAX_TABLE_POINTS:
        requirement = f"must have from 1 to {MAX_TABLE_POINTS} entries, has {len(numbers)}"
        raise ParameterError(name, list(numbers), requirement)
    for i, number in enumerate(numbers):
        if not (is_number(number) and math.isfinite(number) and abs(number) <= LARGEST):
            requirement = f"entry [{i}] = {number!r} is not a finite number of size <= {LARGEST:g}"
            raise ParameterError(name, list(numbers), requirement)
    return tuple(float(number) for number in numbers)


def _is_list(value) -> bool:
    return isinstance(value, (Sequence, np.ndarray)) and not isinstance(value, (str, bytes))


def _slope(points, values, k: int) -> float:
    try:
        return (values[k] - values[k - 1]) / (points[k] - points[k - 1])
    except (OverflowError, ZeroDivisionError):
        return math.inf


def _number(value: float) -> str:
    """A constant as a user would write it: ``1000000``, not ``1e+06``."""
    return str(int(value)) if value.is_integer() and abs(value) < 1e30 else repr(value)


# -- the walk ----------------------------------------------------------------------------


class _Builder:
    """Walks a parsed expression, node types from a whitelist only, and computes its value
    from ``names``: floats fold, :data:`_RUNTIME` stands for x and t when checking, UFL
    objects when building. Conditions are Python bools when constant."""

    def __init__(self, text: str, source: str, name: str, names: dict, numeric: bool = False):
        self.text, self.source, self.name, self.names = text, source, name, names
        self.numeric = numeric  # numpy arrays for x and t (evaluate), not UFL
        self.used: set[str] = set()

    def fail(self, requirement: str):
        raise ParameterError(self.name, self.text, requirement)

    def segment(self, node: ast.AST) -> str:
        return ast.get_source_segment(self.source, node) or type(node).__name__

    def value(self, node: ast.AST):
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
            return _RUNTIME
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
            return _RUNTIME
        if self.numeric:
            return np.where(condition, chosen, other)
        return ufl.conditional(condition, chosen, other)

    def condition(self, node: ast.AST):
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
        return _RUNTIME
    return form(left, right)


def _and(left, right):
    if isinstance(left, bool) or isinstance(right, bool):
        constant, other = (left, right) if isinstance(left, bool) else (right, left)
        return other if constant else False
    if isinstance(left, np.ndarray):  # evaluate's
        return np.logical_and(left, right)
    return _RUNTIME if _runtime(left, right) else ufl.And(left, right)


def _or(left, right):
    if isinstance(left, bool) or isinstance(right, bool):
        constant, other = (left, right) if isinstance(left, bool) else (right, left)
        return True if constant else other
    if isinstance(left, np.ndarray):  # evaluate's
        return np.logical_or(left, right)
    return _RUNTIME if _runtime(left, right) else ufl.Or(left, right)
