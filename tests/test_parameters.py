"""The parameter objects (one check per value, named per entry point), the table of their
names in the API, TOML and flags, the registries that own their keys, and the history."""

import argparse
import inspect
import os
import re

import numpy as np
import pytest
from runs import REPO

from nitsche_dolfinx.cli import (
    add_method_arguments,
    add_run_arguments,
    add_terminal_arguments,
    method_parameters,
    under_its_flag,
)
from nitsche_dolfinx.common import (
    Discretisation,
    NitscheParameters,
    OutputParameters,
    ParameterError,
    TimeStepping,
)
from nitsche_dolfinx.config import OWNERS, PARAMETERS, SCHEMA, by_name, markdown, reported_at
from nitsche_dolfinx.output import History
from nitsche_dolfinx.physics import OBSTACLES
from nitsche_dolfinx.steppers import SCHEMES, make_scheme


@pytest.mark.parametrize(
    "make, name, value",
    [
        (lambda: TimeStepping(0.0, 1.0), "dt", 0.0),
        (lambda: TimeStepping(0.1, float("nan")), "t_end", None),
        (lambda: TimeStepping(0.1, 0.05), "t_end", 0.05),
        (lambda: NitscheParameters(gamma0=float("inf")), "gamma0", float("inf")),
        (lambda: NitscheParameters(nitsche_theta=float("nan")), "nitsche_theta", None),
        (lambda: NitscheParameters(friction=-0.1), "friction", -0.1),
        (lambda: NitscheParameters(method="lagrange"), "method", "lagrange"),
        (lambda: NitscheParameters(method="mixed", friction=0.2), "friction", 0.2),
        (lambda: Discretisation(degree=3), "degree", 3),
        (lambda: Discretisation(degree=2, mass="redistributed"), "mass", "redistributed"),
        (lambda: OutputParameters(output_every=-1), "output_every", -1),
        (lambda: OutputParameters(checkpoint_every=1.5), "checkpoint_every", 1.5),
        (lambda: make_scheme("theta", theta=1.5), "theta", 1.5),
        (lambda: make_scheme("newmark", beta=0.6), "beta", 0.6),
        (lambda: make_scheme("leapfrog"), "scheme", "leapfrog"),
    ],
)
def test_each_bad_value_is_named(make, name, value):
    with pytest.raises(ParameterError) as caught:
        make()
    assert caught.value.name == name
    if value is not None:
        assert caught.value.value == value
        assert str(caught.value).startswith(f"{name}={value!r}: ")


def test_an_entry_point_names_the_value_its_own_way():
    error = ParameterError("gamma0", 0.0, "the Nitsche parameter must be positive")
    assert str(error.named("--gamma0 0")) == "--gamma0 0: the Nitsche parameter must be positive"
    assert error.named("x").name == "gamma0"


def test_schemes_are_looked_up_by_name_with_their_own_parameters():
    assert set(SCHEMES) == {"hybrid", "theta", "newmark", "cn", "verlet"}
    assert make_scheme("theta", theta=0.7).describe() == "theta(theta=0.7)"
    assert make_scheme("verlet", safety=0.3, theta=0.7).describe() == "verlet(safety=0.3)"
    assert make_scheme("newmark", beta=0.5, gamma=1.0).describe() == "newmark(beta=0.5, gamma=1)"


def test_demo_flags_become_the_same_objects():
    parser = argparse.ArgumentParser()
    add_method_arguments(parser, gamma0=1e-3, degree=2, dt=0.1, t_end=1.0)
    parsed = method_parameters(parser.parse_args(["--scheme", "theta", "--theta", "0.5"]))
    assert parsed.time == TimeStepping(0.1, 1.0) and parsed.time.num_steps == 10
    assert parsed.nitsche == NitscheParameters(gamma0=1e-3)
    assert parsed.discretisation == Discretisation(degree=2)
    assert parsed.scheme.describe() == "theta(theta=0.5)"


def test_demo_flags_keep_their_names_and_defaults():
    """The flags of docs/method.md section 6 (SPEC), made from the table: their defaults and
    types as before the table (a demo's own defaults where it gives them)."""
    parser = argparse.ArgumentParser()
    add_method_arguments(parser, gamma0=1e-6, degree=1, dt=0.015, t_end=6.0, beta=0.3)
    add_run_arguments(parser)
    add_terminal_arguments(parser)
    args = vars(parser.parse_args([]))
    assert args == {
        "scheme": "hybrid", "theta": 1.0, "beta": 0.3, "gamma": 0.5, "nitsche_theta": 1.0,
        "gamma0": 1e-6, "gamma0_scaling": "absolute", "degree": 1, "dt": 0.015, "t_end": 6.0,
        "safety": 0.5, "force_dt": False, "mass_solver": "none", "max_step_cuts": 5,
        "checkpoint_every": 0, "restart": False, "output_every": 10, "quiet": False,
        "no_plot": False,
    }  # fmt: skip
    parsed = parser.parse_args(["--degree", "2", "--dt", "0.5", "--scheme", "newmark"])
    assert (parsed.degree, parsed.dt, parsed.scheme) == (2, 0.5, "newmark")
    with pytest.raises(SystemExit):
        parser.parse_args(["--scheme", "leapfrog"])


