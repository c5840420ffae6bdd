"""Symmetry planes, facets tagged by selectors, point probes and the momentum, centre-of-mass
and per-contact columns in a TOML configuration, against the API's run and known truths;
and a sweep over E in TOML files that compiles its forms once."""

import os
import textwrap

import numpy as np
import pytest
from disks import RADIUS, SYMMETRY, symmetric_disks
from dolfinx import fem
from mpi4py import MPI

from nitsche_dolfinx import HybridScheme, Simulation, read_history
from nitsche_dolfinx.cases import impact_problem
from nitsche_dolfinx.cli import main as cli
from nitsche_dolfinx.config import ConfigError, build_simulation, history_columns, load_config
from nitsche_dolfinx.meshing import DISK_CONTACT, DISK_FREE
from nitsche_dolfinx.output import HISTORY_COLUMNS, PointValue


def write(folder, text: str, name: str = "case.toml") -> str:
    path = os.path.join(str(folder), name)
    if MPI.COMM_WORLD.rank == 0:
        with open(path, "w") as f:
            f.write(textwrap.dedent(text))
    MPI.COMM_WORLD.barrier()
    return path


def configured(folder, text: str):
    """The configuration in ``text`` and its simulation."""
    path = write(folder, text)
    config = load_config(path)
    return config, build_simulation(config, progress=False, source=path)


def measure(problem, tag: int) -> float:
    """The length (area) of the facets ``tag``."""
    form = fem.form(fem.Constant(problem.mesh, 1.0) * problem.ds(tag))
    return problem.mesh.comm.allreduce(fem.assemble_scalar(form), op=MPI.SUM)


# -- the half disk: a mesh without physical groups on its boundary ------------------------

#: The half disk of tests/test_symmetry.py, its facets tagged by selectors: the lower and
#: the upper half of the boundary (tags 1 and 2, as disks.py's circle predicates), then the
#: cut x = 0 (tag 3; the last tag that chooses a facet is its tag).
HALF_DISK = """
    [mesh]
    file = "half_disk.msh"
    degree = 2

    [[facet_tag]]
    tag = 1
    in_box = { lower = [-20.0, 0.0], upper = [20.0, 20.0] }

    [[facet_tag]]
    tag = 2
    in_box = { lower = [-20.0, 20.0], upper = [20.0, 40.0] }

    [[facet_tag]]
    tag = 3
    on_plane = { point = [0.0, 0.0], normal = [1.0, 0.0] }

    [material]
    lmbda = 20.0
    mu = 20.0

    [nitsche]
    gamma0 = 1e-3                     # the API run's (impact_problem), not the default

    [scheme]
    dt = 0.25
    t_end = 12.0

    [[obstacle]]
    point = [0.0, 0.0]
    normal = [0.0, 1.0]
    tag = 1

    [[dirichlet]]
    tag = 3
    component = 0
    value = 0.0

    [body_force]
    value = [0.0, -0.1]

    [initial]
    displacement = [0.0, 5.0]

    [[probe]]
    name = "u_y_low"
    quantity = "displacement"
    component = 1
    point = [-10.0, 3.0]

    [[probe]]
    name = "v_x_side"
    quantity = "velocity"
    point = [-19.0, 20.0]

    [output]
    every = 0
    columns = [COLUMNS, "momentum_x", "momentum_y", "centre_of_mass_y", "contact_force_1",
               "u_y_low", "v_x_side"]
"""


def half_disk() -> str:
    """:data:`HALF_DISK` with the demos' columns."""
    return HALF_DISK.replace("COLUMNS", ", ".join(f'"{name}"' for name in HISTORY_COLUMNS))


POINTS = {"u_y_low": ([-10.0, 3.0], 1), "v_x_side": ([-19.0, 20.0], 0)}


def api_half_disk(comm):
    """The half disk of tests/test_symmetry.py through the API, with the probes of
    :data:`HALF_DISK`."""
    mesh, _, tags = symmetric_disks(True, comm=comm)
    problem = impact_problem(dim=2, mesh=(mesh, tags), comm=comm)
    problem.add_dirichlet(SYMMETRY, 0.0, component=0)
    simulation = Simulation(problem, HybridScheme(), dt=0.25, t_end=12.0, progress=False)
    for name, (point, component) in POINTS.items():
        function = simulation.u if name.startswith("u") else simulation.v
        simulation.add_probe(name, PointValue(function, point, component))
    return simulation


