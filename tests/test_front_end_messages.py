"""Mistakes a new user makes, refused in one line that names the value and the key the user
wrote, in the words of the entry point used (issue 44, part 5): a TOML run's message uses
TOML keys and the values of the file (no repr of the library's classes, no API keyword),
the API's uses its keywords, a demo's its flags.
"""

import math
import textwrap

import numpy as np
import pytest
from runs import REPO, assert_one_line_error, ring_config, run

from nitsche_dolfinx import ContactProblem, Material, PlaneObstacle, Simulation, make_scheme
from nitsche_dolfinx.common.keys import SHOWN_LENGTH, shown
from nitsche_dolfinx.common.parameters import DEFAULT_GAMMA0_E, ParameterError
from nitsche_dolfinx.config.builder import build_simulation
from nitsche_dolfinx.config.parameter_table import in_words_of
from nitsche_dolfinx.config.reader import ConfigError, history_columns, load_config
from nitsche_dolfinx.meshing import bar_mesh, block_mesh


def refusal(tmp_path, replace: dict) -> str:
    """The message of the shipped ring's configuration with ``replace`` made, built."""
    path = ring_config(str(tmp_path), replace)
    with pytest.raises(ConfigError) as error:
        build_simulation(load_config(path), progress=False, source="config.toml")
    message = str(error.value)
    assert "\n" not in message
    return message


def before_output(text: str) -> dict:
    """``text`` added to the ring's configuration, before its [output] table."""
    return {"[output]": f"{text}\n\n[output]"}


def configuration(tmp_path, text: str) -> str:
    path = tmp_path / "case.toml"
    path.write_text(textwrap.dedent(text))
    return str(path)


#: A short bar of the library, clamped at x = 1 (tag 2), against the wall x = 0 (tag 1).
BAR = """
    [mesh]
    generator = "bar"
    nx = 10
    {mesh}

    [material]
    E = 1.0
    nu = 0.0
    {material}

    [nitsche]
    {nitsche}

    [scheme]
    name = "{scheme}"
    dt = 0.05
    t_end = 0.2

    [[obstacle]]
    type = "plane"
    point = [0.0]
    normal = [1.0]
    tag = 1

    [[dirichlet]]
    tag = 2
    value = [0.0]

    [initial]
    displacement = {{ constant = [0.05], gradient = [[-0.05]] }}
"""


def bar(mesh="", material="", nitsche="", scheme="hybrid") -> str:
    return BAR.format(mesh=mesh, material=material, nitsche=nitsche, scheme=scheme)


# -- 1. the default columns of a mixed run ---------------------------------------------------


def test_mixed_run_with_supports_writes_its_default_columns(tmp_path):
    """method = "mixed" with a [[dirichlet]] and no [output] columns runs: the defaults name
    only columns the mixed stepper gives (no reaction_2, work, energy_balance)."""
    path = configuration(tmp_path, bar(nitsche='method = "mixed"', scheme="cn"))
    config = load_config(path)
    simulation = build_simulation(config, progress=False, source=path)
    columns = history_columns(config, simulation)
    assert set(columns) <= set(simulation.state())
    assert "reaction_2" not in columns and "energy" in columns and "contact_force" in columns
    history = simulation.run(columns=columns)
    assert history["t"][-1] == pytest.approx(0.2)


def test_nitsche_run_keeps_its_reactions_by_default(tmp_path):
    """The same bar by Nitsche's method keeps the reaction and the work of its support."""
    path = configuration(tmp_path, bar(nitsche="gamma0 = 1e-3"))
    config = load_config(path)
    columns = history_columns(config, build_simulation(config, progress=False, source=path))
    assert {"reaction_2", "work", "energy_balance"} <= set(columns)


# -- 2 and 3. a moving obstacle's keys and the obstacle itself -------------------------------


def test_rotation_axis_is_named_as_the_file_writes_it(tmp_path):
    message = refusal(
        tmp_path,
        {"tag = 1": 'tag = 1\nangle = "0.1 * t"\nrotation_axis = [0.0, 0.0, 0.0]'},
    )
    assert "[[obstacle]] #1 rotation_axis = [0.0, 0.0, 0.0]: the axis must have a non-zero" in (
        message
    )
    assert " axis = " not in message


def test_rotation_axis_in_2d_and_a_pivot_without_angle_are_refused(tmp_path):
    message = refusal(
        tmp_path, {"tag = 1": 'tag = 1\nangle = "0.1 * t"\nrotation_axis = [0.0, 1.0]'}
    )
    assert "[[obstacle]] #1 rotation_axis = [0.0, 1.0]: a 2D obstacle turns about z" in message
    message = refusal(tmp_path, {"tag = 1": 'tag = 1\ntranslation = ["0", "t"]\npivot = [0, 1]'})
    assert "[[obstacle]] #1 pivot = [0, 1]: it goes with angle" in message


