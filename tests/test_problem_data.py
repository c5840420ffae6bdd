"""Problem data in space and time (docs/method.md section 13): loads, Dirichlet values and
initial fields given as UFL of the problem's x and t, or as texts of the expression
language in the API and the TOML file."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest
import ufl
from dolfinx import fem

from nitsche_dolfinx import ContactProblem, Material, PlaneObstacle, Simulation, make_scheme
from nitsche_dolfinx.config import ConfigError, build_simulation, history_columns, load_config
from nitsche_dolfinx.meshing import bar_mesh, block_mesh, tag_facets

#: A free bar (no obstacle, no clamp): (0, 1), E = rho = 1, pushed by f = x t.
FREE_BAR = """
    [mesh]
    generator = "bar"
    nx = 10
    mass = "{mass}"

    [material]
    E = 1.0
    nu = 0.0

    [scheme]
    name = "{scheme}"
    dt = {dt}
    t_end = 0.6

    [body_force]
    value = {force}
"""


def configured(tmp_path, text: str):
    path = tmp_path / "case.toml"
    path.write_text(textwrap.dedent(text))
    config = load_config(str(path))
    return config, build_simulation(config, progress=False, source=str(path))


@pytest.mark.parametrize(
    "scheme, dt, mass", [("hybrid", 0.1, "consistent"), ("verlet", '"auto"', "lumped")]
)
def test_force_in_space_and_time_gives_its_impulse(tmp_path, scheme, dt, mass):
    """A free bar pushed by f = x t: its momentum is int_0^t int_0^1 x s dx ds = t^2 / 4.
    Both schemes integrate it exactly: the hybrid's load is linear over each step, Verlet's
    lumped load (M f_h / rho) sums x exactly on P1 and its velocity update is the
    trapezoid rule, exact for a force linear in t. Round-off: 1e-13 of momenta below 0.1,
    compared to 1e-9 of the largest, as it varies with the processor."""
    text = FREE_BAR.format(scheme=scheme, dt=dt, force='["x * t"]', mass=mass)
    config, simulation = configured(tmp_path, text)
    history = simulation.run(columns=history_columns(config, simulation) + ["momentum"])
    t = np.asarray(history["t"])
    atol = 1e-9 * (t**2 / 4).max()
    np.testing.assert_allclose(history["momentum"], t**2 / 4, rtol=0, atol=atol)


def test_toml_text_and_api_ufl_give_the_same_history(tmp_path):
    """The free bar pushed by f = x t, from the TOML file's text and from the API's UFL
    (problem.x, problem.t): the same history to 1e-9 of each column's largest value (two
    compiled forms, whose round-off may differ with the processor)."""
    text = FREE_BAR.format(scheme="hybrid", dt=0.1, force='["x * t"]', mass="consistent")
    config, simulation = configured(tmp_path, text)
    columns = ["t", "energy", "kinetic", "elastic", "potential", "momentum"]
    theirs = simulation.run(columns=columns)
    mesh, tags = bar_mesh(10)
    problem = ContactProblem(mesh, tags, Material(E=1.0, nu=0.0, rho=1.0))
    problem.add_body_force(ufl.as_vector([problem.x[0] * problem.t]))
    ours = Simulation(problem, make_scheme("hybrid"), dt=0.1, t_end=0.6).run(columns=columns)
    for name in columns:
        their, our = np.asarray(theirs[name]), np.asarray(ours[name])
        assert np.abs(our - their).max() <= 1e-9 * max(np.abs(their).max(), 1e-300), name


@pytest.mark.mpi
def test_text_and_ufl_give_the_same_history():
    """The same data as texts and as UFL of problem.x and problem.t: a block on the plane
    under a load varying in x and t, its top moved along x by a value in x and t, thrown
    with a velocity in x. The two problems compile the same UFL (the texts build the
    user's operations in the same order), so their histories agree to round-off (measured
    below 1e-12 of each column's largest value, the issue's bound); compared to 1e-9, as
    two compilations whose round-off may differ with the processor."""

    def problem(data):
        mesh, tags = block_mesh(2.0, 1.0, 4, 2)
        tags = tag_facets(mesh, {7: lambda x: np.isclose(x[1], 1.0)}, tags)
        problem = ContactProblem(mesh, tags, Material(E=100.0, nu=0.3, rho=1.0), degree=2,
                                 gamma0=1e-5)  # fmt: skip
        problem.add_obstacle(PlaneObstacle([0.0, 0.0], [0.0, 1.0]), 1)
        force, top, velocity = data(problem)
        problem.add_body_force(force)
        problem.add_dirichlet(7, top, component=0)
        problem.set_initial_conditions(velocity=velocity)
        return problem

    def texts(problem):
        return (["0.5 * sin(pi * x) * t", "-1 - 0.5 * x^2"], "0.01 * x * t",
                ["0.1 * y", "-0.2 if x < 0 else -0.1"])  # fmt: skip

    def ufl_data(problem):
        x, t = problem.x, problem.t
        force = ufl.as_vector([0.5 * ufl.sin(ufl.pi * x[0]) * t, -1 - 0.5 * x[0] ** 2])
        velocity = ufl.as_vector([0.1 * x[1], ufl.conditional(ufl.lt(x[0], 0), -0.2, -0.1)])
        return force, 0.01 * x[0] * t, velocity

    histories = [Simulation(problem(data), make_scheme("hybrid"), dt=0.05, t_end=0.5).run()
                 for data in (texts, ufl_data)]  # fmt: skip
    for name in ("energy", "energy_theta", "kinetic", "elastic", "potential", "contact_force"):
        theirs, ours = (np.asarray(h[name]) for h in histories)
        assert np.abs(ours - theirs).max() <= 1e-9 * max(np.abs(theirs).max(), 1e-300), name


@pytest.mark.mpi
def test_dirichlet_value_in_space_and_time():
    """The top of the block follows u_x = 0.01 x t at its nodes (P2 interpolates x t
    exactly): to round-off of the values (1e-15 of 0.01), compared to 1e-9 of their scale,
    0.01 x t <= 3e-3 (the compiled text against numpy)."""
    mesh, tags = block_mesh(2.0, 1.0, 4, 2)
    tags = tag_facets(mesh, {7: lambda x: np.isclose(x[1], 1.0)}, tags)
    problem = ContactProblem(mesh, tags, Material(E=100.0, nu=0.3, rho=1.0), degree=2)
    problem.add_dirichlet(7, "0.01 * x * t", component=0)
    problem.add_dirichlet(1, [0.0, 0.0])  # the bottom clamped
    simulation = Simulation(problem, make_scheme("hybrid"), dt=0.1, t_end=0.3)
    simulation.run()
    V = problem.V
    top = fem.locate_dofs_topological(V, 1, problem.facets(7))
    x = V.tabulate_dof_coordinates()[top, 0]
    u = simulation.u.x.array.reshape(-1, 2)[top, 0]
    np.testing.assert_allclose(u, 0.01 * x * 0.3, rtol=0, atol=1e-9 * 3e-3)


def test_initial_fields_as_texts_and_as_functions():
    """An initial displacement given as a text of x equals the same given as a function
    of the coordinates (interpolated the same way: to round-off, but the compiled sin and
    numpy's are two implementations: 1e-9 of the amplitude 0.1)."""
    fields = []
    for value in ("0.1 * sin(pi * x)", lambda x: 0.1 * np.sin(np.pi * x[0])):
        mesh, tags = bar_mesh(10)
        problem = ContactProblem(mesh, tags, Material(E=1.0, nu=0.0, rho=1.0))
        problem.set_initial_conditions(displacement=value)
        simulation = Simulation(problem, make_scheme("hybrid"), dt=0.1, t_end=0.1)
        fields.append(simulation.u.x.array.copy())
    np.testing.assert_allclose(fields[0], fields[1], rtol=0, atol=1e-9 * 0.1)


@pytest.mark.parametrize(
    "force, token",
    [
        ("[\"__import__('os')\"]", "function '__import__'"),
        ('["x.real"]', "attribute access"),
        ('["y"]', "'y'"),  # the bar is 1D
        ('["2 ** 1000"]', "exponent 1000"),
        ('["t +"]', "syntax error"),
    ],
)
def test_bad_expression_in_the_file_is_named(tmp_path, force, token):
    """A bad text is refused in one line naming the file, the key and the token."""
    text = FREE_BAR.format(scheme="hybrid", dt=0.1, force=force, mass="consistent")
    with pytest.raises(ConfigError) as error:
        configured(tmp_path, text)
    message = str(error.value)
    assert "case.toml" in message and "[body_force]" in message and token in message
    assert "\n" not in message
