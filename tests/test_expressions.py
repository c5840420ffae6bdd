"""The expression language of problem data (nitsche_dolfinx.physics.expressions): formulas against
numpy at the nodes of a mesh, the time as a constant that changes the value without a new
compilation, piecewise-linear tables, and the refusal of every text outside the language.

The values are compared at the nodes of P1 spaces: interpolating into P1 evaluates the
expression at the nodes, so the compiled formula and the numpy one agree to round-off
(measured: 1e-12; two implementations, whose elementary functions may differ with the
processor, so compared to 1e-9 of each formula's scale); no quadrature is involved. Three
expressions are compiled in all (2D, 3D, 1D).
"""

import inspect
import math
import re

import numpy as np
import pytest
import ufl
from dolfinx import fem, mesh
from mpi4py import MPI

from nitsche_dolfinx.common import ParameterError, compat
from nitsche_dolfinx.physics import (
    MAX_EXPONENT,
    check_table,
    expression,
    expressions,
    parse_expression,
    parse_vector,
    table_expression,
    to_ufl,
    vector_expression,
)

KEY = "load.body_force[1]"

# (text, the same formula in numpy of (x, y, t)) on the unit square.
FORMULAS_2D = [
    ("x^2 + 3*y - 1", lambda x, y, t: x**2 + 3 * y - 1),
    ("-x^2", lambda x, y, t: -(x**2)),
    ("2^3^2 + 0*x", lambda x, y, t: 512 + 0 * x),
    (
        "sin(pi*x) * cos(pi*y) * exp(-t)",
        lambda x, y, t: np.sin(np.pi * x) * np.cos(np.pi * y) * np.exp(-t),
    ),
    (
        "tan(0.5*x) + log(1 + x + y) + sqrt(1 + t)",
        lambda x, y, t: np.tan(0.5 * x) + np.log(1 + x + y) + np.sqrt(1 + t),
    ),
    (
        "abs(x - 0.5) + min(x, y) + max(x, y, t)",
        lambda x, y, t: abs(x - 0.5) + np.minimum(x, y) + np.maximum(np.maximum(x, y), t),
    ),
    ("1 if 0.3 < x < 0.6 else -1", lambda x, y, t: np.where((0.3 < x) & (x < 0.6), 1.0, -1.0)),
    (
        "2 if x <= 0.4 and y >= 0.6 or t > 1 else 0",
        lambda x, y, t: np.where((x <= 0.4) & (y >= 0.6) | (t > 1), 2.0, 0.0),
    ),
    (
        "(1 if x == x else 0) + (1 if y != y else 0) + (5 if t == 0.25 else 0)",
        lambda x, y, t: 1 + 0 * x + (5 if t == 0.25 else 0),
    ),
    ("1e-3 * t * x + 2.5E2 * y", lambda x, y, t: 1e-3 * t * x + 2.5e2 * y),
    ("+x - (-y)", lambda x, y, t: x + y),
    ("e^x - pi", lambda x, y, t: np.e**x - np.pi),
    (
        "x / (1 + t) - y / 4 + (1 + x) ** 0.5 + (1 + y) ** -1",
        lambda x, y, t: x / (1 + t) - y / 4 + (1 + x) ** 0.5 + 1 / (1 + y),
    ),
    ("t", lambda x, y, t: t + 0 * x),
    ("3", lambda x, y, t: 3 + 0 * x),
]
TABLE_X = ([0.1, 0.35, 0.8], [1.0, -2.0, 4.0])
TABLE_T = ([0.0, 1.0, 2.0, 3.0], [0.0, 10.0, 5.0, 5.5])


def nodal_values(ufl_vector, msh, count: int):
    """The compiled expression, the function it fills and the nodes (one row per node)."""
    V = compat.function_space(msh, "Lagrange", 1, (count,))
    compiled, u = compat.expression(ufl_vector, V), fem.Function(V)
    return compiled, u, compat.node_coordinates(V)


def interpolated(compiled, u, count: int) -> np.ndarray:
    u.interpolate(compiled)
    return u.x.array.reshape(-1, count)


