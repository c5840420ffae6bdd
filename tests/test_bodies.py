"""Bodies by cell tag (issue 31): a mesh file's physical groups of cells as [[body]] tables,
and the history columns of each body, their momentum, centre of mass and angular momentum
(docs/method.md sections 4 and 6)."""

import os

import numpy as np
import pytest
from mpi4py import MPI
from runs import assert_one_line_error, run

from nitsche_dolfinx import ContactProblem, Material, Simulation, read_history
from nitsche_dolfinx.cases import LOWER_BODY, UPPER_BODY, two_bodies_problem
from nitsche_dolfinx.common import ParameterError
from nitsche_dolfinx.config import build_simulation, load_config
from nitsche_dolfinx.meshing import InBox, block_mesh, tag_cells
from nitsche_dolfinx.output import angular_momentum_columns, body_columns
from nitsche_dolfinx.steppers import make_scheme

#: Two disks of radius 1 (cells 1 and 2, boundaries 11 and 12), the upper one 0.4 to the
#: right: an off-centre hit at t = 0.14, when they move towards each other at 0.5.
CENTRES = {1: (0.0, -1.05), 2: (0.4, 1.05)}
CONFIG = """\
[mesh]
file = "disks.msh"
degree = 1
mass = "{mass}"

[material]
E = 10.0
nu = 0.3
rho = 1.0

[nitsche]
gamma0 = 1e-4

[scheme]
name = "hybrid"
dt = 0.02
t_end = 0.3

[[contact_pair]]
tags = [12, 11]
follow = false  # paired once: round-off growth through sliding is test_sliding.py's

[[body]]
tag = 1
velocity = [0.0, 0.5]

[[body]]
tag = {upper}
velocity = [0.0, -0.5]

[output]
dir = "out"
every = 0
"""