def test_table_names_every_keyword_of_the_api():
    """Every keyword of ContactProblem, Simulation and its run that is a value (not the
    mesh, the material, a scheme object or a callback) is in the table, under its owner."""
    objects = {"mesh", "facet_tags", "cell_tags", "material", "problem", "self", "callback"}
    for owner in ("ContactProblem", "Simulation", "Simulation.run"):
        keywords = set(inspect.signature(OWNERS[owner]).parameters) - objects
        listed = {p.name for p in PARAMETERS if p.owner == owner}
        assert keywords == listed, owner
    assert len({p.name for p in PARAMETERS}) == len(PARAMETERS)
    assert len({p.flag for p in PARAMETERS if p.flag}) == len([p for p in PARAMETERS if p.flag])


def test_table_is_the_schema_of_its_tables():
    """[scheme], [nitsche], [solver], [material] and [output] hold the table's keys, with
    its defaults (the TOML keys a demo's TOML file sets)."""
    for parameter in PARAMETERS:
        if parameter.toml_key is None:
            continue
        assert SCHEMA[parameter.table].keys[parameter.toml_key] is parameter.key
    for table in ("scheme", "nitsche", "solver", "material", "output"):
        assert set(SCHEMA[table].keys) == {p.toml_key for p in PARAMETERS if p.table == table}


def test_registries_own_their_keys():
    """A scheme's keys are its constructor's parameters with its defaults (and those of
    make_scheme); an obstacle's keys are its class's keyword arguments."""
    defaults = inspect.signature(make_scheme).parameters
    for cls in SCHEMES.values():
        signature = inspect.signature(cls).parameters
        assert set(cls.parameters) == set(signature)
        for key, spec in cls.parameters.items():
            assert spec.default == signature[key].default == defaults[key].default
    for name, obstacle in OBSTACLES.items():
        signature = inspect.signature(obstacle.make).parameters
        assert set(obstacle.keys) == set(signature), name
        for key, spec in obstacle.keys.items():
            assert spec.required == (signature[key].default is inspect.Parameter.empty)
            assert SCHEMA["obstacle"].keys[key].kind == spec.kind


def test_docs_parameters_is_up_to_date():
    """docs/parameters.md is what `nitsche-dolfinx parameters` prints (regenerate it with
    `nitsche-dolfinx parameters > docs/parameters.md`)."""
    with open(os.path.join(REPO, "docs", "parameters.md")) as f:
        assert f.read() == markdown()


@pytest.mark.parametrize(
    "name, value, flag, toml",
    [
        ("friction", -1.0, "--mu -1", "[nitsche] friction = -1.0"),
        ("nitsche_theta", 1e300, "--nitsche-theta 1e+300", "[nitsche] theta = 1e+300"),
        ("output_every", -2, "--output-every -2", "[output] every = -2"),
        ("nx", 0, "--nx 0", "[mesh] nx = 0"),  # a demo's own flag: its destination
        ("mu", 0.0, None, "[material] mu = 0.0"),  # the shear modulus, not --mu
    ],
)
def test_errors_are_named_by_the_flag_or_the_key_that_set_them(name, value, flag, toml):
    parser = argparse.ArgumentParser()
    parser.add_argument("--mu", type=float)
    parser.add_argument("--nitsche-theta", type=float)
    parser.add_argument("--output-every", type=int)
    parser.add_argument("--nx", type=int)
    error = ParameterError(name, value, "bad")
    named = under_its_flag(error, parser)
    assert str(named) == (f"{flag}: bad" if flag else str(error))
    where = "[mesh]" if by_name(name) is None else "[scheme]"
    with pytest.raises(ValueError, match="^" + re.escape(f"config: {toml}: bad") + "$"):
        with reported_at(where, "config"):
            raise error


def test_history_columns_rows_and_summary():
    rows = [
        {
            "t": 0.0,
            "energy": 2.0,
            "energy_theta": 2.0,
            "contact_force": 0.0,
            "newton_iterations": 0,
        },
        {
            "t": 0.5,
            "energy": 2.0,
            "energy_theta": 2.1,
            "contact_force": 1.0,
            "newton_iterations": 3,
        },
        {
            "t": 1.0,
            "energy": 1.5,
            "energy_theta": 1.9,
            "contact_force": 2.0,
            "newton_iterations": 5,
        },
        {
            "t": 1.5,
            "energy": 1.0,
            "energy_theta": 1.8,
            "contact_force": 0.0,
            "newton_iterations": 1,
        },
    ]
    history = History(rows)
    assert len(history) == 4 and history[-1]["t"] == 1.5 and list(history)[0] is rows[0]
    assert np.array_equal(history["energy"], [2.0, 2.0, 1.5, 1.0])
    assert history.energy_drift() == pytest.approx(-0.5)
    assert history.energy_drift("energy_theta") == pytest.approx(-0.1)
    assert history.largest_rise() == pytest.approx(0.05)
    assert history.mean_newton_iterations() == pytest.approx(3.0)
    assert history.contact_interval() == (0.5, 1.0)
    assert history.summary()["first_contact"] == 0.5
    with pytest.raises(KeyError, match="no column 'energi'"):
        history["energi"]
