"""Material helpers and the exact bar solution."""

import numpy as np
import pytest
import ufl
from dolfinx import fem, mesh
from mpi4py import MPI

from nitsche_dolfinx import (
    ContactProblem,
    CrankNicolson,
    HybridScheme,
    Material,
    PlaneObstacle,
    Simulation,
)
from nitsche_dolfinx.cases import BAR_ENERGY, bar_contact_values, bar_displacement
from nitsche_dolfinx.common import compat
from nitsche_dolfinx.meshing import BLOCK_CONTACT, block_mesh
from nitsche_dolfinx.output import assemble_global
from nitsche_dolfinx.physics import sigma, von_mises


def test_lame_roundtrip():
    m = Material.from_lame(20.0, 20.0, rho=1.0)
    assert m.lmbda == pytest.approx(20.0) and m.mu == pytest.approx(20.0)
    assert m.nu == pytest.approx(0.25)


@pytest.mark.parametrize(
    "kwargs, named",
    [
        ({"E": 1, "nu": 0.5}, "nu=0.5"),
        ({"E": 1, "nu": 0.3, "rho": -1}, "rho=-1"),
        ({"E": 0, "nu": 0.3}, "E=0"),
    ],
)
def test_bad_material_is_named(kwargs, named):
    with pytest.raises(ValueError, match=named):
        Material(**kwargs)


def _value(msh, expression):
    return assemble_global(fem.form(expression * ufl.dx(domain=msh)), msh.comm)


def test_uniaxial_stress_and_von_mises():
    """u = (eps x, -nu eps y, -nu eps z) is uniaxial tension: sigma_xx = E eps, VM = E eps."""
    msh = mesh.create_unit_cube(MPI.COMM_WORLD, 1, 1, 1)
    m = Material(E=10.0, nu=0.3)
    V = compat.function_space(msh, "Lagrange", 1, (3,))
    u = fem.Function(V)
    e = 0.01
    u.interpolate(lambda x: np.vstack([e * x[0], -m.nu * e * x[1], -m.nu * e * x[2]]))
    s = sigma(u, m)
    assert _value(msh, s[0, 0]) == pytest.approx(m.E * e)
    # zero against its round-off: 1e-9 of the stress's scale E eps
    assert _value(msh, s[1, 1]) == pytest.approx(0.0, abs=1e-9 * m.E * e)
    assert _value(msh, von_mises(u, m)) == pytest.approx(m.E * e)


def test_sigma_1d_is_E_times_strain():
    msh = mesh.create_unit_interval(MPI.COMM_WORLD, 4)
    V = compat.function_space(msh, "Lagrange", 1, (1,))
    u = fem.Function(V)
    u.interpolate(lambda x: (0.2 * x[0]).reshape(1, -1))
    assert _value(msh, sigma(u, Material(E=3.0, nu=0.0))[0, 0]) == pytest.approx(0.6)


def test_exact_bar_solution():
    """Continuous in x and t, consistent with its values at x = 0, energy 1/8 at all times."""
    x = np.linspace(0, 1, 4001)
    for t in (0.3, 1.2, 1.7, 2.5, 4.4):
        u = bar_displacement(t, x)
        assert np.abs(np.diff(u)).max() < 1e-3  # continuous in x
        assert u[0] == pytest.approx(bar_contact_values(t)[0])
        assert u[-1] == pytest.approx(0.0)
        dt = 1e-6
        v = (bar_displacement(t + dt, x) - bar_displacement(t - dt, x)) / (2 * dt)
        ux = np.gradient(u, x)
        energy = compat.trapezoid(0.5 * v**2 + 0.5 * ux**2, x)
        assert energy == pytest.approx(BAR_ENERGY, rel=2e-3)
    assert bar_displacement(0.0, 0.3) == pytest.approx(0.5 - 0.15)
    assert np.all(bar_displacement(np.linspace(0, 6, 601), 0.0) >= 0)


# -- the material as runtime constants: a sweep compiles its forms once ------------------


STRETCH = 1e-3


def _run_block(material, method, mass, out):
    """A block above the ground, stretched by u0 = (eps x, 0) and falling at speed 1: two
    steps of every form of a run (fields written); returns the history."""
    msh, tags = block_mesh(1.0, 0.5, 4, 2)
    problem = ContactProblem(
        msh, tags, material, gamma0=1e-3, gamma0_scaling="E", method=method, mass=mass
    )
    problem.add_obstacle(PlaneObstacle([0.0, -0.1], [0.0, 1.0]), BLOCK_CONTACT)
    problem.add_body_force([0.0, -1.0])
    problem.set_initial_conditions(
        displacement=lambda x: np.vstack([STRETCH * x[0], 0 * x[0]]), velocity=[0.0, -1.0]
    )
    scheme = CrankNicolson() if method == "mixed" else HybridScheme()
    return Simulation(problem, scheme, dt=0.01, t_end=0.02).run(out=out, output_every=1)


@pytest.mark.parametrize(
    "method, mass", [("nitsche", "consistent"), ("nitsche", "lumped"), ("mixed", "consistent")]
)
def test_another_material_compiles_nothing(compilations, mpi_tmp_path, method, mass):
    """E, nu and rho (E also in gamma_h = gamma0 h / E, and in the mixed method's r) are
    runtime constants: a second material, never seen by FFCx's cache as a number, reuses
    every compiled form. Each run has its own material's energies at t = 0:
    elastic = (lambda + 2 mu) eps^2 |Omega| / 2, kinetic = rho |Omega| / 2."""
    seed = np.random.default_rng().uniform(1.0, 2.0)  # numbers no cache has compiled
    materials = [Material(E=10.0, nu=0.25, rho=1.0), Material(E=37.0 * seed, nu=0.3, rho=seed)]
    compiled = []
    for index, material in enumerate(materials):
        before = len(compilations)
        history = _run_block(material, method, mass, f"{mpi_tmp_path}/{index}")
        compiled.append(compilations[before:])
        area = 0.5
        elastic = 0.5 * (material.lmbda + 2 * material.mu) * STRETCH**2 * area
        # assembled energies against their formulas: 1e-9 of each
        assert history["elastic"][0] == pytest.approx(elastic, rel=1e-9)
        assert history["kinetic"][0] == pytest.approx(0.5 * material.rho * area, rel=1e-9)
    assert not compiled[1], f"the second material compiled {compiled[1]}"
