"""Coulomb friction between two bodies (issue 31): a block sliding on a deformable slab
against the same block on a rigid plane (docs/method.md section 11)."""

from __future__ import annotations

import numpy as np
import pytest
import ufl
from dolfinx import fem
from mpi4py import MPI

from nitsche_dolfinx import Simulation
from nitsche_dolfinx.cases import BLOCK, SLAB, block_on_slab_problem, block_problem, body_velocities
from nitsche_dolfinx.common import ParameterError
from nitsche_dolfinx.meshing import bar_mesh
from nitsche_dolfinx.model import ContactProblem
from nitsche_dolfinx.output import BoundaryAverage
from nitsche_dolfinx.physics import Material
from nitsche_dolfinx.steppers import make_scheme

DT = 0.05
MU, V0, G = 0.5, 1.0, 1.0  # a rigid block stops after v0^2 / (2 mu g) = 1, at t = 2
T_END = 2.5


def _history(simulation) -> dict:
    rows = simulation.run()
    return {name: np.array([row[name] for row in rows]) for name in rows[0]}


def run_pair(scheme="hybrid", t_end=T_END, petsc_options=None, comm=MPI.COMM_WORLD, **kwargs):
    """The block on the slab: its history with its mean displacement ``u_block`` along x."""
    kwargs = {"friction": MU, "v0": V0, **kwargs}
    problem, cells = block_on_slab_problem(comm=comm, **kwargs)
    simulation = Simulation(
        problem, make_scheme(**scheme) if isinstance(scheme, dict) else make_scheme(scheme),
        dt=DT, t_end=t_end, petsc_options=petsc_options,
    )  # fmt: skip
    dx = ufl.Measure("dx", domain=problem.mesh, subdomain_data=cells)
    simulation.add_probe("u_block", BoundaryAverage(problem.mesh, simulation.u[0], dx(BLOCK)))
    return _history(simulation), simulation


def run_plane(scheme="hybrid"):
    """The same block (P1, 8 x 4 cells) on the rigid plane y = 0."""
    problem = block_problem(friction=MU, v0=V0, degree=1)
    simulation = Simulation(
        problem, make_scheme(**scheme) if isinstance(scheme, dict) else make_scheme(scheme),
        dt=DT, t_end=T_END,
    )  # fmt: skip
    simulation.add_probe("u_block", BoundaryAverage(problem.mesh, simulation.u[0], problem.dx))
    return _history(simulation)


def test_zero_friction_is_the_frictionless_pair():
    exact = {"snes_rtol": 1e-14, "snes_atol": 1e-13}
    frictionless, sim0 = run_pair(t_end=0.5, petsc_options=exact, friction=None)
    zero, sim1 = run_pair(t_end=0.5, petsc_options=exact, friction=0.0)
    # the same equations, other forms and LU instead of LDL^T: round-off apart, which
    # varies with the processor, so 1e-9 of the scales: u of the block's size 1 (it slides
    # 0.4), v of v0 = 1, the energies (the pairings' too) of E_Theta(0) = 1
    assert np.abs(sim1.u.x.array - sim0.u.x.array).max() <= 1e-9
    assert np.abs(sim1.v.x.array - sim0.v.x.array).max() <= 1e-9
    for name in ("energy_theta", "kinetic", "u_block", "pairing_energy"):
        assert np.allclose(zero[name], frictionless[name], rtol=0, atol=1e-9), name
    assert np.all(zero["friction_dissipation"] == 0.0)  # mu = 0: exactly no work