def test_a_3d_angle_without_its_axis_names_rotation_axis(tmp_path):
    path = configuration(
        tmp_path,
        """
        [mesh]
        generator = "ball"
        mesh_size = 10.0
        order = 1

        [material]
        E = 1000.0
        nu = 0.3

        [scheme]
        dt = 0.01
        t_end = 0.02

        [[obstacle]]
        point = [0.0, 0.0, -1.0]
        normal = [0.0, 0.0, 1.0]
        tag = 1
        angle = "0.1 * t"
        """,
    )
    with pytest.raises(ConfigError) as error:
        build_simulation(load_config(path), progress=False, source="case.toml")
    assert str(error.value) == (
        "case.toml: [[obstacle]] #1 angle = '0.1 * t': a rotation in 3D needs its axis: give "
        "rotation_axis"
    )


def test_a_moving_circle_is_named_by_what_the_file_wrote(tmp_path):
    """A moving circle under a hyperelastic body: the table's motion, not a repr of
    MovingObstacle(SphereObstacle(...))."""
    message = refusal(
        tmp_path,
        {
            "nu = 0.3": 'nu = 0.3\nlaw = "neo_hookean"',
            'type = "plane"\npoint = [0.0, 0.0]\nnormal = [0.0, 1.0]': 'type = "circle"\n'
            'center = [0.0, -100.0]\nradius = 100.0\ntranslation = ["0", "0.1 * t"]',
        },
    )
    assert "[[obstacle]] #1 translation = ['0', '0.1 * t']: a hyperelastic body" in message
    assert "Obstacle(" not in message


# -- 4. the law the file wrote, in the table that wrote it -----------------------------------


def test_a_law_is_quoted_as_written(tmp_path):
    path = configuration(tmp_path, bar(material='law = "neo_hookean"', nitsche="gamma0 = 1e-3"))
    with pytest.raises(ConfigError) as error:
        build_simulation(load_config(path), progress=False, source="case.toml")
    assert "[material] law = 'neo_hookean': a hyperelastic material needs a 2D" in str(error.value)


def test_a_region_law_is_named_in_its_region(tmp_path):
    message = refusal(
        tmp_path, before_output('[[region]]\ntag = 1\nE = 1000.0\nnu = 0.3\nlaw = "svk"')
    )
    assert "[[region]] #1 law = 'svk': a hyperelastic material is one material" in message
    assert "[material]" in message.split(": ", 2)[2]  # where to give it instead


# -- 5. a long value is cut ------------------------------------------------------------------


def test_a_megabyte_expression_is_named_not_echoed(tmp_path):
    text = "x + " * 250_000 + "1"
    message = refusal(tmp_path, {"value = [0.0, -1.0]": f'value = ["0", "{text}"]'})
    assert ": [body_force] value = ['0', 'x + x + " in message
    assert f"(a text of {len(text)} characters)" in message
    assert f"the text has {len(text)} characters, more than 1000" in message
    assert len(message) < 400


def test_shown_cuts_long_values_only():
    assert shown([0.0, "1/t"]) == "[0.0, '1/t']"
    assert shown(np.array([1.0, 2.0])) == "[1.0, 2.0]"
    long = shown(list(range(10_000)))
    assert len(long) <= SHOWN_LENGTH and long.endswith("characters)")
    with pytest.raises(ParameterError) as error:
        ContactProblem(*bar_mesh(2), Material(E=1.0, nu=0.0), method="x" * 100_000)
    assert len(str(error.value)) < 300 and "(a text of 100000 characters)" in str(error.value)


# -- 6. data that is not finite at the start -------------------------------------------------

NOT_FINITE = {
    "body-force-1/t": (
        {"value = [0.0, -1.0]": 'value = ["0", "1/t"]'},
        "[body_force] value = ['0', '1/t']: component 1 ('1/t') is inf at t = 0: the body force "
        "must be finite",
    ),
    "traction-sqrt": (
        before_output('[[traction]]\ntag = 2\nvalue = ["0", "sqrt(-1 - t)"]'),
        "[[traction]] #1 value = ['0', 'sqrt(-1 - t)']: component 1 ('sqrt(-1 - t)') is nan at "
        "t = 0",
    ),
    "dirichlet-1/t": (
        before_output('[[dirichlet]]\ntag = 3\ncomponent = 1\nvalue = "1/t"'),
        "[[dirichlet]] #1 value = '1/t': '1/t' is inf at t = 0",
    ),
    "initial-log": (
        {"velocity = [0.0, -1.0]": 'velocity = ["0", "log(x - x)"]'},
        "[initial] velocity = ['0', 'log(x - x)']: component 1 ('log(x - x)') is -inf at x = [",
    ),
}