def _write_disks(path: str) -> None:
    """The two disks as a gmsh .msh file with physical groups of cells and facets."""
    import gmsh

    gmsh.initialize(readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("two disks")
    for tag, (x, y) in CENTRES.items():
        disk = gmsh.model.occ.addDisk(x, y, 0, 1, 1)
        gmsh.model.occ.synchronize()
        gmsh.model.addPhysicalGroup(2, [disk], tag)
        curves = [c[1] for c in gmsh.model.getBoundary([(2, disk)], oriented=False)]
        gmsh.model.addPhysicalGroup(1, curves, 10 + tag)
    gmsh.option.setNumber("Mesh.CharacteristicLengthMax", 0.25)
    gmsh.model.mesh.generate(2)
    gmsh.write(path)
    gmsh.finalize()


def _config(folder: str, mass: str = "consistent", upper: int = 2) -> str:
    """The configuration of the two disks and its mesh in ``folder`` (rank 0 writes them)."""
    path = os.path.join(folder, f"disks_{mass}_{upper}.toml")
    if MPI.COMM_WORLD.rank == 0:
        if not os.path.exists(os.path.join(folder, "disks.msh")):
            _write_disks(os.path.join(folder, "disks.msh"))
        with open(path, "w") as f:
            f.write(CONFIG.format(mass=mass, upper=upper))
    MPI.COMM_WORLD.barrier()
    return path


def _run(path: str, comm=MPI.COMM_WORLD):
    simulation = build_simulation(load_config(path), comm, progress=False, source=path)
    return simulation.run(columns=list(simulation.state()))


@pytest.mark.parametrize("mass", ["consistent", "lumped"])
def test_mesh_file_bodies_add_up_to_the_whole(mpi_tmp_path, mass):
    """Two [[body]] tables on a .msh file's cell groups: each body starts with its own
    momentum m_b v_b and centre; the bodies' momenta, first moments and angular momenta
    add up to the totals at every level, through the contact (their nodes part the mesh's:
    round-off)."""
    history = _run(_config(mpi_tmp_path, mass))
    assert history["contact_force"].max() > 0
    mass_of_disk = np.pi  # rho = 1, radius 1 (the polygon's area, to its chords)
    for tag, speed in ((1, 0.5), (2, -0.5)):
        assert history[f"momentum_{tag}_y"][0] == pytest.approx(mass_of_disk * speed, rel=2e-2)
        # assembled against exact values, processor-dependent round-off: 1e-9 of the
        # momentum's scale m v = 1.6 and of the radius 1
        assert history[f"momentum_{tag}_x"][0] == pytest.approx(0.0, abs=1e-9)
        for k, c in enumerate("xy"):
            assert history[f"centre_of_mass_{tag}_{c}"][0] == pytest.approx(
                CENTRES[tag][k], abs=1e-9
            )
    scale = mass_of_disk * 0.5  # one disk's momentum
    # the bodies' sums against the whole's: other sums, 1e-9 of their scale (m v, radius 1)
    for c in "xy":
        total = history[f"momentum_1_{c}"] + history[f"momentum_2_{c}"]
        assert np.abs(total - history[f"momentum_{c}"]).max() <= 1e-9 * scale
    # the masses: the momenta of the uniform initial velocities over the speeds
    masses = {1: history["momentum_1_y"][0] / 0.5, 2: history["momentum_2_y"][0] / -0.5}
    for c in "xy":
        moment = sum(masses[tag] * history[f"centre_of_mass_{tag}_{c}"] for tag in (1, 2))
        centre = moment / sum(masses.values())
        assert np.abs(centre - history[f"centre_of_mass_{c}"]).max() <= 1e-9
    angular = history["angular_momentum_1_z"] + history["angular_momentum_2_z"]
    assert np.abs(angular - history["angular_momentum_z"]).max() <= 1e-9 * scale


def test_default_columns_of_a_toml_run_end_with_the_bodies(tmp_path):
    """The command writes the listed columns first, then each body's (docs/method.md
    section 6)."""
    path = _config(str(tmp_path))
    result = run("-m", "nitsche_dolfinx", "run", path, "--quiet")
    assert result.returncode == 0, result.stderr
    history = read_history(str(tmp_path / "out" / "history.csv"))
    bodies = [*body_columns(1, 2), *body_columns(2, 2)]
    assert history.columns[-len(bodies) :] == bodies
    assert history.columns[:3] == ["t", "energy", "energy_theta"]


def test_a_body_tag_the_mesh_lacks_is_refused_in_one_line(tmp_path):
    path = _config(str(tmp_path), upper=7)
    result = run("-m", "nitsche_dolfinx", "run", path, "--quiet")
    assert_one_line_error(result, "disks_consistent_7.toml: [[body]] #2 tag = 7: not a cell tag")
    assert "(it has [1, 2])" in result.stderr


def test_bodies_that_share_nodes_are_refused():
    """Two boxes of one block share the nodes of their interface: their columns would count
    those rows twice."""
    mesh, facets = block_mesh(2.0, 1.0, 4, 2)
    cells = tag_cells(mesh, {1: InBox([-1.0, 0.0], [0.0, 1.0]), 2: InBox([0.0, 0.0], [1.0, 1.0])})
    problem = ContactProblem(mesh, facets, Material(E=1.0, nu=0.3))
    problem.add_body(1, cells)
    with pytest.raises(ParameterError, match="shares nodes with the body of tag 1"):
        problem.add_body(2, cells)
    with pytest.raises(ParameterError, match="is a body already"):
        problem.add_body(1, cells)
    with pytest.raises(ParameterError, match=r"not a cell tag of the mesh \(it has \[1, 2\]\)"):
        problem.add_body(3, cells)
    with pytest.raises(ParameterError, match="the mesh has no cell tags"):
        problem.add_body(1)


def test_angular_momentum_kept_through_an_off_centre_hit():
    """Two disks 10 apart across their axis (radius 20), paired along it, through the
    contact (t = 1.2 to 3): the moment of the masses' momenta about the reference positions
    is kept, as the equations of linear elasticity keep it (docs/method.md section 4), and
    before the contact, the bodies translating, it is the angular momentum itself."""
    problem, cells = two_bodies_problem(dim=2, mesh_size=8.0, v0=1.0, gap=1.0, offset=10.0)
    for tag in (UPPER_BODY, LOWER_BODY):
        problem.add_body(tag, cells)
    simulation = Simulation(problem, make_scheme("hybrid"), dt=0.1, t_end=3.0)
    (current,) = angular_momentum_columns(2)
    (reference,) = angular_momentum_columns(2, reference=True)
    history = simulation.run(columns=["t", "contact_force", current, reference])
    touching = history["contact_force"] > 0
    assert touching[-1] and not touching[0]
    scale = np.pi * 20.0**2 * 1.0 * 20.0  # m v0 R of one disk
    assert history[reference][0] == pytest.approx(-0.5 * scale, rel=1e-3)  # -m v0 (5 + 5)
    # each step's Newton residual F, at most snes_rtol = 1e-10 of its equation's scale (the
    # momentum's change), moves L by its moment tau sum x_i x F_i, the arms at most the
    # pair's extent (2 R); over 30 steps, 1e-8 m v0 R (measured: 1e-13)
    assert np.abs(history[reference] - history[reference][0]).max() <= 1e-8 * scale
    before = ~np.cumsum(touching).astype(bool)
    drift = history[current][before] - history[reference][before]
    # two different sums of the same value: 1e-9 of m v0 R, on any processor
    assert np.abs(drift).max() <= 1e-9 * scale


@pytest.mark.mpi
def test_bodies_on_two_ranks_equal_serial(mpi_tmp_path):
    """The mesh file's two disks on every rank and on each rank alone: the bodies' columns
    agree to round-off (1e-9 of their scale: serial against 2 ranks)."""
    path = _config(mpi_tmp_path)
    parallel = _run(path)
    serial = _run(path, MPI.COMM_SELF)
    names = [*body_columns(1, 2), *body_columns(2, 2), *angular_momentum_columns(2)]
    for name in ["energy", "contact_force", *names]:
        scale = max(np.abs(serial[name]).max(), 1.0)
        assert np.abs(parallel[name] - serial[name]).max() <= 1e-9 * scale, name
