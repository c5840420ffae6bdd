"""Contact between hyperelastic bodies (docs/method.md section 15, "Contact between
bodies"): two neo-Hookean disks colliding head-on, P1, paired along the axis of the
collision; E_Theta, the momenta, the forces on the two bodies, the small-strain limit,
the other implicit schemes, self-contact, a restart, 2 ranks against one."""

from __future__ import annotations

import numpy as np
import pytest
from dolfinx import fem
from mpi4py import MPI

from nitsche_dolfinx import (
    ContactProblem,
    HybridScheme,
    Material,
    PlaneObstacle,
    Simulation,
    make_scheme,
)
from nitsche_dolfinx.cases import LOWER_BODY, UPPER_BODY, two_bodies_problem
from nitsche_dolfinx.contact import FinitePairContact
from nitsche_dolfinx.contact import finite as finite_contact
from nitsche_dolfinx.meshing import C_BOTTOM, C_SLOT, c_shape_mesh
from nitsche_dolfinx.physics import gauss_points

DT = 0.1
#: Newton's tolerance, relative to the scale of the step's equation (the default).
RTOL = 1e-10


def disks_problem(law="neo_hookean", v0=1.0, comm=MPI.COMM_WORLD) -> ContactProblem:
    """The two disks of radius 20 (lambda = mu = 20, rho = 1) of tests/test_two_bodies.py,
    P1 on straight cells (h = 8: 164 DOFs), towards each other at v0 each, their lowest
    and highest nodes touching; declared as bodies 1 (upper) and 2 (lower)."""
    problem, cells = two_bodies_problem(dim=2, mesh_size=8.0, v0=v0, degree=1,
                                        geometry_order=1, gamma0=1e-3, law=law,
                                        comm=comm)  # fmt: skip
    for tag in (UPPER_BODY, LOWER_BODY):
        problem.add_body(tag, cells)
    return problem


def run(problem, t_end, scheme=None, **options) -> dict:
    simulation = Simulation(problem, scheme or HybridScheme(), dt=DT, t_end=t_end, **options)
    history = simulation.run()
    return {name: np.asarray(history[name]) for name in history.columns}


@pytest.fixture(scope="module")
def collision():
    """At v0 = 1 (strains about v0 / c = 0.13): in contact from t = 0.4 to the end, t = 6."""
    return run(disks_problem(), 6.0)


def test_the_halves_are_finite_strain_ones(collision):
    problem = disks_problem()
    assert [type(half) for half in problem.pairs] == [FinitePairContact] * 2
    assert collision["contact_force"].max() > 0
    assert collision["det_F_min"].min() < 0.95  # finite strains (det F of 0.9 and less)


def test_energy_theta_never_rises(collision):
    """Theta = 1, hybrid: E_Theta never rises by more than Newton's tolerance allows. Newton
    stops when ||F|| <= RTOL times the step's scale, at least ||M v^n|| / tau; the residual
    left, tested with the step's increment (about tau v), changes the energy by at most
    RTOL ||M v|| ||v||, of the order of RTOL E: so the bound RTOL E_Theta(0), raised to
    1e-9 E_Theta(0) (what Newton leaves varies with the processor's round-off). Measured
    1.9e-11 E_Theta(0): the 2-point Gauss rule in s of the contact terms' mean derivatives
    (finite_contact.CONTACT_POINTS; see the next test)."""
    energy = collision["energy_theta"]
    assert np.diff(energy).max() < 1e-9 * energy[0]
    assert energy[-1] < energy[0] - 1e-3 * energy[0]  # the impacts dissipate


def test_energy_theta_rises_by_round_off_with_the_exact_rule_in_s(monkeypatch):
    """The same collision (to t = 3) with 4 Gauss points in s and Newton's tolerance 1e-13:
    E_Theta's largest rise falls to round-off (measured 1.1e-14 E_Theta(0); 1.3e-13 with
    4 points at RTOL): the energy identity of the step holds, what is left of it is the
    rule in s and Newton's tolerance."""
    monkeypatch.setattr(finite_contact, "CONTACT_POINTS", gauss_points(4))
    values = run(disks_problem(), 3.0, petsc_options={"snes_rtol": 1e-13})
    energy = values["energy_theta"]
    assert values["contact_force"].max() > 0
    # What is left: Newton's 1e-13 E_Theta(0) at most and E_Theta's round-off (about 1e-14
    # of it), which may differ with the processor. 1e-12 leaves a factor 10 and still tells
    # them from the 2-point rule's 1.9e-11 (above), which is what this test is for: a
    # property of one run, not a comparison of two, kept below the comparisons' 1e-9.
    assert np.diff(energy).max() < 1e-12 * energy[0]