@pytest.mark.mpi
def test_half_disk_configured_is_the_api_run(mpi_tmp_path):
    """The half disk read from a .msh file without boundary groups, its facets tagged by
    [[facet_tag]] selectors and held by a [[dirichlet]] component: its tags measure as
    disks.py's and its history, point probes and new columns included, is the API run's
    to Newton's tolerance."""
    comm = MPI.COMM_WORLD
    symmetric_disks(True, comm=comm, msh=os.path.join(mpi_tmp_path, "half_disk.msh"))
    config, configured_run = configured(mpi_tmp_path, half_disk())
    api = api_half_disk(comm)
    # lengths of meshes 1 ulp apart, and against the exact one: 1e-9 of the length
    for tag in (DISK_CONTACT, DISK_FREE, SYMMETRY):
        expected = measure(api.problem, tag)
        assert measure(configured_run.problem, tag) == pytest.approx(expected, rel=1e-9), tag
    assert measure(api.problem, SYMMETRY) == pytest.approx(2 * RADIUS, rel=1e-9)
    columns = history_columns(config, configured_run)
    history, expected = configured_run.run(columns=columns), api.run(columns=columns)
    assert history["contact_force"].max() > 1.0  # in contact
    assert abs(history["v_x_side"][-1]) > 1e-5  # the side moves out once in contact
    # Two computations: the mesh read back from the .msh file (16 digits) has its nodes up to
    # 1 ulp off the API's. Newton solves each step to snes_rtol = 1e-10 of its equation's
    # scale S, which fixes the step's accelerations to 2 snes_rtol S ||J^-1|| <= 2.0e-9 of
    # their size (measured on this half disk); the velocities sum them (sum tau |a| is about
    # 2 |v|: the fall, then the bounce) and the energies double that: 8e-9, so 1e-8
    # (measured on three BLAS kernels: 9.1e-13).
    for name in columns:
        if name == "step_seconds":
            continue
        # the x velocity at the side: on the scale of the falling speed, 1
        scale = 1.0 if name == "v_x_side" else max(np.abs(expected[name]).max(), 1e-300)
        assert np.abs(history[name] - expected[name]).max() <= 1e-8 * scale, name
    assert np.abs(history["momentum_x"]).max() > 1e-3  # the half is held along x only
    # one pair: its column is a copy of the total, the same number
    assert np.array_equal(history["contact_force_1"], history["contact_force"])


def test_mesh_file_without_boundary_groups_needs_facet_tags(tmp_path):
    symmetric_disks(True, msh=tmp_path / "half_disk.msh")
    text = half_disk()
    text = text[: text.index("[[facet_tag]]")] + text[text.index("[material]") :]
    with pytest.raises(ConfigError, match=r"\[mesh\] mesh file .* has no physical groups on"):
        configured(tmp_path, text)


# -- a block on a roller: rigid motion, known exactly -------------------------------------

#: A block (-1, 1) x (0, 1) of rho = 2 on a roller y = 0 rising as 0.1 t (u_y prescribed,
#: u_x free), pushed along x by f = (2, 0), starting at v = (0, 0.1): it moves rigidly,
#: u = (t^2 / 2, 0.1 t), exact for every scheme (tests/test_symmetry.py). Its sides and top
#: are tagged by selectors; the roller's facets too.
ROLLER = """
    [mesh]
    generator = "block"               # tag 1: y = 0
    nx = 4
    ny = 2
    degree = 2

    [material]
    E = 10.0
    nu = 0.3
    rho = 2.0

    [scheme]
    name = "{scheme}"
    dt = 0.1
    t_end = 1.0

    [[facet_tag]]                     # the right half of the bottom
    tag = 5
    on_plane = {{ point = [0.0, 0.0], normal = [0.0, 2.0] }}
    in_box = {{ lower = [0.0, -1.0], upper = [1.0, 1.0] }}

    [[facet_tag]]                     # the right side
    tag = 6
    normal_within = {{ direction = [1.0, 0.0] }}

    [[facet_tag]]                     # the top, then its left half retagged 10
    tag = 7
    in_box = {{ lower = [-1.0, 1.0], upper = [1.0, 1.0] }}

    [[facet_tag]]
    tag = 10
    in_box = {{ lower = [-1.0, 0.5], upper = [0.0, 1.0] }}
    normal_within = {{ direction = [0.0, 1.0], angle = 45.0 }}

    [[facet_tag]]                     # the left side: the union of two tables
    tag = 8
    on_plane = {{ point = [-1.0, 0.0], normal = [1.0, 0.0], tolerance = 1e-12 }}
    in_box = {{ lower = [-1.0, 0.0], upper = [-1.0, 0.5] }}

    [[facet_tag]]
    tag = 8
    normal_within = {{ direction = [-1.0, 0.0], angle = 0.0 }}
    in_box = {{ lower = [-1.0, 0.5], upper = [0.0, 1.0] }}

    [[dirichlet]]                     # the roller: tags 1 and 5
    tag = 1
    component = 1
    value = {roller}

    [[dirichlet]]
    tag = 5
    component = 1
    value = {roller}

    [body_force]
    value = [2.0, 0.0]

    [initial]
    velocity = [0.0, 0.1]

    [[probe]]
    name = "u_x_right"
    quantity = "displacement"
    facets = 6

    [[probe]]
    name = "u_y_top"
    quantity = "displacement"
    component = 1
    facets = 7

    [[probe]]
    name = "v_x_inside"
    quantity = "velocity"
    point = [0.3, 0.7]

    [output]
    every = 0
    columns = ["t", "elastic", "kinetic", "momentum_x", "momentum_y", "centre_of_mass_x",
               "centre_of_mass_y", "u_x_right", "u_y_top", "v_x_inside"]
"""