def test_formulas_match_numpy_and_follow_the_time_without_compiling(compilations):
    square = mesh.create_unit_square(MPI.COMM_SELF, 4, 4)
    t = fem.Constant(square, 0.25)
    x = ufl.SpatialCoordinate(square)
    parts = [expression(text, square, t, name=KEY) for text, _ in FORMULAS_2D]
    parts += [table_expression(*TABLE_X, x[0], name="table_x")]
    parts += [table_expression(*TABLE_T, t, name="table_t")]
    parts += [table_expression([0.5], [3.0], t, name="table_1")]
    parts += list(vector_expression(["x*t", 2], square, t, name="v"))
    compiled, u, nodes = nodal_values(ufl.as_vector(parts), square, len(parts))
    compiled_forms = len(compilations)
    for time in (0.25, 1.7, 3.5):  # 1.7: past 't > 1', between table points; 3.5: beyond
        t.value = time
        values = interpolated(compiled, u, len(parts))
        X, Y = nodes[:, 0], nodes[:, 1]
        expected = [numpy(X, Y, time) for _, numpy in FORMULAS_2D]
        expected += [np.interp(X, *TABLE_X), np.interp(time + 0 * X, *TABLE_T), 3.0 + 0 * X]
        expected += [X * time, 2.0 + 0 * X]
        for i, column in enumerate(expected):
            label = FORMULAS_2D[i][0] if i < len(FORMULAS_2D) else f"part {i}"
            atol = 1e-9 * np.abs(column).max()  # compiled C against numpy: 1e-9 of the scale
            assert np.allclose(values[:, i], column, rtol=1e-9, atol=atol), (label, time)
    assert len(compilations) == compiled_forms, "changing t compiled again"


def test_three_and_one_dimensions():
    cube = mesh.create_unit_cube(MPI.COMM_SELF, 1, 1, 1)
    t = fem.Constant(cube, 2.0)
    vector = vector_expression(["x", "y*z", "z^2 + t"], cube, t, name="v")
    compiled, u, nodes = nodal_values(vector, cube, 3)
    X, Y, Z = nodes.T
    assert np.allclose(interpolated(compiled, u, 3), np.column_stack([X, Y * Z, Z**2 + 2]))
    bar = mesh.create_interval(MPI.COMM_SELF, 4, [0.0, 2.0])
    time = fem.Constant(bar, 0.5)
    cubic = expression("x^3 - t", bar, time, name="f")
    compiled, u, nodes = nodal_values(ufl.as_vector([cubic]), bar, 1)
    assert np.allclose(interpolated(compiled, u, 1)[:, 0], nodes[:, 0] ** 3 - 0.5)


def test_what_a_tree_knows_without_a_mesh():
    tree = parse_expression("sin(pi * x) * t", name=KEY, gdim=2)
    assert tree.uses_time and tree.uses_space and tree.names == {"pi", "x", "t"}
    assert tree.value is None
    constant = parse_expression("2^10 / 4 + max(1, e)", name=KEY, gdim=1)
    assert not constant.uses_time and not constant.uses_space
    assert constant.value == pytest.approx(256 + math.e)
    assert parse_expression(2.5, name=KEY, gdim=3).value == 2.5
    assert parse_expression(np.float64(-1.0), name=KEY, gdim=3).value == -1.0
    assert parse_expression("1 if pi > 3 else log(0.5)", name=KEY, gdim=1).value == 1.0
    assert parse_expression(f"x**{MAX_EXPONENT} + x**-{MAX_EXPONENT}", name=KEY, gdim=1).uses_space
    vector = parse_vector(["t", 0, "x"], name="v", gdim=3)
    assert [c.uses_time for c in vector] == [True, False, False]


def test_time_needed_but_absent_and_other_mesh():
    square = mesh.create_unit_square(MPI.COMM_SELF, 1, 1)
    assert expression("x + y", square, name=KEY) is not None
    with pytest.raises(ParameterError, match="'t' \\(time\\) is not available"):
        expression("x + t", square, name=KEY)
    with pytest.raises(ParameterError, match="coordinate 'z'"):
        expression("z", square, fem.Constant(square, 0.0), name=KEY)
    tree = parse_expression("x", name=KEY, gdim=3)
    with pytest.raises(ValueError, match="gdim=3"):
        to_ufl(tree, ufl.SpatialCoordinate(square))


