"""Reactions of the supports, the work of loads, supports and moving obstacles, and the
energy balance that closes with them (docs/method.md section 13)."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest

from nitsche_dolfinx import ContactProblem, Material, PlaneObstacle, Simulation, make_scheme
from nitsche_dolfinx.config import build_simulation, history_columns, load_config
from nitsche_dolfinx.meshing import BAR_CLAMPED, BAR_CONTACT, bar_mesh, block_mesh
from nitsche_dolfinx.steppers import reaction_columns

#: The bar (0, 1), E = rho = 1, clamped at x = 1: g its gravity along -x.
GRAVITY = 0.1
REACTION = f"reaction_{BAR_CLAMPED}"


def hanging_bar(scheme: str, degree: int = 2, cells: int = 8):
    """The bar hanging from x = 1 under its weight, at rest in its static state
    u = g/(2E) (x^2 - 1) (quadratic: exact in P2)."""
    mesh, tags = bar_mesh(cells)
    problem = ContactProblem(mesh, tags, Material(E=1.0, nu=0.0, rho=1.0), degree=degree)
    problem.add_dirichlet(BAR_CLAMPED, 0.0)
    problem.add_body_force([-GRAVITY])
    problem.set_initial_conditions(displacement=lambda x: GRAVITY / 2 * (x[0] ** 2 - 1))
    return Simulation(problem, make_scheme(scheme), 0.1, 1.0)


@pytest.mark.parametrize("scheme", ["hybrid", "cn", "theta", "newmark"])
def test_reaction_of_a_body_at_rest_is_its_weight(scheme):
    """The support holds the weight rho g L = 0.1, up (+x), at every level to round-off
    (sums of a few terms of 0.1: 1e-15), and nothing moves: no work. Round-off varies with
    the processor: 1e-9 of the scales, the weight and its energy, 0.1 x u0(0) = 5e-3."""
    history = hanging_bar(scheme).run(columns=[REACTION, "work", "energy_balance", "kinetic"])
    np.testing.assert_allclose(history[REACTION], GRAVITY, rtol=0, atol=1e-9 * GRAVITY)
    assert np.abs(history["work"]).max() < 1e-9 * 5e-3
    assert np.abs(history["kinetic"]).max() < 1e-9 * 5e-3


def shaken_bar(scheme: str, mass: str = "consistent", damping: bool = False, t_end: float = 4.0):
    """The bar held at x = 1 by a shaker u = 0.05 sin(3t), pulled by f = -0.1 (1 + t), its
    end x = 0 hitting a wall at x = -0.02 (all the terms of the balance at once)."""
    mesh, tags = bar_mesh(50)
    problem = ContactProblem(mesh, tags, Material(E=1.0, nu=0.0, rho=1.0), gamma0=1e-3, mass=mass)
    problem.add_dirichlet(BAR_CLAMPED, lambda t: [0.05 * np.sin(3 * t)])
    problem.add_obstacle(PlaneObstacle([-0.02], [1.0]), BAR_CONTACT)
    problem.add_body_force(lambda t: [-0.1 * (1 + t)])
    if damping:
        problem.set_damping(alpha=0.05, beta=0.002)
    dt = "auto" if scheme == "verlet" else 0.02
    return Simulation(problem, make_scheme(scheme), dt, t_end)


COLUMNS = ["t", "energy_theta", "work", "energy_balance", "contact_force", "momentum",
           REACTION, "contact_dissipation", "damping_dissipation"]  # fmt: skip


@pytest.mark.parametrize("scheme, damping", [("hybrid", False), ("cn", False), ("hybrid", True)])
def test_energy_balance_closes_with_loads_supports_and_contact(scheme, damping):
    """A shaken bar pulled by a load growing in time and hitting a wall: the internal
    energy's change plus what contact (and damping) dissipated equals the work of the load
    and the shaker at every level, to the solves' round-off (energies of 0.1, Newton to
    1e-10 of the equation's scale: 1e-12 of the work; compared to 1e-9 of it, as round-off
    varies with the processor), for the hybrid scheme with Theta =
    1 and for Crank-Nicolson (the trapezoid of the forces). The run does touch the wall and
    the shaker does work."""
    columns = COLUMNS if damping else COLUMNS[:-1]
    history = shaken_bar(scheme, damping=damping).run(columns=columns)
    assert history["contact_force"].max() > 0 and np.ptp(history["work"]) > 0.05
    scale = np.abs(history["work"]).max()
    assert np.abs(history["energy_balance"]).max() < 1e-9 * scale
    # measured: 7e-16 (hybrid), 9e-16 (cn)


def test_theta_scheme_dissipates_beyond_the_balance():
    """theta = 1 dissipates by itself: its balance is open, and negative (energy lost)."""
    history = shaken_bar("theta").run(columns=["energy_balance", "work"])
    assert history["energy_balance"].min() < -1e-3


def test_verlet_balance_to_its_order():
    """Verlet's balance is its trapezoid of the work against its levels' energies: open at
    second order (1e-3 of the work at dt = auto on 50 cells, with the stiff contact)."""
    history = shaken_bar("verlet", mass="lumped").run(columns=["energy_balance", "work"])
    assert np.abs(history["energy_balance"]).max() < 0.02 * np.abs(history["work"]).max()


def test_momentum_changes_by_the_loads_and_the_reaction():
    """d(momentum)/dt = loads + reactions (+ contact forces), step by step: with no wall,
    the hybrid scheme's (p^{n+1} - p^n)/tau is the load at t^{n+1/2} plus the step's
    reaction. What the steps leave of it is the sum over the free dofs of the equation's
    residual, below snes_rtol = 1e-10 times the equation's scale (up to about 1e3 here:
    the prescribed rows of the initial guess w = a^n): 1e-7. Measured: 2.5e-10, the round-off
    of the direct solves at that scale (the same with snes_rtol = 1e-13)."""
    mesh, tags = bar_mesh(40)
    problem = ContactProblem(mesh, tags, Material(E=1.0, nu=0.0, rho=1.0))
    problem.add_dirichlet(BAR_CLAMPED, lambda t: [0.05 * np.sin(3 * t)])
    problem.add_body_force(lambda t: [-0.1 * (1 + t)])
    history = Simulation(problem, make_scheme("hybrid"), 0.02, 2.0).run(
        columns=["t", "momentum", REACTION]
    )
    t, p, reaction = history["t"], history["momentum"], history[REACTION]
    middle = (t[1:] + t[:-1]) / 2
    loads = -0.1 * (1 + middle)  # int_0^1 f dx
    change = np.diff(p) / np.diff(t)
    np.testing.assert_allclose(change, loads + reaction[1:], rtol=0, atol=1e-7)


def test_restart_continues_the_work_and_the_reactions(tmp_path):
    """Crank-Nicolson's trapezoid takes the last level's reactions: they are in the
    checkpoint, so a run stopped at t = 2 and restarted to 4 gives the straight run's
    history bit for bit (the same computation)."""
    straight = shaken_bar("cn").run(columns=COLUMNS[:-1])
    out = str(tmp_path / "out")
    shaken_bar("cn", t_end=2.0).run(out=out, columns=COLUMNS[:-1], checkpoint_every=25)
    restarted = shaken_bar("cn").run(out=out, columns=COLUMNS[:-1], restart=True)
    for name in COLUMNS[1:-1]:
        np.testing.assert_array_equal(restarted[name], straight[name], err_msg=name)


def test_reactions_per_tag_and_component():
    """A block clamped at its bottom, its top pushed down by a traction: the bottom's
    reaction has an x and a y column, and each changes the momentum as it should."""
    mesh, tags = block_mesh(2.0, 1.0, 8, 4)
    from nitsche_dolfinx.meshing import tag_facets

    tags = tag_facets(mesh, {2: lambda x: np.isclose(x[1], 1.0)}, tags)
    problem = ContactProblem(mesh, tags, Material(E=100.0, nu=0.3, rho=1.0), degree=2)
    problem.add_dirichlet(1, [0.0, 0.0])
    problem.add_traction(2, [0.0, -1.0])
    columns = reaction_columns([1], 2)
    assert columns == ("reaction_1_x", "reaction_1_y")
    simulation = Simulation(problem, make_scheme("hybrid"), 0.01, 2.0)
    history = simulation.run(columns=["t", "momentum_x", "momentum_y", *columns])
    # no horizontal load: the horizontal momentum changes by the horizontal reaction alone
    # (the mesh's diagonals all lean one way, so it is not zero), to Newton's tolerance
    change = np.diff(history["momentum_x"]) / np.diff(history["t"])
    np.testing.assert_allclose(change, history["reaction_1_x"][1:], rtol=0, atol=1e-8)
    assert np.abs(history["reaction_1_x"]).max() > 1e-3
    # vertically the traction pushes 2 (1 on a width of 2) down: the change of momentum is
    # the reaction less 2
    change = np.diff(history["momentum_y"]) / np.diff(history["t"])
    np.testing.assert_allclose(change, history["reaction_1_y"][1:] - 2.0, rtol=0, atol=1e-8)


def test_toml_run_writes_reactions_and_the_balance(tmp_path):
    """A TOML file with a [[dirichlet]] table writes the reaction and balance columns."""
    text = textwrap.dedent(
        """
        [mesh]
        generator = "bar"
        nx = 10

        [material]
        E = 1.0
        nu = 0.0

        [scheme]
        name = "hybrid"
        dt = 0.1
        t_end = 0.5

        [[dirichlet]]
        tag = 2
        value = ["0.01 * sin(t)"]

        [body_force]
        value = [-0.1]
        """
    )
    path = tmp_path / "case.toml"
    path.write_text(text)
    config = load_config(str(path))
    simulation = build_simulation(config, progress=False, source=str(path))
    columns = history_columns(config, simulation)
    assert "reaction_2" in columns and "work" in columns and "energy_balance" in columns
    history = simulation.run(columns=columns)
    # round-off, processor-dependent: 1e-9 of the work
    assert np.abs(history["energy_balance"]).max() < 1e-9 * np.abs(history["work"]).max()


def test_momentum_changes_by_the_contact_force_too(monkeypatch):
    """With the wall: (p^{n+1} - p^n)/tau = loads + reactions - (the contact terms' rows
    summed: the force the step's equation puts on the body from the wall, its affine part
    summing to zero), each as the hybrid step's equation takes it. The contact terms are
    assembled from the step's own state before it moves on; the bound is the one of the
    test above (1e-7: Newton's tolerance, summed over the free dofs)."""
    import ufl
    from dolfinx import fem
    from dolfinx.fem import petsc as fem_petsc
    from petsc4py import PETSc

    from nitsche_dolfinx.common import compat
    from nitsche_dolfinx.contact import contact_parts
    from nitsche_dolfinx.steppers import NitscheStepper

    simulation = shaken_bar("hybrid", t_end=3.0)
    stepper, problem = simulation.stepper, simulation.problem
    test = ufl.TestFunction(problem.V)
    state = (stepper.w, stepper.u, stepper.v, stepper.a, stepper._dt)
    parts = [simulation.scheme.residual(part, *state, test) for part in contact_parts(problem)]
    contact = fem.form(parts[0] + parts[1])
    forces = []
    reactions = NitscheStepper._reactions

    def with_contact(self):
        vector = compat.create_vector(problem.V)
        with vector.localForm() as local:
            local.set(0.0)
        fem_petsc.assemble_vector(vector, contact)
        vector.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        forces.append(-vector.sum())
        vector.destroy()
        return reactions(self)

    monkeypatch.setattr(NitscheStepper, "_reactions", with_contact)
    history = simulation.run(columns=["t", "momentum", REACTION, "contact_force"])
    t, p = history["t"], history["momentum"]
    loads = -0.1 * (1 + (t[1:] + t[:-1]) / 2)
    forces = np.array(forces)
    assert history["contact_force"].max() > 0 and np.abs(forces).max() > 0.1
    change = np.diff(p) / np.diff(t)
    np.testing.assert_allclose(change, loads + history[REACTION][1:] + forces, rtol=0, atol=1e-7)
