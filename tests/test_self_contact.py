"""Self-contact (docs/method.md section 11): the C-shaped body of demos/c_shape_2d.py, whose
slot's faces are one surface paired with itself, lands on the ground and closes the slot;
the pairing in the reference configuration, E_Theta, and 2 ranks against one."""

import numpy as np
import pytest
from dolfinx import fem
from mpi4py import MPI

from nitsche_dolfinx import ContactProblem, HybridScheme, Material, PlaneObstacle, Simulation
from nitsche_dolfinx.meshing import C_BOTTOM, C_SLOT, c_shape_mesh

MESH_SIZE, SLOT, HIGH, V0, DROP = 0.2, 0.2, 1.2, 0.5, 0.0525


def _problem(comm=MPI.COMM_WORLD, mesh_size=MESH_SIZE, depth=0.0):
    """The demo's body on a coarser mesh (h = 0.2, the slot one cell wide); ``depth``: the
    prism of that depth over it."""
    mesh, _, facets = c_shape_mesh(slot=SLOT, mesh_size=mesh_size, depth=depth, comm=comm)
    problem = ContactProblem(mesh, facets, Material(E=100.0, nu=0.3, rho=1.0), 1, 1e-5, 1.0)
    problem.add_contact_pair(C_SLOT, C_SLOT)
    down = np.eye(problem.gdim)[1]
    problem.add_obstacle(PlaneObstacle(point=-DROP * down, normal=down), C_BOTTOM)
    problem.set_initial_conditions(velocity=-V0 * down)
    return problem


def _c_shape(comm=MPI.COMM_WORLD, t_end=1.0):
    """The body landing: the slot closes at its open end from t = 0.4 on."""
    problem = _problem(comm)
    return problem, Simulation(problem, HybridScheme(), dt=0.01, t_end=t_end)


@pytest.fixture(scope="module")
def landed():
    problem, simulation = _c_shape()
    return problem, simulation.run()


def test_a_surface_paired_with_itself_faces_across_the_slot():
    """In the reference configuration each node of the slot's two sides is paired with the
    other side, straight across (gap = the slot's width, normal along y), never with
    its own side; the nodes of the slot's end face nothing and have no partner (their
    own partners: u - T u = 0, a positive gap)."""
    problem = _problem(mesh_size=0.05)  # (nodes on the slot's end)
    (half,) = problem.pairs
    assert half.weight == 0.5  # each touching pair of points counted from both sides
    pairing = half.pairing
    nodes, positions = pairing._nodes, pairing._positions
    normal = pairing.normal.x.array.reshape(-1, 2)[nodes]
    gap = np.einsum("nd,nd->n", pairing.gap_vector.x.array.reshape(-1, 2)[nodes], normal)
    sides = np.abs(np.abs(positions[:, 1] - 1.1) - SLOT / 2) < 1e-9  # nodes 0.05 apart
    end = ~sides  # x = 1, strictly between the sides
    upper = positions[:, 1] > 1.1
    # reference positions and a unit normal: round-off of the coordinates (about 1),
    # against exact values: 1e-9 of that scale
    assert np.abs(gap[sides] - SLOT).max() < 1e-9
    assert np.abs(normal[sides & upper] - [0.0, -1.0]).max() < 1e-9
    assert np.abs(normal[sides & ~upper] - [0.0, 1.0]).max() < 1e-9
    u = fem.Function(problem.V)
    u.x.array[:] = np.random.default_rng(1).random(len(u.x.array))
    relative = pairing._relative(u)
    assert end.sum() >= 3 and np.abs(relative[end]).max() == 0.0  # its own partner
    assert (gap[end] > 0).all()


def test_slot_closes_and_e_theta_is_controlled(landed):
    """The slot closes (its pair carries a force) and opens again; between pairings
    E_Theta never rises beyond the solver's tolerance, and the pairings, made at every
    step, change it by less than 1e-3 of E_Theta(0) in all."""
    _, history = landed
    slot = np.asarray(history["contact_force_1"])
    assert slot.max() > 0 and slot[-1] == 0.0
    energy = np.asarray(history["energy_theta"])
    pairing = np.asarray(history["pairing_energy"])
    # a step's rise is at most snes_rtol |F| |du| plus round-off of E_Theta: measured
    # 3e-13 E_Theta(0); both vary with the processor: 1e-9 E_Theta(0)
    assert np.diff(energy - pairing).max() < 1e-9 * energy[0]
    assert np.abs(pairing).max() < 1e-3 * energy[0]


def test_prism_closes_its_slot_and_e_theta_is_controlled():
    """The prism of depth 1 over the C (h = 0.35, tetrahedra): the slot's faces end at its
    two sides, flush with each other, where a node beside the other face's end sees it
    at a glancing angle; the surface does not turn there, so its plane goes on past the
    end (docs/method.md section 11) and the pairings keep E_Theta (measured: 3e-5 of
    E_Theta(0); 3e-2 with the line to the end as the normal)."""
    problem = _problem(mesh_size=0.35, depth=1.0)
    history = Simulation(problem, HybridScheme(), dt=0.01, t_end=0.8).run()
    assert np.asarray(history["contact_force_1"]).max() > 0
    energy = np.asarray(history["energy_theta"])
    pairing = np.asarray(history["pairing_energy"])
    assert np.diff(energy - pairing).max() < 1e-9 * energy[0]  # as above
    assert np.abs(pairing).max() < 1e-3 * energy[0]


@pytest.mark.mpi
def test_self_contact_on_two_ranks_equals_serial(landed):
    """2 ranks against 1, the slot's faces on both ranks: each column to 1e-8 of its
    largest value (round-off that the contact switch and the pairings amplify)."""
    if MPI.COMM_WORLD.size == 1:
        pytest.skip("a comparison of 2 ranks with 1")
    _, parallel = landed
    _, simulation = _c_shape(MPI.COMM_SELF)
    serial = simulation.run()
    energy = np.abs(serial["energy_theta"]).max()
    for column in ("energy", "energy_theta", "pairing_energy", "contact_force_1"):
        scale = np.abs(serial[column]).max() if column.startswith("contact") else energy
        difference = np.abs(np.asarray(parallel[column]) - np.asarray(serial[column]))
        assert difference.max() <= 1e-8 * scale, column


def test_restart_while_the_slot_is_closed_continues_the_run(landed, tmp_path):
    """A run stopped at t = 0.45 (the slot closed, paired at every step) and restarted from
    its checkpoint continues the uninterrupted run, each column to 1e-8 of its largest
    value (the restart pairs the surface in the saved displacement; measured 1.5e-14 of
    E_Theta and 3e-12 of the force: the history's rows read back from the CSV and the
    round-off that the contact switch amplifies)."""
    _, history = landed
    out = str(tmp_path / "run")
    _, first = _c_shape(MPI.COMM_SELF, t_end=0.45)
    first.run(out=out, checkpoint_every=1000)
    _, second = _c_shape(MPI.COMM_SELF)
    restarted = second.run(out=out, restart=True)
    kept = np.asarray(restarted["t"]) > 0.455
    energy = np.abs(history["energy_theta"]).max()
    for column in ("energy_theta", "pairing_energy", "contact_force_1"):
        scale = np.abs(history[column]).max() if column.startswith("contact") else energy
        difference = np.asarray(restarted[column])[kept] - np.asarray(history[column])[kept]
        assert np.abs(difference).max() <= 1e-8 * scale, column
