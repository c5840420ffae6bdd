"""The fields of ``solution.xdmf`` (issue 18): P2 fields written at every node of their
space, and the contact fields on Gamma_C (contact_pressure, gap, contact_status) of the
ring, the disk, the ball, the bar and a contact pair at every output time, checked against
the history, read with h5py, with meshio and as ParaView shows them."""

import json
import os
import shutil
import subprocess
import xml.etree.ElementTree as ElementTree

import numpy as np
import pytest
from dolfinx import fem
from mpi4py import MPI
from runs import MESH

from nitsche_dolfinx import (
    ContactProblem,
    CrankNicolson,
    HybridScheme,
    Material,
    PlaneObstacle,
    Simulation,
)
from nitsche_dolfinx.cases import (
    BAR_COLUMNS,
    bar_simulation,
    block_problem,
    impact_problem,
    two_bodies_problem,
)
from nitsche_dolfinx.meshing import disk_mesh, load_mesh
from nitsche_dolfinx.output import match_points, read_solution

CONTACT_FIELDS = {"contact_pressure", "gap", "contact_status"}
FIELDS = {"displacement", "velocity", "von_mises", *CONTACT_FIELDS}


def node_values(function) -> tuple[np.ndarray, np.ndarray]:
    """The coordinates and values of the owned nodes of a Lagrange Function."""
    V = function.function_space
    owned = V.dofmap.index_map.size_local
    bs = V.dofmap.index_map_bs
    points = V.tabulate_dof_coordinates()[:owned, : V.mesh.geometry.dim]
    return points, function.x.array.reshape(-1, bs)[:owned]


# -- P2 fields, node by node ----------------------------------------------------------------


@pytest.mark.mpi
def test_p2_fields_are_written_at_every_node_of_their_space(mpi_tmp_path):
    """The P2 block on an affine mesh (8 x 4 cells: 45 vertices, 153 P2 nodes): every level
    of the file has the 153 nodes in quadratic triangles, and at each node the values of
    the solution's dofs, the mid-edge nodes included (serially and on 2 ranks)."""
    simulation = Simulation(block_problem(), HybridScheme(), dt=0.01, t_end=0.02)
    simulation.run(out=mpi_tmp_path, output_every=1)
    path = os.path.join(mpi_tmp_path, "solution.xdmf")
    topology = ElementTree.parse(path).getroot().find("Domain/Grid/Topology")
    assert topology.get("TopologyType") == "Triangle_6"
    levels = read_solution(path)
    # time levels: scalar IEEE arithmetic and its text, the same on any processor
    assert [level.t for level in levels] == pytest.approx([0.0, 0.01, 0.02], abs=1e-12)
    V = simulation.problem.V
    assert simulation.problem.mesh.topology.index_map(0).size_global == 45
    for level in levels:
        assert len(level.points) == V.dofmap.index_map.size_global == 153
        assert level.cells.shape == (64, 6)
        assert len(np.unique(level.cells[:, :3])) == 45  # vertices, then mid-edge nodes
        assert len(np.unique(level.cells[:, 3:])) == 153 - 45
        assert set(level.fields) == FIELDS | {"slip_velocity", "friction_traction"}
    last, compared = levels[-1], 0
    for name, function in (("displacement", simulation.u), ("velocity", simulation.v)):
        points, values = node_values(function)
        # the nodes computed twice (block 2 x 1): 1e-9, far below their spacing 0.125
        index = match_points(last.points[:, :2], points, 1e-9)
        assert np.all(index >= 0)
        # equal to round-off: dolfinx's writer evaluates the Function at the nodes, cell by
        # cell, another computation than the dofs': 1e-9 of the field's scale
        difference = np.abs(last.fields[name][index, :2] - values).max()
        assert difference <= 1e-9 * np.abs(values).max(), name
        compared += len(points)
    # every node of the file, the mid-edge ones included, is the owned dof of one rank
    assert MPI.COMM_WORLD.allreduce(compared, op=MPI.SUM) == 2 * 153


# -- the contact fields of the ring, the disk and the ball ---------------------------------