@pytest.mark.parametrize("name", list(NOT_FINITE))
def test_data_not_finite_at_the_start_is_refused_by_its_key(tmp_path, name):
    replace, named = NOT_FINITE[name]
    assert named in refusal(tmp_path, replace)


def test_data_not_finite_in_the_api():
    mesh, tags = block_mesh(2.0, 1.0, 4, 2)
    problem = ContactProblem(mesh, tags, Material(E=100.0, nu=0.3))
    with pytest.raises(ParameterError, match=r"^value=\['0', '1/t'\]: component 1 \('1/t'\)"):
        problem.add_body_force(["0", "1/t"])
    with pytest.raises(ParameterError, match=r"^velocity=\['log\(y\)', '0'\]: component 0"):
        problem.set_initial_conditions(velocity=["log(y)", "0"])  # y = 0 at the bottom
    problem.add_body_force(["0", "1/(t - 0.5)"])  # finite at the start
    problem.add_body_force(["0", "1/(x + 0.123456)"])  # finite at the cells' midpoints


def test_a_load_infinite_at_the_start_stops_the_command_in_one_line(tmp_path):
    path = ring_config(str(tmp_path), {"value = [0.0, -1.0]": 'value = ["0", "1/t"]'})
    result = run("-m", "nitsche_dolfinx", "run", path, "--quiet")
    assert_one_line_error(result, "[body_force] value = ['0', '1/t']: component 1 ('1/t') is inf")
    assert len(result.stderr.strip().splitlines()) == 1
    assert "gamma0" not in result.stderr


# -- 7. the default gamma0, whatever the units -----------------------------------------------


def test_default_gamma0_is_relative_to_the_stiffness():
    mesh, tags = bar_mesh(4)
    for E in (50.0, 2e11, 1e-3):
        problem = ContactProblem(mesh, tags, Material(E=E, nu=0.0))
        assert float(problem.gamma0.value) * E == pytest.approx(DEFAULT_GAMMA0_E)
        assert problem.gamma0_scaling == "absolute"
    scaled = ContactProblem(mesh, tags, Material(E=2e11, nu=0.0), gamma0_scaling="E")
    assert float(scaled.gamma0.value) == DEFAULT_GAMMA0_E
    given = ContactProblem(mesh, tags, Material(E=50.0, nu=0.0), gamma0=1e-6)
    assert float(given.gamma0.value) == 1e-6  # a given gamma0 as it is


def test_default_gamma0_with_regions_takes_the_stiffest():
    from nitsche_dolfinx.meshing import two_bars_mesh

    mesh, cells, facets = two_bars_mesh(4)
    soft, hard = Material(E=1.0, nu=0.0), Material(E=1e4, nu=0.0)
    problem = ContactProblem(mesh, facets, {1: hard, None: soft}, cell_tags=cells)
    assert float(problem.gamma0.value) == pytest.approx(DEFAULT_GAMMA0_E / 1e4)


def test_a_soft_body_runs_with_the_default_gamma0():
    """E = 50 and no gamma0: gamma0 E = 1e-3, the block lands and bounces (gamma0 = 1, the
    old default, was gamma0 E = 50, beyond the stability limit)."""
    mesh, tags = block_mesh(1.0, 0.5, 4, 2)
    problem = ContactProblem(mesh, tags, Material(E=50.0, nu=0.3))
    problem.add_obstacle(PlaneObstacle([0.0, 0.0], [0.0, 1.0]), 1)
    problem.set_initial_conditions(velocity=[0.0, -1.0])
    history = Simulation(problem, make_scheme("hybrid"), dt=0.01, t_end=0.3).run()
    assert history["t"][-1] == pytest.approx(0.3) and np.max(history["contact_force"]) > 0


def test_si_units_with_the_default_gamma0_are_valid(tmp_path):
    config = load_config(
        ring_config(str(tmp_path), {"E = 1000.0": "E = 2e11", "gamma0 = 1e-6": ""})
    )
    simulation = build_simulation(config, progress=False, source="config.toml")
    assert float(simulation.problem.gamma0.value) * 2e11 == pytest.approx(DEFAULT_GAMMA0_E)


