"""The parameter objects (one check per value, named per entry point) and the history."""

import argparse

import numpy as np
import pytest

from nitsche_dolfinx.arguments import add_method_arguments, method_parameters
from nitsche_dolfinx.history import History
from nitsche_dolfinx.parameters import (
    Discretisation,
    NitscheParameters,
    OutputParameters,
    ParameterError,
    TimeStepping,
)
from nitsche_dolfinx.schemes import SCHEMES, make_scheme


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
        (lambda: Discretisation(degree=2, mass="lumped"), "mass", "lumped"),
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
    assert set(SCHEMES) == {"hybrid", "theta", "newmark", "cn"}
    assert make_scheme("theta", theta=0.7).describe() == "theta(theta=0.7)"
    assert make_scheme("newmark", beta=0.5, gamma=1.0).describe() == "newmark(beta=0.5, gamma=1)"


def test_demo_flags_become_the_same_objects():
    parser = argparse.ArgumentParser()
    add_method_arguments(parser, gamma0=1e-3, degree=2, dt=0.1, t_end=1.0)
    parsed = method_parameters(parser.parse_args(["--scheme", "theta", "--theta", "0.5"]))
    assert parsed.time == TimeStepping(0.1, 1.0) and parsed.time.num_steps == 10
    assert parsed.nitsche == NitscheParameters(gamma0=1e-3)
    assert parsed.discretisation == Discretisation(degree=2)
    assert parsed.scheme.describe() == "theta(theta=0.5)"


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