def ring_simulation() -> tuple[Simulation, float, tuple]:
    """The ring of the demo (P1), from 0.1 above the ground at speed 1: in contact from
    t = 0.1; with the centre and radius of Gamma_C."""
    mesh, tags = load_mesh(MESH)
    problem = ContactProblem(mesh, tags, Material(E=1000.0, nu=0.3, rho=1.0), 1, 1e-6)
    problem.add_body_force((0.0, -1.0))
    problem.add_obstacle(PlaneObstacle((0.0, 0.0), (0.0, 1.0)), 1)
    problem.set_initial_conditions(velocity=(0.0, -1.0))
    return Simulation(problem, HybridScheme(), dt=0.005, t_end=0.15), 5, ((0.0, 1.1), 1.0)


def impact_simulation(dim: int) -> tuple[Simulation, float, tuple]:
    """The disk or the ball of the impact test (h = 8, P2), from 0.05 above the plane at
    speed 1: in contact from t = 0.05."""
    problem = impact_problem(dim=dim, mesh_size=8.0)
    down = np.zeros(dim)
    down[-1] = -1.0
    problem.set_initial_conditions(displacement=-0.05 * down, velocity=down)
    centre = np.zeros(dim)
    centre[-1] = 20.0
    return Simulation(problem, HybridScheme(), dt=0.1, t_end=0.6), 2, (centre, 20.0)


CASES = {
    "ring": ring_simulation,
    "disk": lambda: impact_simulation(2),
    "ball": lambda: impact_simulation(3),
}


def on_contact_boundary(points: np.ndarray, centre, radius: float) -> np.ndarray:
    """The nodes of Gamma_C, the lower half of the circle or sphere (centre, radius)."""
    offset = points[:, : len(centre)] - np.asarray(centre)
    on_circle = np.abs(np.linalg.norm(offset, axis=1) - radius) < 1e-6 * radius
    return on_circle & (offset[:, -1] <= 1e-9 * radius)


@pytest.mark.mpi
@pytest.mark.parametrize("case", sorted(CASES))
def test_contact_fields_at_every_output_time(mpi_tmp_path, case):
    """Short runs through the first contact: at every output time the file holds the contact
    fields, zero off Gamma_C; the least gap over the nodes of Gamma_C is -penetration_max
    of the history; at the last level the integrals of the pressure and of the status over
    Gamma_C are -contact_force and contact_area (the lumped projections keep integrals)."""
    simulation, every, (centre, radius) = CASES[case]()
    history = simulation.run(out=mpi_tmp_path, output_every=every)
    levels = read_solution(os.path.join(mpi_tmp_path, "solution.xdmf"))
    check_fields(simulation, history, levels, every, centre, radius)


def check_fields(simulation, history, levels, every, centre, radius) -> None:
    """The contact fields of a run against its history (see the test above)."""
    assert [level.t for level in levels] == pytest.approx(history["t"][::every], abs=1e-9)
    assert history["contact_force"][-1] > 0
    for level, penetration in zip(levels, history["penetration_max"][::every]):
        assert FIELDS <= set(level.fields)
        pressure, gap, status = (
            level.fields[name][:, 0] for name in ("contact_pressure", "gap", "contact_status")
        )
        boundary = on_contact_boundary(level.points, centre, radius)
        # signs, bounds and zeros up to the writer's round-off: 1e-9 of each field's scale
        scale = np.abs(pressure).max()
        assert np.all(pressure <= 1e-9 * scale) and np.all(np.abs(status - 0.5) <= 0.5 + 1e-9)
        for values in (pressure, gap, status):  # zero, up to the round-off of the writer
            assert np.abs(values[~boundary]).max() <= 1e-9 * max(np.abs(values).max(), 1.0)
        # the field's least gap against the history's, computed otherwise: 1e-9 of the
        # value, and of the body's size (its radius) near 0
        assert gap[boundary].min() == pytest.approx(-penetration, rel=1e-9, abs=1e-9 * radius)
    assert levels[0].fields["contact_status"].max() == 0.0  # apart at t = 0
    assert levels[-1].fields["contact_status"].max() > 0
    # the integrals over Gamma_C of the written P1 projections, at the last level
    fields = simulation.output_fields()
    problem = simulation.problem
    ds = problem.ds(problem.contact_tags[0])
    integrals = (("contact_pressure", "contact_force", -1), ("contact_status", "contact_area", 1))
    for name, column, sign in integrals:
        local = fem.assemble_scalar(fem.form(fields[name][0].source.function * ds))
        value = problem.mesh.comm.allreduce(local, op=MPI.SUM)
        # the projection's integral against the history's sum: 1e-9 of the value
        assert value == pytest.approx(sign * history[column][-1], rel=1e-9), name