def test_momentum_is_kept_and_the_bodies_feel_equal_and_opposite_forces(collision):
    """The pair terms tested with a constant vector vanish (T c = c at the slave nodes and
    D sigma_n[c] = 0): the total momentum is kept to Newton's tolerance (a force residual
    of RTOL times the scale, about ||M v|| / tau, over a step tau: RTOL M v0 per step;
    measured 1e-15 of M v0), and what each body gains the other loses (the upper body
    gains 0.82 M v0; the sum of the two gains measured 3e-16 of M v0). The bodies are
    mirror images: the two halves of the unbiased pair carry the same force (measured equal
    to 6e-16 of its largest value)."""
    M_v0 = np.abs(collision["momentum_1_y"][0])  # one body's momentum, M v0
    steps = len(collision["t"])
    for component in ("x", "y"):
        total = collision[f"momentum_{component}"]
        assert np.abs(total - total[0]).max() < steps * RTOL * M_v0, component
        gained = [collision[f"momentum_{b}_{component}"] - collision[f"momentum_{b}_{component}"][0]
                  for b in (UPPER_BODY, LOWER_BODY)]  # fmt: skip
        assert np.abs(gained[0] + gained[1]).max() < steps * RTOL * M_v0, component
    assert collision["momentum_1_y"].max() - collision["momentum_1_y"][0] > 0.1 * M_v0
    forces = collision["contact_force_1"], collision["contact_force_2"]
    # two halves computed on mirror images: 1e-9 of the force, on any processor
    assert np.abs(forces[0] - forces[1]).max() < 1e-9 * forces[0].max()


def _first_touch(problem) -> float:
    """The smallest gap at a quadrature point of the upper disk's contact surface (P1, the
    2-point Gauss rule on each facet: the gap is linear along a facet): where the contact
    begins when the disks approach each other."""
    half = problem.pairs[0]
    pairing = half.pairing
    bs = problem.gdim
    gap = np.einsum("nd,nd->n", pairing.gap_vector.x.array.reshape(-1, bs),
                    pairing.normal.x.array.reshape(-1, bs))  # fmt: skip
    xi = 0.5 - 0.5 / np.sqrt(3.0)  # the Gauss point nearer to a facet's end
    fdim = problem.mesh.topology.dim - 1
    smallest = np.inf
    for facet in problem.facets(half.ds.subdomain_id()):
        ends = np.sort(gap[fem.locate_dofs_topological(problem.V, fdim, np.array([facet]))])
        smallest = min(smallest, ends[0] + xi * (ends[-1] - ends[0]))
    return float(smallest)


def _force_per_speed(law: str, speed: float, touch: float, window: float) -> np.ndarray:
    """The contact force over the speed, from the step before the first touch for
    ``window``."""
    t_touch = touch / (2 * speed)
    values = run(disks_problem(law, speed), round(t_touch - DT / 2 + window, 6))
    return values["contact_force"][int(round(t_touch / DT - 0.5)) :] / speed


def test_small_speeds_give_the_linear_pair_run():
    """At speed V the strains are about V / c (c = 7.7); the neo-Hookean disks' contact
    force over V differs from the linear material's by O(V). The speeds are chosen so that
    the first touch falls in the middle of a step for both (else the step in which it
    falls, which differs with V, would change the discrete history by more than the
    material does): at V = 0.099 the force over V differs from the linear one by 9.1e-3 of
    its peak over 1 time unit of contact, at V = 0.0099 by 9.1e-4 (ratio 10.05 for speeds
    9.98 apart)."""
    touch = _first_touch(disks_problem("linear"))
    speeds = [touch / (2 * steps * DT) for steps in (32.5, 324.5)]
    differences = []
    for speed in speeds:
        linear = _force_per_speed("linear", speed, touch, 1.0)
        neo_hookean = _force_per_speed("neo_hookean", speed, touch, 1.0)
        assert linear[0] == 0 and linear.max() > 0
        differences.append(np.abs(neo_hookean - linear).max() / linear.max())
    assert differences[0] < 2e-2
    ratio = (differences[0] / differences[1]) / (speeds[0] / speeds[1])
    assert 0.9 < ratio < 1.1, differences