@pytest.mark.parametrize("scheme", ["hybrid", "theta"])
def test_block_on_slab_stops_like_on_a_rigid_plane(scheme):
    """Hybrid and backward Euler: the stop, the friction's work and the energy identity
    E_Theta^{n+1} - E_Theta^n + D^n <= 0 (Theta = 1; pairings apart)."""
    pair, _ = run_pair(scheme)
    plane = run_plane(scheme)
    distance, reference = pair["u_block"][-1], plane["u_block"][-1]
    # it has stopped (the hybrid scheme's block rings on: 2e-4 in the last 0.2)
    assert abs(pair["u_block"][-1] - pair["u_block"][-5]) < 1e-3 * reference
    assert distance == pytest.approx(reference, rel=0.02)
    dissipated = pair["friction_dissipation"].sum()
    lost = pair["kinetic"][0] - pair["kinetic"][-1]
    if scheme == "hybrid":
        assert distance == pytest.approx(V0**2 / (2 * MU * G), rel=0.02)
        assert dissipated == pytest.approx(lost, rel=0.01)
    else:  # backward Euler dissipates |v^{n+1} - v^n|^2 / 2 too: as on the plane
        assert dissipated == pytest.approx(plane["friction_dissipation"].sum(), rel=0.01)
    # E_Theta less the pairings' changes plus the friction's work never rises (up to
    # round-off, processor-dependent: 1e-9 of E_Theta(0) = 1)
    controlled = (
        pair["energy_theta"] - pair["pairing_energy"] + np.cumsum(pair["friction_dissipation"])
    )
    assert np.diff(controlled).max() <= 1e-9


@pytest.mark.parametrize("degree", [1, 2])
def test_slab_nodes_beyond_the_block_have_no_partner(degree):
    """The slab's top as the slave (the unbiased pair's second half), paired where the
    block has slid by 0.1 and sunk 2e-6 into the slab: the nodes under the block see that
    penetration; those beyond its ends, whose closest point is a corner of the block's
    bottom, face no point of it and are their own partners, a facet's size (0.25) apart
    (docs/method.md section 11); for P2 so is the midpoint of an edge with such a vertex
    (x = -0.875), so that the gap interpolated on that edge is not negative. Before, their
    normal ran along the line to the corner, turned inwards by the block's plane 2e-6
    below them, and made their distance to the corner a penetration: 0.1 to 3.4."""
    problem, cells = block_on_slab_problem(friction=None, variant="unbiased", degree=degree)
    pairing = problem.pairs[1].pairing
    assert pairing.generation == 1
    u = body_velocities(problem, cells, {BLOCK: [0.1, -3e-6], SLAB: [0.0, 0.0]})
    pairing.pair(u)
    partner = fem.Function(problem.V)
    pairing.apply(u, partner)
    normal = pairing.normal.x.array.reshape(-1, 2)
    opening = pairing.gap_vector.x.array - (u.x.array - partner.x.array)
    opening = np.einsum("nd,nd->n", opening.reshape(-1, 2), normal)
    x = problem.V.tabulate_dof_coordinates()[:, 0]
    slave = np.linalg.norm(normal, axis=1) > 0
    under = slave & (np.abs(x - 0.1) < 1.0)
    if degree == 2:
        under &= ~np.isclose(x, -0.875)
    assert (under.sum(), (slave & ~under).sum()) == ((8, 17) if degree == 1 else (15, 34))
    # gaps from coordinates of size 1, against exact values: 1e-9 of that size (measured
    # 7e-13 of 0.25, the mesh from gmsh), which still tells 2e-6
    assert np.abs(opening[under] + 2e-6).max() < 1e-9
    assert np.allclose(opening[slave & ~under], 0.25, rtol=1e-9 / 0.25, atol=0)