@pytest.mark.parametrize(
    "scheme, roller",
    [
        ("hybrid", "[[0.0, 0.0], [1.0, 0.1]]"),
        ("newmark", '{ profile = "ramp", value = 0.1, duration = 1.0 }'),
        ("cn", "[[0.0, 0.0], [2.0, 0.2]]"),
    ],
)
def test_block_on_a_roller_configured_moves_rigidly(tmp_path, scheme, roller):
    config, simulation = configured(tmp_path, ROLLER.format(scheme=scheme, roller=roller))
    problem = simulation.problem
    # the block's tag 1 (y = 0) keeps the facets no selector chooses
    lengths = {1: 1.0, 5: 1.0, 6: 1.0, 7: 1.0, 10: 1.0, 8: 1.0}
    for tag, length in lengths.items():  # assembled against exact: 1e-9 of the length
        assert measure(problem, tag) == pytest.approx(length, rel=1e-9), tag
    history = simulation.run(columns=history_columns(config, simulation))
    t, mass = history["t"], 2.0 * 2.0  # rho |Omega|
    exact = {
        "centre_of_mass_x": t**2 / 2,
        "centre_of_mass_y": 0.5 + 0.1 * t,
        "momentum_x": mass * t,
        "momentum_y": mass * 0.1 + 0 * t,
        "u_x_right": t**2 / 2,
        "u_y_top": 0.1 * t,
        "v_x_inside": t,
        "kinetic": 0.5 * mass * (t**2 + 0.01),
    }
    # the run against the exact motion, round-off apart: 1e-9 of each column's scale, and
    # the elastic energy of a rigid motion (its round-off) on the scale of the kinetic one
    for name, values in exact.items():
        atol = 1e-9 * np.abs(values).max()
        np.testing.assert_allclose(history[name], values, rtol=0, atol=atol, err_msg=name)
    assert np.abs(history["elastic"]).max() <= 1e-9 * history["kinetic"].max()


# -- a sweep over E compiles once --------------------------------------------------------


#: A block stretched by u0 = (1e-3 x, 0) falling at speed 1 above the ground, two steps
#: with its fields written: every form of a run.
STRETCHED = """
    [mesh]
    generator = "block"
    width = 1.0
    height = 0.5
    nx = 4
    ny = 2

    [material]
    E = {E}
    nu = 0.3
    rho = {rho}

    [nitsche]
    gamma0 = 1e-3
    gamma0_scaling = "E"

    [scheme]
    dt = 0.01
    t_end = 0.02

    [[obstacle]]
    point = [0.0, -0.1]
    normal = [0.0, 1.0]
    tag = 1

    [body_force]
    value = [0.0, -1.0]

    [initial]
    displacement = {{ gradient = [[1e-3, 0.0], [0.0, 0.0]] }}
    velocity = [0.0, -1.0]

    [output]
    every = 1
"""