# (text, gdim, a piece of the message that names the offending token)
HOSTILE = [
    ("x.__class__", 2, "'.' (attribute access) is not allowed: 'x.__class__'"),
    ("().__class__", 2, "'.' (attribute access)"),
    ("t.value", 2, "'.' (attribute access)"),
    ("os.system('ls')", 2, "'.' (attribute access) is not allowed: 'os.system'"),
    ("eval('1')", 2, "function 'eval' is not in the list (sin, cos"),
    ("open('f')", 2, "function 'open' is not in the list"),
    ("__import__('os')", 2, "function '__import__' is not in the list"),
    ("getattr(x, 'a')", 2, "function 'getattr'"),
    ("import os", 2, ("syntax error at column 1", "'import os'")),
    ("x; import os", 2, "syntax error at column 2"),
    ("x = 1", 2, "syntax error at column 3"),
    ("2x", 2, ("syntax error at column 1", "'2x'")),
    ("x ^^ 2", 2, ("syntax error at column 4", "'^ 2'")),
    ("lambda: 1", 2, "'lambda' is not allowed"),
    ("(lambda: 1)()", 2, "'lambda' is not allowed"),
    ("[i for i in x]", 2, "a comprehension ('for')"),
    ("{i for i in x}", 2, "a comprehension ('for')"),
    ("{i: i for i in x}", 2, "a comprehension ('for')"),
    ("(i for i in x)", 2, "a generator ('for')"),
    ("x[0]", 2, "'[...]' (indexing) is not allowed: 'x[0]'"),
    ("[x]", 2, "a list"),
    ("(1, 2)", 2, "a tuple"),
    ("{}", 2, "a dict"),
    ("'a'", 2, "'a' is not a number"),
    ("b'a'", 2, "b'a' is not a number"),
    ("x if t < 1 else 'a'", 2, "'a' is not a number"),
    ("f'{x}'", 2, "an f-string is not allowed"),
    ("True", 2, "True is not a number"),
    ("None", 2, "None is not a number"),
    ("1j", 2, "1j is not a number"),
    ("sin(*x)", 2, "'*' (unpacking) is not allowed: '*x'"),
    ("sin(x=1)", 2, "keyword argument 'x=' is not allowed in 'sin(...)'"),
    ("max(**x)", 2, "keyword argument '**'"),
    ("(a := 1)", 2, "':=' (assignment) is not allowed"),
    ("await x", 2, "'await' is not allowed"),
    ("10**10**10", 2, "exponent 10000000000 is too large (at most 100)"),
    ("2**100000", 2, "exponent 100000 is too large"),
    ("9**9**9", 2, "exponent 387420489 is too large"),
    ("x^101", 2, "exponent 101 is too large"),
    ("x**-101", 2, "exponent -101 is too large"),
    ("1e999", 2, "'1e999' is inf"),
    ("1e100 * 10", 2, "'1e100 * 10' is 1e+101"),
    ("exp(1000)", 2, "'exp(1000)' is inf"),
    ("log(-1)", 2, "'log(-1)' is undefined"),
    ("(-8)^(1/3)", 2, "is undefined"),
    ("1/0", 2, "division by zero in '1/0'"),
    ("x / (1 - 1)", 2, "division by zero"),
    ("os", 2, "unknown name 'os' (allowed: x, y, t, pi, e)"),
    ("X", 2, "unknown name 'X'"),
    ("time", 2, "unknown name 'time'"),
    ("__builtins__", 2, "unknown name '__builtins__'"),
    ("y", 1, "coordinate 'y' does not exist on a mesh of dimension 1 (allowed: x, t, pi, e)"),
    ("z", 2, "coordinate 'z' does not exist on a mesh of dimension 2"),
    ("sin", 2, "'sin' is a function"),
    ("sin()", 2, "function 'sin' takes one argument, got 0"),
    ("min(x)", 2, "function 'min' takes two or more arguments, got 1"),
    ("", 2, "an empty expression"),
    ("   ", 2, "an empty expression"),
    ("x" * 1001, 2, "the text has 1001 characters, more than 1000"),
    ("x & 1", 2, "operator '&' is not allowed"),
    ("x | 1", 2, "operator '|'"),
    ("~x", 2, "operator '~'"),
    ("x << 2", 2, "operator '<<'"),
    ("not x", 2, "operator 'not'"),
    ("1 if x in t else 0", 2, "operator 'in'"),
    ("x is t", 2, "operator 'is'"),
    ("x @ t", 2, "operator '@'"),
    ("x // 2", 2, "operator '//'"),
    ("x % 2", 2, "operator '%'"),
    ("x < 1", 2, "'x < 1' is a condition, not a number"),
    ("1 if x else 0", 2, "the condition 'x' of 'a if condition else b' must be a comparison"),
    ("-" * 120 + "x", 2, "nested deeper than 100 levels"),
    ("sin(" * 120 + "x" + ")" * 120, 2, "nested deeper than 100 levels"),
    ("\x00", 2, "null bytes"),
]