def test_unbiased_pair_stops_the_block_like_the_biased_one():
    """The unbiased pair (both surfaces slaves, weight 1/2 each; the slab's nodes beyond
    the block have no partner): the block stops after v0^2 / (2 mu g), the friction's
    work is the kinetic energy lost, and E_Theta less the pairings' changes plus the
    friction's work never rises (hybrid, Theta = 1)."""
    pair, _ = run_pair(variant="unbiased")
    distance = pair["u_block"][-1]
    assert abs(pair["u_block"][-1] - pair["u_block"][-5]) < 1e-3 * distance
    assert distance == pytest.approx(V0**2 / (2 * MU * G), rel=0.02)
    lost = pair["kinetic"][0] - pair["kinetic"][-1]
    assert pair["friction_dissipation"].sum() == pytest.approx(lost, rel=0.01)
    controlled = (
        pair["energy_theta"] - pair["pairing_energy"] + np.cumsum(pair["friction_dissipation"])
    )
    assert np.diff(controlled).max() <= 1e-9  # E_Theta(0) = 1: as above
    # the contact force stays of the order of the weight's pressure times the stiffness
    # 1 / gamma_h at the sag (not 1e4 and more, as the wrong gaps made it)
    assert pair["contact_force"].max() < 1e3


@pytest.mark.parametrize("scheme", [{"name": "cn"}, {"name": "newmark", "beta": 0.5, "gamma": 1.0}])
def test_other_schemes_stop_the_block_where_the_plane_does(scheme):
    pair, _ = run_pair(scheme)
    assert pair["u_block"][-1] == pytest.approx(run_plane(scheme)["u_block"][-1], rel=0.01)


def test_pair_jacobian_with_friction_is_the_derivative_of_its_residual():
    """While the block slides, the Jacobian (the coupling's friction terms included) times a
    direction equals the central difference of the residual along it."""
    from petsc4py import PETSc

    from nitsche_dolfinx.common import compat

    _, simulation = run_pair("theta", t_end=0.5)
    snes = simulation.solver.snes
    A = snes.getJacobian()[0]
    w = compat.petsc_vector(simulation.solver.u)
    direction, plus, minus, product = (w.duplicate() for _ in range(4))
    rng = np.random.default_rng(MPI.COMM_WORLD.rank)
    x = w.copy()
    snes.computeJacobian(x, A)
    direction.array[:] = rng.standard_normal(direction.array.size)
    epsilon = 1e-7 * x.norm() / direction.norm()
    for sign, F in ((1.0, plus), (-1.0, minus)):
        shifted = x.copy()
        shifted.axpy(sign * epsilon, direction)
        snes.computeFunction(shifted, F)
    plus.axpy(-1.0, minus)
    plus.scale(1.0 / (2 * epsilon))
    A.mult(direction, product)
    product.axpy(-1.0, plus)
    infinity = PETSc.NormType.NORM_INFINITY
    assert product.norm(infinity) <= 1e-5 * plus.norm(infinity)


def test_pair_friction_refusals():
    """Penalty, the mixed method and the verlet scheme are refused in one line each; every
    implicit scheme steps a frictional pair."""
    mesh, tags = bar_mesh(4)
    problem = ContactProblem(mesh, tags, Material(E=1.0, nu=0.0), method="penalty", friction=0.1)
    with pytest.raises(ParameterError, match="method='penalty'.*Nitsche contact"):
        problem.add_contact_pair(1, 2)
    with pytest.raises(ParameterError, match="the mixed method is frictionless"):
        ContactProblem(mesh, tags, Material(E=1.0, nu=0.0), method="mixed", friction=0.1)
    problem, _ = block_on_slab_problem(friction=MU)
    with pytest.raises(ParameterError, match="the verlet scheme is frictionless"):
        Simulation(problem, make_scheme("verlet", mass_solver="cg"), dt=DT, t_end=T_END)


@pytest.mark.mpi
@pytest.mark.parametrize("variant", ["biased", "unbiased"])
def test_parallel_pair_friction_matches_serial(variant):
    parallel, _ = run_pair(t_end=1.0, comm=MPI.COMM_WORLD, variant=variant)
    serial, _ = run_pair(t_end=1.0, comm=MPI.COMM_SELF, variant=variant)
    for name in ("u_block", "kinetic", "energy_theta", "friction_dissipation", "contact_force"):
        scale = np.abs(serial[name]).max()
        assert np.abs(parallel[name] - serial[name]).max() <= 1e-8 * scale, name