@pytest.mark.skipif(MPI.COMM_WORLD.size > 1, reason="meshio reads the file serially")
def test_meshio_reads_every_field_at_every_time(tmp_path):
    """meshio's TimeSeriesReader (one collection of levels, one mesh) gives the fields that
    h5py reads, at every output time."""
    meshio = pytest.importorskip("meshio")
    simulation, every, _ = impact_simulation(2)
    simulation.run(out=str(tmp_path), output_every=every)
    path = str(tmp_path / "solution.xdmf")
    levels = read_solution(path)
    with meshio.xdmf.TimeSeriesReader(path) as reader:
        points, cells = reader.read_points_cells()
        assert reader.num_steps == len(levels) == 4
        assert cells[0].type == "triangle6"
        for k, level in enumerate(levels):
            t, point_data, _ = reader.read_data(k)
            assert t == level.t and set(point_data) == set(level.fields) == FIELDS
            for name, values in level.fields.items():  # the same file read twice: bitwise
                assert np.array_equal(point_data[name], values)
        assert np.array_equal(points, levels[0].points)


def test_two_obstacles_on_one_part_of_gamma_c(tmp_path):
    """The disk with a second plane obstacle on the same Gamma_C, 5 below the ground: the
    fields of the two contacts together (pressures summed, the least gap, in contact with
    either) keep the identities of one obstacle: the integrals of the pressure and of the
    status are -contact_force and contact_area (each facet counted once in the lumped
    mass), and the least gap is -penetration_max."""
    simulation, every, (centre, radius) = impact_simulation(2)
    simulation.problem.add_obstacle(PlaneObstacle([0.0, -5.0], [0.0, 1.0]), 1)
    simulation = Simulation(simulation.problem, HybridScheme(), dt=0.1, t_end=0.6)
    history = simulation.run(out=str(tmp_path), output_every=every)
    levels = read_solution(str(tmp_path / "solution.xdmf"))
    check_fields(simulation, history, levels, every, centre, radius)


# -- the bar: the contact pressure at x = 0, Nitsche and mixed ------------------------------


@pytest.mark.parametrize("method", ["nitsche", "mixed"])
def test_bar_contact_pressure_is_sigma_contact(tmp_path, method):
    """On the bar, Gamma_C is the point x = 0: the written contact_pressure there is the
    history's sigma_contact (lambda_h, or the mixed method's multiplier) at every output
    time through the contact (1 <= t <= 2), and the status is 1 exactly when it is < 0."""
    scheme = CrankNicolson() if method == "mixed" else HybridScheme()
    simulation = bar_simulation(scheme, method=method, t_end=1.5)
    history = simulation.run(out=str(tmp_path), columns=BAR_COLUMNS, output_every=10)
    levels = read_solution(str(tmp_path / "solution.xdmf"))
    sigma = history["sigma_contact"][::10]
    assert len(levels) == len(sigma) == 11 and sigma.min() < -0.4
    for level, expected in zip(levels, sigma):
        (node,) = np.flatnonzero(level.points[:, 0] == 0.0)
        written = level.fields["contact_pressure"][node, 0]
        # the written projection against the history's value: 1e-9 of sigma's scale, 1
        assert written == pytest.approx(expected, rel=1e-9, abs=1e-9)
        assert level.fields["contact_status"][node, 0] == (1.0 if expected < 0 else 0.0)
        assert level.fields["gap"][node, 0] == pytest.approx(level.fields["displacement"][node, 0])


# -- a contact pair: each surface has its own fields ----------------------------------------