# -- the sweep: other parameters named by the entry point's words ----------------------------

SWEEP = {
    "mixed-two-obstacles": (
        {
            "theta = 1.0 ": 'method = "mixed"\ntheta = 1.0 ',
            'name = "hybrid"': 'name = "cn"',
            "[output]": "[[obstacle]]\npoint = [0.0, 5.0]\nnormal = [0.0, -1.0]\ntag = 2\n\n"
            "[output]",
        },
        "[nitsche] method = 'mixed': the mixed method takes exactly one [[obstacle]], the file "
        "has 2",
    ),
    "mixed-dirichlet-value": (
        {
            "theta = 1.0 ": 'method = "mixed"\ntheta = 1.0 ',
            'name = "hybrid"': 'name = "cn"',
            "[output]": "[[dirichlet]]\ntag = 3\nvalue = [0.0, 0.1]\n\n[output]",
        },
        "[[dirichlet]] #1 value = [0.0, 0.1]: the mixed method ([nitsche] method = 'mixed') "
        "takes zero Dirichlet values only",
    ),
    "mixed-scheme-as-written": (
        {"theta = 1.0 ": 'method = "mixed"\ntheta = 1.0 ', 'name = "hybrid"': 'name = "newmark"'},
        "[scheme] name = 'newmark': the mixed method is time-discretised by Crank-Nicolson only",
    ),
    "other-parameter-in-toml-words": (
        {"degree = 1": 'degree = 2\nmass = "redistributed"', 'name = "hybrid"': 'name = "cn"'},
        "[mesh] mass = 'redistributed': this mass needs P1 elements, got [mesh] degree = 2",
    ),
    "verlet-in-toml-words": (
        {'name = "hybrid"': 'name = "verlet"'},
        "say which ([scheme] mass_solver = 'cg'), or take [mesh] mass = 'lumped'",
    ),
    "petsc-option": (
        before_output('[petsc]\nsnes_type = "newtonlsx"'),
        "[petsc] snes_type = 'newtonlsx': PETSc error code 86",
    ),
}


@pytest.mark.parametrize("name", list(SWEEP))
def test_configuration_names_keys_in_its_words(tmp_path, name):
    replace, named = SWEEP[name]
    message = refusal(tmp_path, replace)
    assert named in message
    assert "=" not in message.replace(" = ", "").replace("==", "")  # no API keyword=value


def test_in_words_of_each_entry_point():
    text = "take dt='auto' or insist on it (force_dt=True); got degree=2, nx=3, x==1"
    assert in_words_of(text, "toml") == (
        "take [scheme] dt = 'auto' or insist on it ([scheme] force_dt = true); got [mesh] "
        "degree = 2, nx=3, x==1"
    )
    assert in_words_of(text, "flag") == (
        "take --dt auto or insist on it (--force-dt); got --degree 2, nx=3, x==1"
    )


def test_a_demo_names_other_parameters_by_their_flags(tmp_path):
    result = run(
        "demos/bar_1d.py", "--degree", "2", "--mass", "redistributed", "--scheme", "cn",
        "--out", str(tmp_path), "--no-compare", "--no-plot", "--quiet",
    )  # fmt: skip
    assert_one_line_error(result, "--mass redistributed: this mass needs P1 elements, got "
                          "--degree 2")  # fmt: skip


def test_cli_names_a_petsc_flag(tmp_path):
    path = ring_config(str(tmp_path))
    result = run("-m", "nitsche_dolfinx", "run", path, "--check", "--petsc", "snes_type=bogus")
    assert_one_line_error(result, "--petsc snes_type=bogus: PETSc error code 86")


def test_no_nan_slips_through_the_checks():
    """The texts' values at points compute as the compiled forms do: nan and inf appear,
    conditionals and functions evaluate elementwise."""
    from nitsche_dolfinx.physics.expressions import evaluate, parse_expression

    points = np.array([[-1.0, 0.0, 2.0], [0.0, 1.0, 4.0]])
    cases = {
        "1/x": [-1.0, math.inf, 0.5],
        "sqrt(x)": [math.nan, 0.0, math.sqrt(2.0)],
        "max(x, y, 1) if x < 1 and y >= 0 else -t": [1.0, 1.0, -3.0],
        "log(abs(x)) + 2^2": [4.0, -math.inf, math.log(2.0) + 4.0],
    }
    for text, expected in cases.items():
        values = evaluate(parse_expression(text, name="v", gdim=2), points, 3.0)
        np.testing.assert_array_equal(values, expected)
    assert REPO  # the helpers' repository
