"""The same physical problem in other units gives the same run (docs/method.md sections 8
and 10): Newton's tolerance is relative to the scale of each step's equation, and gamma0
can be given without units (``gamma0_scaling="E"``).

The ring of ``demos/ring_2d.toml`` in SI units (steel: E = 2.1e11 Pa, rho = 7800 kg/m^3,
gravity 9.81 m/s^2, tau = 5e-4 s) against the same ring in scaled units: lengths kept,
stresses divided by S = E / 1000, densities by R = rho, so that times are divided by
T = sqrt(R / S) and, per unit thickness, energies by S and forces by S.
"""

import re

import numpy as np
import pytest
from mpi4py import MPI
from runs import MESH

from nitsche_dolfinx import ContactProblem, HybridScheme, Material, PlaneObstacle, Simulation
from nitsche_dolfinx.common import ParameterError
from nitsche_dolfinx.meshing import load_mesh

E_SI, RHO_SI, G_SI, DT_SI = 2.1e11, 7800.0, 9.81, 5e-4
STRESS = E_SI / 1000.0  # the scaled ring has E = 1000, rho = 1
TIME = np.sqrt(RHO_SI / STRESS)
#: history columns and their unit in the scaled run (per unit thickness, lengths kept)
SCALES = {
    "t": TIME,
    "energy": STRESS,
    "energy_theta": STRESS,
    "kinetic": STRESS,
    "elastic": STRESS,
    "potential": STRESS,
    "contact_force": STRESS,
    "contact_area": 1.0,
    "penetration_max": 1.0,
    "dt": TIME,
}


def _ring(E, rho, gravity, velocity, dt, gamma0, scaling, steps=40):
    mesh, tags = load_mesh(MESH, gdim=2, comm=MPI.COMM_WORLD)
    problem = ContactProblem(
        mesh, tags, Material(E=E, nu=0.3, rho=rho), gamma0=gamma0, gamma0_scaling=scaling
    )
    # the ground just below the ring (its lowest point is at y = 0.1): contact at once
    problem.add_obstacle(PlaneObstacle([0.0, 0.0995], [0.0, 1.0]), 1)
    problem.add_body_force([0.0, -rho * gravity])
    problem.set_initial_conditions(velocity=[0.0, -velocity])
    return Simulation(problem, HybridScheme(), dt=dt, t_end=steps * dt).run()


@pytest.mark.parametrize("scaling", ["E", "absolute"])
def test_steel_ring_in_si_units_is_the_scaled_ring(scaling):
    gamma0 = 1e-3 if scaling == "E" else 1e-3 / E_SI
    si = _ring(E_SI, RHO_SI, G_SI, 1.0, DT_SI, gamma0, scaling)
    gamma0 = 1e-3 if scaling == "E" else 1e-3 / 1000.0
    scaled = _ring(1000.0, 1.0, G_SI * TIME**2, TIME, DT_SI / TIME, gamma0, scaling)
    assert max(si["contact_force"]) > 0  # the ring hits the ground
    np.testing.assert_array_equal(si["newton_iterations"], scaled["newton_iterations"])
    for column, unit in SCALES.items():
        expected = scaled[column] * unit
        scale = np.abs(expected).max()
        np.testing.assert_allclose(si[column], expected, rtol=0, atol=1e-8 * scale, err_msg=column)


@pytest.mark.parametrize(
    "E, gamma0, scaling, message",
    [
        (2.1e11, 1e-6, "absolute", "gamma0 * E = 2.1e+05"),
        (1000.0, 1e300, "absolute", "gamma0=1e+300"),
        (1000.0, 1e-20, "E", "gamma0=1e-20"),
        (1000.0, 1e-3, "stress", "gamma0_scaling='stress'"),
    ],
)
def test_gamma0_out_of_range_is_refused(E, gamma0, scaling, message):
    mesh, tags = load_mesh(MESH, gdim=2, comm=MPI.COMM_WORLD)
    with pytest.raises(ParameterError, match=re.escape(message)):
        ContactProblem(
            mesh, tags, Material(E=E, nu=0.3, rho=1.0), gamma0=gamma0, gamma0_scaling=scaling
        )


def test_configuration_takes_gamma0_without_units(tmp_path):
    """``[nitsche] gamma0_scaling = "E"`` with gamma0 = 1e-3 is the shipped ring's
    gamma0 = 1e-6 at E = 1000, through the impact; ``[scheme] max_step_cuts`` is read."""
    from runs import ring_config

    from nitsche_dolfinx.config import build_simulation, load_config

    ground = {"point = [0.0, 0.0]": "point = [0.0, 0.0995]"}  # contact at once
    dimensionless = {
        **ground,
        "gamma0 = 1e-6": 'gamma0 = 1e-3\ngamma0_scaling = "E"',
        'name = "hybrid"': 'name = "hybrid"\nmax_step_cuts = 0',
    }
    runs = []
    for name, replace in (("absolute", ground), ("E", dimensionless)):
        folder = tmp_path / name
        folder.mkdir()
        config = load_config(ring_config(str(folder), replace, t_end=0.1))
        simulation = build_simulation(config, progress=False)
        runs.append((simulation, simulation.run()))
    (absolute, a), (scaled, b) = runs
    assert scaled.problem.gamma0_scaling == "E" and absolute.problem.gamma0_scaling == "absolute"
    assert (scaled.max_step_cuts, absolute.max_step_cuts) == (0, 5)
    assert max(a["contact_force"]) > 0
    np.testing.assert_array_equal(a["newton_iterations"], b["newton_iterations"])
    for column in SCALES:
        scale = np.abs(a[column]).max()  # two scalings, other numbers: 1e-9 of the column
        np.testing.assert_allclose(b[column], a[column], rtol=0, atol=1e-9 * scale, err_msg=column)
