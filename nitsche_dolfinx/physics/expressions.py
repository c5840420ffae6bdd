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
those above), so no user text ever runs as Python
(:class:`~nitsche_dolfinx.physics.expression_walk.ExpressionWalk`). The walk folds constant
parts in floats and checks them: a constant exponent is at most
:data:`~nitsche_dolfinx.physics.expression_walk.MAX_EXPONENT` in magnitude, every constant is
finite and at most :data:`~nitsche_dolfinx.common.keys.LARGEST` in magnitude, and ``1/0``,
``log(-1)`` or ``exp(1000)`` are refused. A mistake raises
:class:`~nitsche_dolfinx.common.parameters.ParameterError` naming the key, the text and the
offending token, before any UFL is built. Piecewise-linear tables are in
:mod:`~nitsche_dolfinx.physics.tables`.
"""

from __future__ import annotations

import ast
import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import ufl

from ..common.keys import LARGEST, is_number
from ..common.parameters import ParameterError
from .expression_walk import COORDINATES, RUNTIME, ExpressionWalk, scope
from .tables import is_list

__all__ = [
    "MAX_DEPTH",
    "MAX_LENGTH",
    "ExpressionTree",
    "evaluate",
    "has_text",
    "expression",
    "parse_expression",
    "parse_vector",
    "to_ufl",
    "vector_expression",
]


#: The longest text of one expression, in characters.
MAX_LENGTH = 1000
#: The deepest nesting of operations (each operation, call or conditional counts one level,
#: parentheses none).
MAX_DEPTH = 100


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
    names = scope(gdim, [RUNTIME] * gdim, RUNTIME)
    builder = ExpressionWalk(text, source, name, names)
    value = builder.value(tree.body)
    number = None if value is RUNTIME else float(value)
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
    names = scope(tree.gdim, [x[i] for i in range(tree.gdim)], t)
    builder = ExpressionWalk(tree.text, tree._source, tree.name, names)
    return ufl.as_ufl(builder.value(tree._tree.body))


def evaluate(tree: ExpressionTree, points: np.ndarray, t: float | None = None) -> np.ndarray:
    """The values of a checked expression at ``points`` (shape (gdim or 3, N)) and time
    ``t``, in floating point as the compiled form computes them: nan or inf where it is
    undefined or infinite there (``1/t`` at t = 0), no error. A check of the data before
    a run (:class:`~nitsche_dolfinx.physics.problem_values.ProblemValue`), not a way to
    compute them.

    Returns:
        An array of N values.
    """
    points = np.asarray(points, dtype=float)
    count = points.shape[1]
    if t is None and tree.uses_time:
        raise ParameterError(tree.name, tree.text, "'t' (time) is not available here")
    time = np.full(count, 0.0 if t is None else float(t))
    names = scope(tree.gdim, [points[i] for i in range(tree.gdim)], time)
    builder = ExpressionWalk(tree.text, tree._source, tree.name, names, numeric=True)
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
    if not is_list(texts):
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
