"""The optional history columns: point values (probes), and the contact totals of each
obstacle next to their sums; serially and under mpirun."""

import numpy as np
import pytest
from disks import symmetric_disks
from dolfinx import mesh as dmesh
from mpi4py import MPI

from nitsche_dolfinx import HybridScheme, PlaneObstacle, Simulation
from nitsche_dolfinx.cases import impact_problem
from nitsche_dolfinx.common import compat
from nitsche_dolfinx.meshing import DISK_CONTACT
from nitsche_dolfinx.output import HISTORY_COLUMNS, PointValue, contact_columns


def linear_field(x):
    return np.vstack([x[0] + 2 * x[1], 3 * x[0] - x[1]])


@pytest.mark.mpi
def test_point_value_of_a_linear_field():
    """A linear field is exact in P2: its value at any point, a vertex between cells and
    ranks included, on every rank alike."""
    from dolfinx import fem

    mesh = dmesh.create_unit_square(MPI.COMM_WORLD, 5, 4)
    V = compat.function_space(mesh, "Lagrange", 2, (2,))
    u = fem.Function(V, name="displacement")
    u.interpolate(linear_field)
    scalar = fem.Function(compat.function_space(mesh, "Lagrange", 1), name="scalar")
    scalar.interpolate(lambda x: 1 + x[0] * 0 + 2 * x[1])
    for point in ([0.3, 0.7], [0.6, 0.5], [1.0, 0.0], [0.2, 0.25]):
        exact = linear_field(np.array([[point[0]], [point[1]]]))[:, 0]
        for component in (0, 1):
            value = PointValue(u, point, component)()
            # evaluated against the formula: 1e-9 of the fields' scale, their largest value 3
            assert value == pytest.approx(exact[component], abs=3e-9)
            assert MPI.COMM_WORLD.allgather(value) == [value] * MPI.COMM_WORLD.size
        assert PointValue(scalar, point)() == pytest.approx(1 + 2 * point[1], abs=3e-9)
    with pytest.raises(ValueError, match="give the component"):
        PointValue(u, [0.5, 0.5])


@pytest.mark.mpi
def test_contact_totals_of_each_obstacle():
    """The symmetric disk of the impact test dropped into a valley of two walls at 30
    degrees, mirror images in x = 0: each wall takes half the contact force and area, and
    the sums keep their columns. A probe of the velocity at the disk's top is in the
    history too."""
    mesh, _, tags = symmetric_disks(half=False)
    problem = impact_problem(dim=2, mesh=(mesh, tags), contact=False)
    angle = np.radians(30.0)
    for side in (1.0, -1.0):  # the left wall's normal points up to the right
        wall = PlaneObstacle([0.0, -2.0], [side * np.sin(angle), np.cos(angle)])
        problem.add_obstacle(wall, DISK_CONTACT)
    simulation = Simulation(problem, HybridScheme(), dt=0.25, t_end=10.0)
    simulation.add_probe("top_velocity_y", PointValue(simulation.v, [0.0, 40.0], 1))
    columns = [*HISTORY_COLUMNS, *contact_columns(2), "top_velocity_y"]
    history = simulation.run(columns=columns)
    force = history["contact_force"]
    assert force.max() > 1.0  # in contact since t = 8.8
    for name in ("contact_force", "contact_area"):
        first, second = history[f"{name}_1"], history[f"{name}_2"]
        scale = history[name].max()  # mirror images, and sums: 1e-9 of the total
        assert np.abs(first - second).max() <= 1e-9 * scale
        assert np.abs(first + second - history[name]).max() <= 1e-9 * scale
    before = history["t"] <= 8.5  # free fall: v = -0.1 t everywhere
    assert history["top_velocity_y"][before] == pytest.approx(-0.1 * history["t"][before])
