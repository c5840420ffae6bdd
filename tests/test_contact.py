"""The Nitsche contact terms as pure UFL: values, signs and the hybrid switch, no solve."""

import numpy as np
import pytest
import ufl
from dolfinx import fem, mesh
from mpi4py import MPI

from nitsche_dolfinx import HybridScheme, PlaneObstacle, SignedDistanceObstacle, Simulation
from nitsche_dolfinx.cases import bar_problem
from nitsche_dolfinx.contact import hybrid_contact_force, positive_part
from nitsche_dolfinx.output import assemble_global


@pytest.fixture(scope="module")
def square():
    return mesh.create_unit_square(MPI.COMM_WORLD, 2, 2)


# pytest.approx's default here: 1e-6 of the value; the zeros compared are exact on any
# processor (the positive part of a negative number, the zero component of a normal)
def integral(msh, expression):
    """int over the unit square = the value of a constant expression."""
    return assemble_global(fem.form(expression * ufl.dx(domain=msh)), msh.comm)


@pytest.mark.parametrize("x, expected", [(-2.0, 0.0), (0.0, 0.0), (3.0, 3.0)])
def test_positive_part(square, x, expected):
    assert integral(square, positive_part(fem.Constant(square, x))) == pytest.approx(expected)


@pytest.mark.parametrize(
    "P_old, P_new, expected",
    [
        (0.4, 0.2, 0.3),  # in contact at t^n: midpoint [(P_old + P_new)/2]_+
        (0.4, -1.0, 0.0),  # midpoint, released: [(0.4 - 1)/2]_+ = 0
        (-0.2, 0.6, 0.3),  # not in contact at t^n: CN ([P_old]_+ + [P_new]_+)/2
        (-0.2, 0.1, 0.05),  # CN although the midpoint value is negative
        (-0.2, -0.1, 0.0),
    ],
)
def test_hybrid_switch(square, P_old, P_new, expected):
    c = lambda v: fem.Constant(square, v)  # noqa: E731
    phi = hybrid_contact_force(c(P_old), c((P_old + P_new) / 2), c(P_new))
    assert integral(square, phi) == pytest.approx(expected)


def test_plane_obstacle_conventions(square):
    """Ground y = 0 under the body: d = y, n_c = (0, -1), u_n = -u_y, g = d."""
    obstacle = PlaneObstacle(point=[0.0, 0.0], normal=[0.0, 2.0])
    x = ufl.SpatialCoordinate(square)
    n_c = obstacle.normal(x)
    assert integral(square, n_c[0]) == pytest.approx(0.0)
    assert integral(square, n_c[1]) == pytest.approx(-1.0)
    assert integral(square, obstacle.gap(x)) == pytest.approx(0.5)  # mean of y


def test_signed_distance_obstacle_normal(square):
    """A general obstacle: the normal is -grad d / |grad d|, here of the plane y = -1 tilted."""
    obstacle = SignedDistanceObstacle(lambda x: 3.0 * (x[1] + 1.0) + 4.0 * x[0])
    x = ufl.SpatialCoordinate(square)
    n_c = obstacle.normal(x)
    assert integral(square, n_c[0]) == pytest.approx(-0.8)
    assert integral(square, n_c[1]) == pytest.approx(-0.6)


def test_zero_normal_is_named():
    with pytest.raises(ValueError, match=r"\[0.0, 0.0\]"):
        PlaneObstacle([0.0, 0.0], [0.0, 0.0])


def test_contact_quantities_on_the_bar():
    """In 1D at x = 0: n = -1, n_c = -1, u_n = -u, sigma_n = E u'(0), P = -u - gamma_h u'."""
    problem = bar_problem(nx=10, gamma0=0.5)
    contact = problem.contacts[0]
    u = fem.Function(problem.V)
    u.interpolate(lambda x: (-0.1 + 0.3 * x[0]).reshape(1, -1))  # u(0) = -0.1, u' = 0.3
    ds = problem.ds(1)
    comm = problem.mesh.comm
    value = lambda e: assemble_global(fem.form(e * ds), comm)  # noqa: E731
    gamma_h = 0.5 * 0.1
    assert value(contact.normal_displacement(u)) == pytest.approx(0.1)
    assert value(contact.sigma_n(u)) == pytest.approx(0.3)
    assert value(contact.projection(u)) == pytest.approx(0.1 - gamma_h * 0.3)
    assert value(contact.pressure(u)) == pytest.approx(-(0.1 - gamma_h * 0.3) / gamma_h)


def test_gamma0_and_theta_change_without_recompiling():
    """gamma0 and Theta are fem.Constants: the compiled forms see new values."""
    problem = bar_problem(nx=10, gamma0=1e-3)
    sim = Simulation(problem, HybridScheme(), dt=0.01, t_end=0.01)
    form = sim.solver.system.F_forms.form
    forms_before = id(form)
    sim.u.interpolate(lambda x: (-0.01 * (1 - x[0])).reshape(1, -1))  # penetrating
    b1 = fem.petsc.assemble_vector(form).norm()
    problem.gamma0.value = 1e-2
    problem.nitsche_theta.value = -1.0
    b2 = fem.petsc.assemble_vector(form).norm()
    assert id(sim.solver.system.F_forms.form) == forms_before
    assert not np.isclose(b1, b2)