def test_sweep_over_E_compiles_once(tmp_path, compilations):
    """Three TOML files that differ in E (and rho), run by the command line in one process:
    the second and third compile nothing (E, nu and rho are runtime constants; their values
    are new to any cache), and each run has its own material's energies at t = 0:
    elastic = (lambda + 2 mu) eps^2 |Omega| / 2, kinetic = rho |Omega| / 2."""
    seed = np.random.default_rng().uniform(1.0, 2.0)
    compiled = []
    for index, (E, rho) in enumerate([(10.0, 1.0), (37.0 * seed, seed), (71.0 * seed, 2.0)]):
        folder = tmp_path / str(index)
        folder.mkdir()
        path = write(folder, STRETCHED.format(E=repr(E), rho=repr(rho)))
        before = len(compilations)
        assert cli(["run", path, "--quiet", "--out", str(folder / "out")]) == 0
        compiled.append(compilations[before:])
        history = read_history(str(folder / "out" / "history.csv"))
        lmbda, mu = E * 0.3 / (1.3 * 0.4), E / 2.6
        area = 0.5
        elastic = 0.5 * (lmbda + 2 * mu) * 1e-6 * area
        # assembled energies against their formulas: 1e-9 of each
        assert history["elastic"][0] == pytest.approx(elastic, rel=1e-9)
        assert history["kinetic"][0] == pytest.approx(0.5 * rho * area, rel=1e-9)
    assert not compiled[1] and not compiled[2], compiled


# -- the example of docs/usage.md ----------------------------------------------------------


@pytest.mark.parametrize("linear_solver", ["auto", "lu"])
def test_readme_configuration_runs(tmp_path, linear_solver):
    """The TOML block of docs/usage.md with a symmetry plane, selectors and point probes: the
    block starts 0.01 above the ground at speed 1 (u_y = 0.01 at the corner and on the
    top, centre of mass 0.51 up, momentum -rho |Omega| = -2), bounces, and once released
    keeps its momentum along y and moves its centre of mass by it (no load).

    With direct solves (lu) the momentum is kept to round-off, a property of the scheme;
    with the default ("auto": conjugate gradients here, each solve stopped at a tenth of
    Newton's tolerance, docs/method.md section 8) to that tolerance."""
    import re

    usage = os.path.join(os.path.dirname(os.path.dirname(__file__)), "docs", "usage.md")
    example = re.search(r"<!-- usage-toml -->\s*```toml\n(.*?)```", open(usage).read(), re.S)
    assert example, "docs/usage.md lost its marked TOML example"
    assert "linear_solver" not in example.group(1)  # the example runs the default
    given = example.group(1) + (f'\n[solver]\nlinear_solver = "{linear_solver}"\n')
    config, simulation = configured(tmp_path, given)
    assert simulation.solver_description.startswith(
        "auto: cg-jacobi" if linear_solver == "auto" else "lu"
    ), simulation.solver_description
    history = simulation.run(columns=history_columns(config, simulation))
    first = history[0]
    # sums over the 306 dofs of M v (or M u): 38 terms a row, then the rows summed in pairs,
    # so up to (38 + log2 306) eps sum |M| |v| = 2.7e-14 off (sum |M| e_y = 2.7); against
    # exact values, 1e-9 of each one's scale (u: 0.01, the block: 1, rho |Omega| v: 2)
    for name, value, scale in [("u_y_corner", 0.01, 0.01), ("u_y_top", 0.01, 0.01),
                               ("centre_of_mass_y", 0.51, 1.0), ("momentum_y", -2.0, 2.0),
                               ("momentum_x", 0.0, 2.0)]:  # fmt: skip
        assert first[name] == pytest.approx(value, abs=1e-9 * scale), name
    touching = np.flatnonzero(history["contact_force"] > 0)
    assert len(touching) > 0 and touching[-1] < len(history) - 5  # released
    free = slice(touching[-1] + 1, None)
    momentum = history["momentum_y"][free]
    # A free step changes the momentum by tau e_y . F (M e_y is K's null vector): with lu,
    # F is round-off, and the momentum's own round-off (2.7e-14, above) rules: 5.4e-14
    # between two levels, 3.2e-14 of it. With CG, ||F|| <= snes_rtol S / 10 a step, which
    # bounds the drift by tau |e_y| sum ||F|| = 9.7e-8 of the momentum over the 30 free
    # steps (measured: 3.9e-9). The rise divides the round-off of two centres of mass
    # (46 eps sum |M| |u| = 1.4e-14 each) by tau = 0.01: 3.3e-12 of it. Round-off of
    # different levels, processor-dependent: with lu, 1e-9 of the momentum and of the rise.
    tolerance = 1e-9 if linear_solver == "lu" else 1e-7
    assert momentum.min() > 1.0 and np.ptp(momentum) <= tolerance * momentum.max()
    rise = np.diff(history["centre_of_mass_y"][free]) / np.diff(history["t"][free])
    np.testing.assert_allclose(rise, momentum[0] / 2.0, rtol=tolerance)