@pytest.mark.parametrize(("text", "gdim", "named"), HOSTILE)
def test_hostile_or_malformed_text_is_refused_naming_the_token(text, gdim, named):
    with pytest.raises(ParameterError) as refused:
        parse_expression(text, name=KEY, gdim=gdim)
    for piece in named if isinstance(named, tuple) else (named,):
        assert piece in refused.value.requirement
    assert refused.value.name == KEY and refused.value.value == text
    assert "\n" not in str(refused.value) and str(refused.value).startswith(f"{KEY}=")


def test_parentheses_too_deep_for_the_parser_are_refused():
    """Python's parser refuses them, in words that depend on the Python version."""
    with pytest.raises(ParameterError, match="^load"):
        parse_expression("(" * 250 + "x" + ")" * 250, name=KEY, gdim=2)
    assert parse_expression("(" * 150 + "x" + ")" * 150, name=KEY, gdim=2).uses_space


@pytest.mark.parametrize(
    ("value", "named"),
    [(True, "got bool"), (None, "got NoneType"), (math.inf, "finite"), (1e101, "at most")],
)
def test_values_that_are_neither_text_nor_a_number(value, named):
    with pytest.raises(ParameterError, match=named):
        parse_expression(value, name=KEY, gdim=2)


@pytest.mark.parametrize(
    ("texts", "gdim", "named"),
    [
        (["x", "y"], 3, "wrong dimension: 2 components for a mesh of dimension 3"),
        (["1", "2", "3"], 2, "wrong dimension: 3 components"),
        ([], 1, "wrong dimension: 0 components"),
        ("x", 1, "must be a list of 1 components"),
        (["x", "os"], 2, "unknown name 'os'"),
    ],
)
def test_vectors_of_the_wrong_dimension_are_refused(texts, gdim, named):
    with pytest.raises(ParameterError, match=re.escape(named)):
        parse_vector(texts, name="load.traction", gdim=gdim)


def test_a_bad_component_is_named_by_its_index():
    with pytest.raises(ParameterError) as refused:
        parse_vector([0, "x.y"], name="load.traction", gdim=2)
    assert refused.value.name == "load.traction[1]"


def test_tables_are_checked():
    assert check_table([0, 1, 2.5], [1, -1, 0], name="f") == ((0.0, 1.0, 2.5), (1.0, -1.0, 0.0))


@pytest.mark.parametrize(
    ("points", "values", "named"),
    [
        ([0.0, 2.0, 1.0], [1, 2, 3], "points[2] = 1.0 is not greater than points[1] = 2.0"),
        ([0.0, 0.0], [1, 2], "points[1] = 0.0 is not greater than points[0] = 0.0"),
        ([0.0, 1.0], [1.0], "one value per point: 1 values for 2 points"),
        ([], [], "from 1 to 1000 entries, has 0"),
        ([0.0, math.nan], [1, 2], "entry [1] = nan"),
        ([0.0, math.inf], [1, 2], "entry [1] = inf"),
        ([0.0, 1.0], [1, math.inf], "entry [1] = inf"),
        ([0.0, "1"], [1, 2], "entry [1] = '1'"),
        ("0 1", [1, 2], "must be a list of numbers"),
        ([0.0, 1e-300], [-1e100, 1e100], "slope between points[0] and points[1]"),
    ],
)
def test_bad_tables_are_refused_naming_the_entry(points, values, named):
    with pytest.raises(ParameterError, match=re.escape(named)):
        table_expression(points, values, ufl.as_ufl(0.0), name="load.table")


def test_the_module_never_runs_text():
    """No eval, exec or compile of anything: the text is only read by ``ast.parse``."""
    source = inspect.getsource(expressions)
    assert not re.search(r"\b(eval|exec|compile)\s*\(", source)
    assert "__import__" not in source and "getattr" not in source
    assert 'ast.parse(source, mode="eval")' in source