def test_pair_fields_are_those_of_one_disk_on_the_plane_of_symmetry(tmp_path):
    """Two mirror-image disks paired along the axis are one disk on the plane of symmetry
    with gamma0 / 2 (docs/method.md section 11): on the upper disk's Gamma_C the pair's
    contact pressure and status are the single disk's, and its gap, to the other disk, is
    twice the single disk's gap to the plane (in the lower part of the disk)."""
    pair, _ = two_bodies_problem(dim=2, mesh_size=8.0, v0=1.0)
    mesh, tags = disk_mesh(8.0, 2, 20.0, [0.0, 20.0])
    single = ContactProblem(mesh, tags, Material.from_lame(20.0, 20.0, rho=1.0), 2, 0.5e-3)
    single.add_obstacle(PlaneObstacle([0.0, 0.0], [0.0, 1.0]), 1)
    single.set_initial_conditions(velocity=[0.0, -1.0])
    levels = {}
    for name, problem in (("pair", pair), ("single", single)):
        Simulation(problem, HybridScheme(), dt=0.1, t_end=0.4).run(
            out=str(tmp_path / name), output_every=2
        )
        levels[name] = read_solution(str(tmp_path / name / "solution.xdmf"))
    for pair_level, single_level in zip(levels["pair"], levels["single"]):
        index = match_points(pair_level.points, single_level.points, 1e-9)
        assert np.all(index >= 0)  # the upper disk's nodes in the pair's file
        upper = {name: values[index, 0] for name, values in pair_level.fields.items()}
        alone = {name: values[:, 0] for name, values in single_level.fields.items()}
        scale = np.abs(alone["contact_pressure"]).max() + 1e-300
        assert np.abs(upper["contact_pressure"] - alone["contact_pressure"]).max() < 1e-9 * scale
        assert np.array_equal(upper["contact_status"] > 0.5, alone["contact_status"] > 0.5)
        # (away from the equator, where the axis meets the other disk at a grazing angle)
        lower = alone["gap"] < 10.0
        # gaps to a surface and to a plane: 1e-9 of their scale, the radius 20
        assert upper["gap"][lower] == pytest.approx(2 * alone["gap"][lower], abs=1e-9 * 20.0)
    assert levels["single"][-1].fields["contact_pressure"].min() < 0


# -- what ParaView shows ---------------------------------------------------------------------

PARAVIEW_SCRIPT = """
import json, sys
from paraview.simple import OpenDataFile, servermanager
from vtkmodules.numpy_interface import dataset_adapter

reader = OpenDataFile(sys.argv[1])
shown = []
for t in reader.TimestepValues:
    reader.UpdatePipeline(t)
    data = servermanager.Fetch(reader)
    grid = dataset_adapter.WrapDataObject(data)
    shown.append({
        "t": t,
        "class": data.GetClassName(),
        "cell_types": sorted({data.GetCellType(i) for i in range(data.GetNumberOfCells())}),
        "points": grid.Points.tolist(),
        "fields": {name: grid.PointData[name].tolist() for name in grid.PointData.keys()},
    })
print(json.dumps(shown))
"""


@pytest.mark.skipif(shutil.which("pvpython") is None, reason="needs ParaView's pvpython")
@pytest.mark.skipif(MPI.COMM_WORLD.size > 1, reason="runs pvpython itself: run it serially")
def test_paraview_shows_every_field_time_and_p2_node(tmp_path):
    """ParaView (pvpython, the Xdmf3 reader) shows the P2 block as one unstructured grid of
    quadratic triangles (VTK type 22) per time level, with the 153 nodes and every field
    of the file at each, equal to what h5py reads."""
    Simulation(block_problem(), HybridScheme(), dt=0.01, t_end=0.02).run(
        out=str(tmp_path), output_every=1
    )
    path = str(tmp_path / "solution.xdmf")
    script = tmp_path / "show.py"
    script.write_text(PARAVIEW_SCRIPT)
    result = subprocess.run(
        ["pvpython", "--force-offscreen-rendering", str(script), path],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    shown = json.loads(result.stdout.strip().splitlines()[-1])
    levels = read_solution(path)
    assert [level["t"] for level in shown] == pytest.approx([level.t for level in levels])
    for seen, level in zip(shown, levels):
        assert seen["class"] == "vtkUnstructuredGrid" and seen["cell_types"] == [22]
        points = np.array(seen["points"])[:, :2]
        assert np.array_equal(points, level.points[:, :2]) and len(points) == 153
        assert set(seen["fields"]) == set(level.fields)
        for name, values in level.fields.items():
            shown_values = np.array(seen["fields"][name]).reshape(len(points), -1)
            assert np.allclose(shown_values, values, rtol=1e-7, atol=1e-30), name
