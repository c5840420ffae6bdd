"""Contact pairs that follow the sliding (docs/method.md section 11): two disks hitting
off-centre and sliding past each other, paired again in the configuration of the last
converged step; the pairing against an exhaustive search, E_Theta, a restart in the
middle of the sliding, and 2 ranks against one."""

import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

from nitsche_dolfinx import HybridScheme, Simulation
from nitsche_dolfinx.cases import LOWER_BODY, UPPER_BODY, body_velocities, two_bodies_problem

MESH_SIZE = 4.0
#: Each disk moves at (-+VX, -+VY): a grazing hit whose surfaces slide past each other.
VX, VY = 2.0, 0.3


def _sliding(comm=MPI.COMM_WORLD, t_end=14.0):
    """The two disks of the talk (radius 20, P2), centres 36 apart sideways, hitting each
    other while they pass: in contact from t = 5.7 to 13, sliding 4 a unit of time."""
    problem, cells = two_bodies_problem(
        dim=2, mesh_size=MESH_SIZE, gap=1.0, along_axis=False, offset=36.0, comm=comm
    )
    velocities = {UPPER_BODY: [-VX, -VY], LOWER_BODY: [VX, VY]}
    problem.set_initial_conditions(velocity=body_velocities(problem, cells, velocities))
    return problem, Simulation(problem, HybridScheme(), dt=0.1, t_end=t_end)


@pytest.fixture(scope="module")
def slid():
    problem, simulation = _sliding()
    return problem, simulation.run()


def _saved(pairing):
    T = pairing.T.copy()
    return T, pairing.normal.x.array.copy(), pairing.gap_vector.x.array.copy()


@pytest.mark.mpi
def test_pairing_after_sliding_agrees_with_an_exhaustive_search(slid):
    """After the surfaces slid past each other by more than 5 cells, the pairing the
    k-d tree search made agrees with the one found by projecting every slave node on every
    facet of the other surface, to round-off (the same projections, on the candidates
    the search kept)."""
    problem, history = slid
    contact = np.asarray(history["t"])[np.asarray(history["contact_force"]) > 0]
    assert 2 * VX * (contact.max() - contact.min()) > 5 * MESH_SIZE
    for pair in problem.pairs:
        pairing = pair.pairing
        assert pairing.generation > 10
        T, normal, gap = _saved(pairing)
        pairing.pair(pairing.displacement, exhaustive=True)
        T.axpy(-1.0, pairing.T, structure=PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
        # T holds basis function values (at most 1), the normal is a unit vector, the gap
        # vector is below 2 radii = 40: round-off of the projections' arithmetic, by two
        # searches, so 1e-9 of those scales
        assert T.norm(PETSc.NormType.INFINITY) < 1e-9
        assert np.abs(pairing.normal.x.array - normal).max() < 1e-9
        assert np.abs(pairing.gap_vector.x.array - gap).max() < 1e-9 * 40
        T.destroy()


def test_sliding_keeps_momentum_and_controls_energy(slid):
    """The pairs' forces are equal and opposite: the total momentum stays zero to round-off
    (relative to one disk's, rho pi R^2 |v|). Between pairings E_Theta never rises beyond
    the solver's tolerance; a pairing changes it by ``pairing_energy``, here 0.14% of
    E_Theta(0) in all (more with coarser steps or a coarser slip threshold: docs/method.md
    section 11)."""
    _, history = slid
    one_disk = np.pi * 20.0**2 * np.hypot(VX, VY)
    # zero up to round-off, which varies with the processor: 1e-9 of one disk's
    for component in ("momentum_x", "momentum_y"):
        assert np.abs(history[component]).max() < 1e-9 * one_disk
    energy = np.asarray(history["energy_theta"])
    pairing = np.asarray(history["pairing_energy"])
    # a step's rise is at most snes_rtol |F| |du| plus round-off of E_Theta: measured
    # 1.2e-13 E_Theta(0), so 1e-9 E_Theta(0) on any processor; a new pairing's changes are
    # of order 1e-4 E_Theta(0)
    assert np.diff(energy - pairing).max() < 1e-9 * energy[0]
    assert 0 < np.abs(pairing[-1]) < 1e-2 * energy[0]


def _assert_same_run(history, reference):
    """Each column to 1e-8 of its largest value (the pairings' share of E_Theta on
    E_Theta's scale): the runs differ by round-off (the Jacobian's sparsity, the ranks'
    sums) that the contact switch and the pairings amplify. Measured: 2e-12 (energies) and
    8e-10 (force) on 2 ranks against 1, 1e-12 and 4e-10 for the restart."""
    energy = np.abs(reference["energy_theta"]).max()  # (the scale of the energies)
    for column in ("energy", "energy_theta", "pairing_energy", "contact_force"):
        scale = np.abs(reference[column]).max() if column == "contact_force" else energy
        difference = np.abs(np.asarray(history[column]) - np.asarray(reference[column]))
        assert np.nanmax(difference) <= 1e-8 * scale, column


def test_restart_in_the_middle_of_the_sliding_continues_the_run(slid, tmp_path):
    """A run stopped at t = 9 (in contact, sliding, paired many times) and restarted from
    its checkpoint continues the uninterrupted run: the restart pairs the surfaces in the
    saved displacement of their last pairing."""
    _, history = slid
    out = str(tmp_path / "run")
    _, first = _sliding(MPI.COMM_SELF, t_end=9.0)
    first.run(out=out, checkpoint_every=100)
    _, second = _sliding(MPI.COMM_SELF)
    restarted = second.run(out=out, restart=True)
    kept = np.asarray(restarted["t"]) > 9.05  # (the rows read back have the CSV's columns)
    _assert_same_run(
        {c: np.asarray(restarted[c])[kept] for c in _COMPARED},
        {c: np.asarray(history[c])[kept] for c in _COMPARED},
    )


_COMPARED = ("energy", "energy_theta", "pairing_energy", "contact_force")


@pytest.mark.mpi
def test_sliding_on_two_ranks_equals_serial(slid):
    """2 ranks against 1, the two disks' surfaces on both ranks."""
    if MPI.COMM_WORLD.size == 1:
        pytest.skip("a comparison of 2 ranks with 1")
    _, parallel = slid
    _, serial = _sliding(MPI.COMM_SELF)
    _assert_same_run(parallel, serial.run())
