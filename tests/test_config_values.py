"""What the TOML configuration adds to the demos' runs, against known values: loads and
Dirichlet values that follow a table in time, curved obstacles, the schema, the output
defaults and the --petsc flag."""

import math
import os
import textwrap

import numpy as np
import pytest
from runs import ring_config

from nitsche_dolfinx.cli import main as cli
from nitsche_dolfinx.config import (
    FACET_SELECTORS,
    SCHEMA,
    build_simulation,
    describe,
    history_columns,
    load_config,
    output_parameters,
)
from nitsche_dolfinx.physics import PiecewiseLinear, PolynomialField, Ramp, Sine


def configured(tmp_path, text: str, name: str = "case.toml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    config = load_config(str(path))
    return config, build_simulation(config, progress=False, source=str(path))


#: A free bar (no obstacle, no clamp): (0, 1), E = rho = 1.
FREE_BAR = """
    [mesh]
    generator = "bar"
    nx = 10

    [material]
    E = 1.0
    nu = 0.0

    [scheme]
    dt = 0.1
    t_end = 0.6
"""


@pytest.mark.parametrize(
    "force",
    [
        "[[0.0, 0.0], [0.3, 1.0], [0.6, 1.0]]",
        '{ profile = "ramp", value = [1.0], duration = 0.3 }',
    ],
    ids=["table", "ramp"],
)
def test_load_table_in_time(tmp_path, force):
    """A free bar pushed by f(t), linear up to 1 at t = 0.3 and then held: its momentum is
    int_0^t f exactly (the scheme integrates a force linear over each step exactly)."""
    config, simulation = configured(tmp_path, FREE_BAR + f"\n[body_force]\nvalue = {force}\n")
    history = simulation.run(columns=history_columns(config, simulation) + ["momentum"])
    t = history["t"]
    impulse = np.where(t <= 0.3, t**2 / 0.6, 0.15 + (t - 0.3))
    # the run against the exact impulse, round-off apart: 1e-9 of its largest value
    atol = 1e-9 * impulse.max()
    np.testing.assert_allclose(history["momentum"], impulse, rtol=0, atol=atol)


def test_dirichlet_table_in_time(tmp_path):
    """The end x = 1 of a bar follows its table of displacements at every time level."""
    text = (
        FREE_BAR
        + """
        [[dirichlet]]
        tag = 2
        value = [[0.0, 0.0], [0.25, 0.01], [0.5, -0.02]]

        [[probe]]
        name = "u_end"
        quantity = "displacement"
        facets = 2
    """
    )
    config, simulation = configured(tmp_path, text)
    history = simulation.run(columns=history_columns(config, simulation))
    expected = np.interp(history["t"], [0.0, 0.25, 0.5], [0.0, 0.01, -0.02])
    # the probe of the run against the table: 1e-9 of the table's scale, 0.02
    np.testing.assert_allclose(history["u_end"], expected, rtol=0, atol=1e-9 * 0.02)


DISK = """
    [mesh]
    generator = "disk"                # radius 20 around (0, 20): its lowest point at 0
    mesh_size = 16.0
    degree = 2

    [material]
    lmbda = 20.0
    mu = 20.0

    [scheme]
    dt = 0.5
    t_end = {t_end}

    [body_force]
    value = [0.0, -0.1]

    [initial]
    displacement = [0.0, {lift}]

    [[obstacle]]
    tag = 1
    {obstacle}
"""
BALL = """
    [mesh]
    generator = "ball"                # radius 20 around (0, 0, 20)
    mesh_size = 20.0
    order = 2

    [material]
    lmbda = 20.0
    mu = 20.0

    [scheme]
    dt = 0.5
    t_end = 0.5

    [[obstacle]]
    tag = 1
    {obstacle}
"""


@pytest.mark.parametrize(
    "body, obstacle, gap",
    [
        (DISK, 'type = "circle"\ncenter = [0.0, 20.0]\nradius = 25.0\nside = "inside"', 5.0),
        (DISK, 'type = "circle"\ncenter = [0.0, -100.0]\nradius = 100.0', 0.0),
        (BALL, 'type = "sphere"\ncenter = [0.0, 0.0, -50.0]\nradius = 50.0', 0.0),
        (BALL, 'type = "cylinder"\npoint = [0.0, 0.0, 5.0]\naxis = [0.0, 0.0, 2.0]\n'
         'radius = 25.0\nside = "inside"', 5.0),
    ],
    ids=["disk-in-circle", "disk-on-circle", "ball-on-sphere", "ball-in-pipe"],
)  # fmt: skip
def test_curved_obstacle_gap(tmp_path, body, obstacle, gap):
    """The initial gap of the nodes of Gamma_C (on the exact circle or sphere): 5 to a
    concentric cavity of radius 25 (for the ball in a pipe, at its equator), 0 at the
    lowest point on a circle or sphere below."""
    text = body.format(t_end=0.5, lift=0.0, obstacle=obstacle.replace("\n", "\n    "))
    _, simulation = configured(tmp_path, text)
    # distances computed against exact ones: 1e-9 of the body's size, its radius 20
    assert simulation.state()["penetration_max"] == pytest.approx(-gap, abs=1e-9 * 20.0)


def test_disk_falls_on_a_circle_as_on_the_plane(tmp_path):
    """Lifted by 5, the disk reaches a large circle below at the time it reaches the plane
    (its lowest point first), and E_Theta does not rise."""
    first = {}
    for name, obstacle in (
        ("plane", 'type = "plane"\n    point = [0.0, 0.0]\n    normal = [0.0, 1.0]'),
        ("circle", 'type = "circle"\n    center = [0.0, -1000.0]\n    radius = 1000.0'),
    ):
        folder = tmp_path / name
        folder.mkdir()
        _, simulation = configured(folder, DISK.format(t_end=12.0, lift=5.0, obstacle=obstacle))
        history = simulation.run()
        first[name] = history["t"][np.argmax(history["contact_force"] > 0)]
        # a step's rise of E_Theta is <F, u^{n+1} - u^n> <= snes_rtol S |du|: at most 3.0e-8
        # here (measured; tau = 0.5), plus twice its round-off (3.8e-11): 4.8e-11 E_Theta(0);
        # Newton's and round-off's share vary with the processor: 1e-9 E_Theta(0)
        assert np.diff(history["energy_theta"]).max() <= 1e-9 * history["energy_theta"][0]
    assert first["circle"] == first["plane"] and 10.0 <= first["plane"] <= 10.5


def test_schema_lists_every_key_with_its_default(capsys):
    text = describe()
    for name, table in SCHEMA.items():
        assert table.header(name) in text
        for key, spec in table.keys.items():
            assert f"  {key:18s} {spec.kind:14s}" in text, (name, key)
    for name, table in FACET_SELECTORS.items():
        section = text[text.index(f"\n{name} = {{ ... }}") :]
        for key, spec in table.keys.items():
            assert f"  {key:18s} {spec.kind:14s}" in section, (name, key)
    assert 'default: "hybrid"' in text and 'time step tau (verlet: "auto"' in text
    assert cli(["schema"]) == 0
    printed = capsys.readouterr().out
    assert cli(["--help-config"]) == 0
    assert capsys.readouterr().out == printed == text + "\n"


def test_output_defaults_next_to_the_file(tmp_path):
    """Without [output] dir and every: out/<name> next to the file, about 50 outputs."""
    path = ring_config(str(tmp_path), {"every = 10": "", 'dir = "../out/ring_2d_cli"': ""}, 0.3)
    config = load_config(path)
    assert config["output"]["dir"] == os.path.join(str(tmp_path), "out", "config")
    assert output_parameters(config).output_every == math.ceil(60 / 50)


def test_petsc_flag_reaches_the_solver(tmp_path, capfd):
    path = ring_config(str(tmp_path), t_end=0.01)
    out = str(tmp_path / "out")
    assert cli(["run", path, "--quiet", "--out", out, "--petsc", "snes_monitor"]) == 0
    assert "SNES Function norm" in capfd.readouterr().out


def test_value_forms():
    table = PiecewiseLinear([[0.0, 0.0, 1.0], [2.0, 4.0, -1.0]])
    # dyadic values, exact in any order of the operations: compared exactly
    np.testing.assert_array_equal(table(-1.0), [0.0, 1.0])  # held before the first time
    np.testing.assert_array_equal(table(0.5), [1.0, 0.5])
    np.testing.assert_array_equal(table(3.0), [4.0, -1.0])  # and after the last
    np.testing.assert_array_equal(Ramp([2.0], 4.0)(1.0), [0.5])
    # libm's sin(pi) against 0: 1e-9 of the amplitude 2
    assert Sine([2.0], 0.25, math.pi / 2)(1.0)[0] == pytest.approx(0.0, abs=1e-9 * 2.0)
    field = PolynomialField(2, [1.0, 0.0], [[0.0, 2.0], [0.0, 0.0]], [np.eye(2), np.zeros((2, 2))])
    x = np.array([[1.0, 2.0], [3.0, -1.0], [0.0, 0.0]])
    expected = [1.0 + 2.0 * x[1] + 0.5 * (x[0] ** 2 + x[1] ** 2), np.zeros(2)]
    # numpy's products (BLAS) against the formula: 1e-9 of the values (zeros stay exact)
    np.testing.assert_allclose(field(x), expected, rtol=1e-9)
