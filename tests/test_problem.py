"""ContactProblem and Simulation in 2D and 3D: initial acceleration, impact energy, MPI."""

import numpy as np
import pytest
from dolfinx import mesh
from mpi4py import MPI

from nitsche_dolfinx import (
    ContactProblem,
    CrankNicolson,
    HybridScheme,
    Material,
    PlaneObstacle,
    Simulation,
)
from nitsche_dolfinx.meshing import tag_facets

BOTTOM, TOP = 1, 2


def block(dim, comm, n=4):
    if dim == 2:
        msh = mesh.create_unit_square(comm, n, n)
    else:
        msh = mesh.create_unit_cube(comm, n, n, n)
    tags = tag_facets(
        msh,
        {BOTTOM: lambda x: np.isclose(x[dim - 1], 0.0), TOP: lambda x: np.isclose(x[dim - 1], 1.0)},
    )
    return msh, tags


def up(dim, value):
    vector = np.zeros(dim)
    vector[dim - 1] = value
    return vector


def dropped_block(dim, comm=MPI.COMM_WORLD, gravity=0.0, degree=1, gamma0=1e-4, **options):
    """A block 0.05 above the ground, falling at speed 1 (gamma0 E = 5e-3: well-posed);
    ``options``: further arguments of ContactProblem (method, mass)."""
    msh, tags = block(dim, comm)
    problem = ContactProblem(
        msh,
        tags,
        Material(E=50.0, nu=0.3, rho=1.0),
        degree=degree,
        gamma0=gamma0,
        nitsche_theta=1.0,
        **options,
    )
    problem.add_obstacle(PlaneObstacle(point=up(dim, -0.05), normal=up(dim, 1.0)), BOTTOM)
    if gravity:
        problem.add_body_force(up(dim, -gravity))
    problem.set_initial_conditions(velocity=up(dim, -1.0))
    return problem


@pytest.mark.parametrize("dim", [2, 3])
def test_consistent_initial_acceleration(dim):
    """A stress-free body under gravity starts with a0 = f / rho everywhere."""
    problem = dropped_block(dim, gravity=0.1)
    problem.set_initial_conditions(displacement=up(dim, 5.0))
    sim = Simulation(problem, HybridScheme(), dt=0.01, t_end=0.01)
    a = sim.a.x.array.reshape(-1, dim)
    # a solve against the exact value: 1e-9 of the acceleration's scale g = 0.1
    assert np.allclose(a[:, dim - 1], -0.1, atol=1e-9 * 0.1)
    assert np.allclose(a[:, : dim - 1], 0.0, atol=1e-9 * 0.1)


@pytest.mark.mpi
@pytest.mark.parametrize("dim", [2, 3])
def test_impact_hybrid_energy_theta_never_grows(dim):
    problem = dropped_block(dim, gravity=0.5)
    records = Simulation(problem, HybridScheme(), dt=0.01, t_end=0.3).run()
    energy_theta = np.array([r["energy_theta"] for r in records])
    force = np.array([r["contact_force"] for r in records])
    area = np.array([r["contact_area"] for r in records])
    assert force.max() > 0 and area.max() == pytest.approx(1.0)  # the whole bottom touched
    # a step's rise is <F, u^{n+1} - u^n> <= snes_rtol S |du|: at most 7.8e-10 in 2D and
    # 7.0e-10 in 3D (measured; the round-off of E_Theta is 2e-14): 1.6e-9 E_Theta(0)
    assert np.diff(energy_theta).max() <= 1.6e-9 * abs(energy_theta[0])
    penetration = np.array([r["penetration_max"] for r in records])
    assert penetration[0] == pytest.approx(-0.05)
    assert penetration.max() < 0.02


@pytest.mark.mpi
@pytest.mark.parametrize("scheme", [HybridScheme(), CrankNicolson()], ids=["hybrid", "cn"])
def test_parallel_matches_serial_2d(scheme):
    """Energies, forces and penetration on all ranks equal those of a one-rank run."""
    from nitsche_dolfinx.output import STATE_COLUMNS

    runs = []
    for comm in (MPI.COMM_WORLD, MPI.COMM_SELF):
        problem = dropped_block(2, comm=comm, gravity=0.5, degree=2)
        runs.append(Simulation(problem, scheme, dt=0.01, t_end=0.2).run())
    # two computations (another partition) that take the same Newton iterations, so that
    # they differ by round-off: about cond(J) eps = 1.6e-14 of the state a step (cond(J) =
    # 74), 3.3e-13 in 20 steps (measured: 5e-14); Newton's tolerance alone would allow
    # 2 snes_rtol S ||J^-1|| = 1.8e-7 of a step's accelerations here. Compared to 1e-9 of
    # each value, and of the scales near 0 (the energies 1 to 2, the block's size 1)
    for parallel, serial in zip(*runs):
        for column in STATE_COLUMNS:
            assert parallel[column] == pytest.approx(serial[column], rel=1e-9, abs=1e-9), column


@pytest.mark.parametrize("scheme", [HybridScheme(), CrankNicolson()], ids=["hybrid", "cn"])
def test_time_dependent_traction_gives_exact_momentum(scheme):
    """A free block pushed on its top by g_N(t) = (0, -c t): its momentum is -c t^2 / 2 exactly
    (both schemes integrate a linear-in-time force exactly)."""
    import ufl
    from dolfinx import fem

    from nitsche_dolfinx.output import assemble_global

    msh, tags = block(2, MPI.COMM_WORLD)
    problem = ContactProblem(msh, tags, Material(E=50.0, nu=0.3, rho=2.0))
    c = 0.3
    problem.add_traction(TOP, lambda t: [0.0, -c * t])
    sim = Simulation(problem, scheme, dt=0.05, t_end=0.5)
    momentum = fem.form(2.0 * sim.v[1] * ufl.dx)
    values = []
    sim.run(callback=lambda s: values.append((s.t, assemble_global(momentum, msh.comm))))
    t, p = np.array(values).T
    # the run against the exact momentum: 1e-9 of its scale, its largest value
    assert np.allclose(p, -c * t**2 / 2, rtol=1e-9, atol=1e-9 * np.abs(p).max())


def test_time_dependent_dirichlet_is_applied():
    """The bottom follows u = (0, 0.01 t^2) at every time level, whatever the scheme."""
    from dolfinx import fem

    msh, tags = block(2, MPI.COMM_WORLD)
    problem = ContactProblem(msh, tags, Material(E=50.0, nu=0.3))
    problem.add_dirichlet(BOTTOM, lambda t: [0.0, 0.01 * t**2])
    sim = Simulation(problem, HybridScheme(), dt=0.1, t_end=0.5)
    dofs = fem.locate_dofs_topological(problem.V, 1, problem.facets(BOTTOM))
    checks = []
    sim.run(callback=lambda s: checks.append(s.u.x.array.reshape(-1, 2)[dofs, 1] - 0.01 * s.t**2))
    # the run's values against the formula: 1e-9 of their scale, 0.01 t_end^2 = 2.5e-3
    assert len(checks) == 5 and all(np.abs(c).max() < 1e-9 * 2.5e-3 for c in checks if len(c))