@pytest.mark.parametrize("scheme", ["theta", "newmark"])
def test_backward_euler_and_newmark_step_the_pair(scheme):
    """Backward Euler (theta = 1) and Newmark (the trapezoidal rule) take the pair terms at
    t^{n+1}: the momentum is kept, the energy does not grow (backward Euler dissipates)."""
    values = run(disks_problem(), 3.0, make_scheme(scheme))
    assert values["contact_force"].max() > 0
    M_v0 = np.abs(values["momentum_1_y"][0])
    # kept up to round-off, which varies with the processor: 1e-9 of M v0
    assert np.abs(values["momentum_y"] - values["momentum_y"][0]).max() < 1e-9 * M_v0
    assert values["energy"][-1] < values["energy"][0]


def test_the_full_jacobian_with_the_coupling_is_the_split_one_on_linear_pairs():
    """``reuse_jacobian=False`` with contact pairs: the full Jacobian of every iteration
    plus the pairs' coupling (systems.FormSystem, as at finite strain) solves the linear
    disks as the split Jacobian does (affine_system.AffineSystem): the same history to 1e-9 of
    each column's scale, as two computations on any processor (measured 1e-13)."""
    split = run(disks_problem("linear"), 3.0)
    full = run(disks_problem("linear"), 3.0, reuse_jacobian=False)
    assert split["contact_force"].max() > 0
    for name in ("energy_theta", "contact_force", "momentum_1_y"):
        scale = np.abs(split[name]).max()
        assert np.abs(full[name] - split[name]).max() < 1e-9 * scale, name


def test_self_contact_at_finite_strain():
    """The C-shaped body of tests/test_self_contact.py, neo-Hookean, lands and closes its
    slot (the surface paired with itself, again at every step): E_Theta less the
    pairings' changes never rises by more than RTOL E_Theta(0) (measured 1.3e-11), compared
    to 1e-9 E_Theta(0), as its round-off varies with the processor."""
    mesh, _, facets = c_shape_mesh(slot=0.2, mesh_size=0.2)
    material = Material(E=100.0, nu=0.3, rho=1.0, law="neo_hookean")
    problem = ContactProblem(mesh, facets, material, 1, 1e-5, 1.0)
    problem.add_contact_pair(C_SLOT, C_SLOT)
    down = np.eye(2)[1]
    problem.add_obstacle(PlaneObstacle(point=-0.0525 * down, normal=down), C_BOTTOM)
    problem.set_initial_conditions(velocity=-0.5 * down)
    values = Simulation(problem, HybridScheme(), dt=0.01, t_end=1.0).run()
    assert np.max(values["contact_force_1"]) > 0  # the slot closed
    energy = np.asarray(values["energy_theta"]) - np.asarray(values["pairing_energy"])
    assert np.diff(energy).max() < 1e-9 * energy[0]


def test_restart_in_contact_continues_the_run_to_the_bit(tmp_path):
    """Stopped at t = 1.5 (in contact) and restarted from its checkpoint, the collision's
    rows after it are the uninterrupted run's to the bit: the pairing, the Newton guess
    and, on the first Jacobian in contact, the coupling's sparsity are the same."""
    columns = ("energy", "energy_theta", "contact_force", "det_F_min", "momentum_1_y")
    history = run(disks_problem(), 3.0)
    out = str(tmp_path / "run")
    Simulation(disks_problem(), HybridScheme(), dt=DT, t_end=1.5).run(
        out=out, checkpoint_every=1000
    )
    restarted = Simulation(disks_problem(), HybridScheme(), dt=DT, t_end=3.0).run(
        out=out, restart=True
    )
    kept = np.asarray(restarted["t"]) > 1.55
    assert kept.sum() == 15 and history["contact_force"][kept].max() > 0
    for column in columns:
        assert np.array_equal(np.asarray(restarted[column])[kept], history[column][kept]), column


@pytest.mark.mpi
def test_two_ranks_equal_one():
    """The collision to t = 3 on 2 ranks gives the serial history to 1e-8 of each column's
    largest value (the momenta: of one body's, M v0; measured 5e-15, each surface on both
    ranks)."""
    parallel = run(disks_problem(), 3.0)
    serial = run(disks_problem(comm=MPI.COMM_SELF), 3.0)
    assert serial["contact_force"].max() > 0
    M_v0 = np.abs(serial["momentum_1_y"][0])
    for name in ("energy", "energy_theta", "contact_force", "det_F_min", "momentum_y",
                 "momentum_1_y"):  # fmt: skip
        scale = M_v0 if name.startswith("momentum") else np.abs(serial[name]).max()
        assert np.abs(parallel[name] - serial[name]).max() < 1e-8 * scale, name
