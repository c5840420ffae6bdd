"""Hyperelastic bodies at finite strain (docs/method.md section 15): the energy-consistent
step, momenta, the small-strain limit, contact with E_Theta controlled, refusals."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest
import ufl
from dolfinx import fem
from dolfinx import mesh as dmesh
from mpi4py import MPI

from nitsche_dolfinx import (
    ContactProblem,
    Material,
    PlaneObstacle,
    Simulation,
    make_scheme,
)
from nitsche_dolfinx.cases import impact_problem
from nitsche_dolfinx.common import ParameterError
from nitsche_dolfinx.config import build_simulation, load_config
from nitsche_dolfinx.contact import gateaux
from nitsche_dolfinx.meshing import OnPlane, tag_facets
from nitsche_dolfinx.output import FINITE_COLUMNS, HISTORY_COLUMNS, angular_momentum_columns
from nitsche_dolfinx.physics import MaterialConstants, first_piola, neo_hookean

COLUMNS = (*HISTORY_COLUMNS, *FINITE_COLUMNS, "momentum_x", "momentum_y",
           *angular_momentum_columns(2))  # fmt: skip


def spinning_square(law: str, comm=MPI.COMM_WORLD, degree: int = 1) -> ContactProblem:
    """A unit square, free, spinning at 0.5 rad/s and stretching (strains up to about
    0.2 within a few time units)."""
    mesh = dmesh.create_unit_square(comm, 4, 4)
    problem = ContactProblem(mesh, None, Material(E=1.0, nu=0.3, law=law), degree=degree)

    def velocity(x):
        return np.vstack([-0.5 * (x[1] - 0.5) + 0.3 * (x[0] - 0.5),
                          0.5 * (x[0] - 0.5) - 0.2 * (x[1] - 0.5) ** 2])  # fmt: skip

    problem.set_initial_conditions(velocity=velocity)
    return problem


class MidpointProblem(ContactProblem):
    """The midpoint rule's bulk term, P(F(u^{n+1/2})), for comparison: not energy-consistent
    for a nonlinear material."""

    def hybrid_operator(self, u_old, u_new, v, velocity=None, reference=None):
        return self.bulk_stiffness((u_old + u_new) / 2, v)


def history(problem, steps: int, dt: float = 0.05, columns=COLUMNS) -> dict:
    simulation = Simulation(problem, make_scheme("hybrid"), dt=dt, t_end=steps * dt)
    rows = list(simulation.run(columns=columns))
    return {key: np.array([row[key] for row in rows]) for key in columns}


def test_free_flight_keeps_energy_and_momenta_where_the_midpoint_rule_drifts():
    """Free flight of a spinning, stretching neo-Hookean square over 200 steps: E stays
    within 1e-9 E0 (measured 2e-15: the step's averaged stress is an exact discrete
    gradient up to its Gauss rule in s; Newton stops at 1e-10 of the equation's scale and
    the energy error that leaves is that residual times the step's increment), the
    momentum and the angular momentum to 1e-9 of the momenta's scale rho |Omega| max |v0| =
    0.4 (the step's equation keeps them exactly; Newton's residual is a balanced force to
    its tolerance; what round-off leaves varies with the processor). The
    midpoint rule, P at u^{n+1/2}, drifts by more than 1e-5 E0 on the same run (measured
    6e-4)."""
    values = history(spinning_square("neo_hookean"), 200)
    energy, E0 = values["energy"], values["energy"][0]
    assert np.max(np.abs(energy - E0)) < 1e-9 * E0
    assert values["elastic"].max() > 0.1 * E0  # a finite-strain motion, not a rigid one
    for name in ("momentum_x", "momentum_y", "angular_momentum_z"):
        assert np.max(np.abs(values[name] - values[name][0])) < 1e-9 * 0.4, name
    assert values["det_F_min"].min() > 0
    mesh = dmesh.create_unit_square(MPI.COMM_WORLD, 4, 4)
    midpoint = MidpointProblem(mesh, None, Material(E=1.0, nu=0.3, law="neo_hookean"))
    midpoint.set_initial_conditions(velocity=spinning_square("linear").initial_velocity)
    drift = history(midpoint, 200, columns=HISTORY_COLUMNS)["energy"]
    assert np.max(np.abs(drift - drift[0])) > 1e-5 * drift[0]


def test_saint_venant_kirchhoff_keeps_energy_to_round_off():
    """W quadratic in C: the stress at the mean C is the exact discrete gradient (Simo and
    Tarnow), so E is kept to Newton's tolerance, 1e-10 of the equation's scale (measured
    1e-12 E0 on P2; compared to 1e-9 E0, as its round-off varies with the processor), with
    Newton's tolerance taken 1000 times tighter to round-off (measured 3e-15 E0)."""
    values = history(spinning_square("svk", degree=2), 40)
    energy = values["energy"]
    assert np.max(np.abs(energy - energy[0])) < 1e-9 * energy[0]
    problem = spinning_square("svk", degree=2)
    simulation = Simulation(problem, make_scheme("hybrid"), dt=0.05, t_end=2.0,
                            petsc_options={"snes_rtol": 1e-13})  # fmt: skip
    energy = np.array([row["energy"] for row in simulation.run(columns=COLUMNS)])
    # A property of one run, not a comparison of two: Newton's 1e-13 bounds it, 33 times
    # the round-off measured, which leaves room for other processors and still tells it
    # from the default tolerance's 1e-12 E0 (above), which is what this test is for.
    assert np.max(np.abs(energy - energy[0])) < 1e-13 * energy[0]


def block_force_per_speed(law: str, speed: float) -> np.ndarray:
    """The contact force over speed of a P2 block falling flat on the ground at ``speed``."""
    mesh = dmesh.create_rectangle(MPI.COMM_WORLD, [[-0.5, 0.0], [0.5, 1.0]], [6, 6])
    tags = tag_facets(mesh, {1: OnPlane([0.0, 0.0], [0.0, 1.0])})
    material = Material.from_lame(20.0, 20.0, law=law)
    problem = ContactProblem(mesh, tags, material, degree=2, gamma0=1e-3)
    problem.add_obstacle(PlaneObstacle([0.0, 0.0], [0.0, 1.0]), 1)
    problem.set_initial_conditions(velocity=[0.0, -speed])
    return history(problem, 30, dt=0.02, columns=HISTORY_COLUMNS)["contact_force"] / speed


def test_small_strains_give_the_linear_contact_force():
    """At speed V the strains are about V / c (c = 7.7): 1.3e-4 at V = 1e-3. The linear
    force over V does not depend on V; St Venant-Kirchhoff's differs from it by O(V):
    measured 6.3e-4 of the peak at V = 1e-3, 6.3e-5 at 1e-4 (ratio 10.0)."""
    linear = block_force_per_speed("linear", 1e-3)
    peak = linear.max()
    assert peak > 0
    differences = [
        np.max(np.abs(block_force_per_speed("svk", speed) - linear)) / peak
        for speed in (1e-3, 1e-4)
    ]
    assert differences[0] < 1e-3
    assert 9.0 < differences[0] / differences[1] < 11.0


def test_dropped_disk_keeps_energy_theta_under_control():
    """The talk's disk, neo-Hookean, dropped on the ground (Theta = 1, hybrid): E_Theta
    never rises by more than 1e-9 E_Theta(0) over a step (measured 3e-13; Newton's
    tolerance and round-off, which varies with the processor) through the impacts, and
    Newton takes at most 5 iterations."""
    problem = impact_problem(dim=2, mesh_size=4.0, degree=1, geometry_order=1,
                             law="neo_hookean")  # fmt: skip
    values = history(problem, 160, dt=0.1)
    assert values["contact_force"].max() > 0
    rises = np.diff(values["energy_theta"])
    assert rises.max() < 1e-9 * values["energy_theta"][0]
    assert values["newton_iterations"].max() <= 5


def test_contact_test_terms_are_the_derivatives_of_the_contact_quantities():
    """D sigma_n(u)[v] of :func:`gateaux` against a centred difference of sigma_n on a
    curved obstacle (the normal turns with x = X + u): agreement to 1e-7, the difference's
    truncation error at eps = 1e-5."""
    mesh = dmesh.create_unit_square(MPI.COMM_WORLD, 3, 3)
    problem = ContactProblem(mesh, None, Material(E=1.0, nu=0.3, law="neo_hookean"))
    constants = MaterialConstants(Material(E=1.0, nu=0.3), lambda x: fem.Constant(mesh, x))
    n = ufl.FacetNormal(mesh)
    X = ufl.SpatialCoordinate(mesh)

    def sigma_n(u):
        x = X + u
        normal = -(x - ufl.as_vector([0.5, -1.0])) / ufl.sqrt(ufl.dot(x - ufl.as_vector(
            [0.5, -1.0]), x - ufl.as_vector([0.5, -1.0])))  # fmt: skip
        return ufl.dot(ufl.dot(first_piola(neo_hookean, constants, u), n), normal)

    u, z = fem.Function(problem.V), fem.Function(problem.V)
    u.interpolate(lambda x: np.vstack([0.1 * x[1] ** 2, 0.05 * x[0] * x[1]]))
    z.interpolate(lambda x: np.vstack([np.sin(x[0]), x[1] ** 2]))
    derivative = fem.assemble_scalar(fem.form(gateaux(sigma_n, u, z) * ufl.ds))
    eps = 1e-5
    plus = fem.assemble_scalar(fem.form(sigma_n(u + eps * z) * ufl.ds))
    minus = fem.assemble_scalar(fem.form(sigma_n(u - eps * z) * ufl.ds))
    assert abs(derivative - (plus - minus) / (2 * eps)) < 1e-7 * abs(derivative)


@pytest.mark.parametrize(
    ("keywords", "named"),
    [
        ({"law": "rubber"}, "law"),
        ({"law": ["svk"]}, "law"),
    ],
)
def test_bad_law_is_named(keywords, named):
    with pytest.raises(ParameterError, match=named):
        Material(E=1.0, nu=0.3, **keywords)


def test_what_a_hyperelastic_body_does_not_take_is_refused_in_one_line():
    material = Material(E=1.0, nu=0.3, law="svk")
    mesh = dmesh.create_unit_square(MPI.COMM_WORLD, 2, 2)
    line = dmesh.create_unit_interval(MPI.COMM_WORLD, 2)
    with pytest.raises(ParameterError, match="2D"):
        ContactProblem(line, None, material)
    with pytest.raises(ParameterError, match="frictionless"):
        ContactProblem(mesh, None, material, friction=0.1)
    with pytest.raises(ParameterError, match="Nitsche"):
        ContactProblem(mesh, None, material, method="penalty")
    problem = ContactProblem(mesh, None, material)
    with pytest.raises(ParameterError, match="damping"):
        problem.set_damping(0.1, 0.0)
    with pytest.raises(ParameterError, match="verlet"):
        Simulation(ContactProblem(mesh, None, material, mass="lumped"),
                   make_scheme("verlet"), dt="auto", t_end=1.0)  # fmt: skip


def test_toml_law(tmp_path):
    """``[material] law`` makes the hyperelastic material, and the history has det_F_min."""
    text = textwrap.dedent(
        """
        [mesh]
        generator = "block"
        width = 1.0
        height = 1.0
        nx = 3
        ny = 3
        [material]
        E = 1.0
        nu = 0.3
        law = "neo_hookean"
        [initial]
        velocity = ["-0.5 * (y - 0.5)", "0.5 * x"]
        [scheme]
        name = "hybrid"
        dt = 0.1
        t_end = 0.3
        """
    )
    path = tmp_path / "spin.toml"
    path.write_text(text)
    config = load_config(str(path))
    simulation = build_simulation(config, progress=False, source=str(path))
    assert simulation.problem.finite
    rows = list(simulation.run(columns=COLUMNS))
    assert rows[-1]["det_F_min"] > 0


@pytest.mark.mpi
def test_two_ranks_equal_one(tmp_path):
    """The free flight on 2 ranks equals the serial run to 1e-9 of each column's size
    (round-off of sums in another order, amplified by Newton's tolerance 1e-10 at most)."""
    parallel = history(spinning_square("neo_hookean"), 20)
    serial = history(spinning_square("neo_hookean", comm=MPI.COMM_SELF), 20)
    momentum = max(np.max(np.abs(serial[name])) for name in ("momentum_x", "momentum_y"))
    for name in ("energy", "momentum_x", "momentum_y", "angular_momentum_z", "det_F_min"):
        scale = momentum if name.startswith("momentum") else np.max(np.abs(serial[name]))
        assert np.max(np.abs(parallel[name] - serial[name])) < 1e-9 * scale, name


def dropped_disk(law: str = "neo_hookean", comm=MPI.COMM_WORLD, t_end: float = 12.0):
    """The talk's disk, coarse and P1, dropped on the ground: in contact from t = 10.2."""
    problem = impact_problem(dim=2, mesh_size=4.0, degree=1, geometry_order=1, law=law,
                             comm=comm)  # fmt: skip
    return Simulation(problem, make_scheme("hybrid"), dt=0.1, t_end=t_end)


def test_restart_in_contact_continues_the_run_to_the_bit(tmp_path):
    """A run stopped at t = 11 (in contact) and restarted from its checkpoint takes the same
    Newton guess, the last step's unknown, kept in the checkpoint: the rows after it are
    the uninterrupted run's to the bit (the same computation)."""
    columns = (*HISTORY_COLUMNS, *FINITE_COLUMNS)
    history = dropped_disk().run(columns=columns)
    out = str(tmp_path / "run")
    dropped_disk(t_end=11.0).run(out=out, columns=columns, checkpoint_every=1000)
    restarted = dropped_disk().run(out=out, columns=columns, restart=True)
    kept = np.asarray(restarted["t"]) > 11.05
    assert kept.sum() == 10
    for column in ("energy", "energy_theta", "contact_force", "det_F_min"):
        after = np.asarray(restarted[column])[kept]
        assert np.array_equal(after, np.asarray(history[column])[kept]), column


def test_an_inverted_element_is_no_state():
    """A converged state with det F <= 0 somewhere is refused like one that E_Theta does not
    control, with its own one-line reason, and a smaller step may be tried."""
    from nitsche_dolfinx.steppers import UncontrolledStep, energy_controlled

    values = {"energy": 1.0, "energy_theta": 1.0, "kinetic": 0.5, "elastic": 0.5,
              "potential": 0.0, "det_F_min": -0.01}  # fmt: skip
    assert not energy_controlled(values)
    error = UncontrolledStep(values, 3, "")
    assert error.cut_may_help and error.reason_name == "INVERTED"
    assert "det F = -0.01" in str(error) and "\n" not in str(error)
    assert energy_controlled({**values, "det_F_min": 0.2})


def test_a_cube_in_3d_keeps_energy_and_momenta():
    """3D, P1: a spinning, stretching neo-Hookean cube, 40 steps: E to 1e-9 E0 (Newton's
    tolerance, as in 2D), momenta to 1e-9 of their scale rho |Omega| max |v0| = 0.4."""
    mesh = dmesh.create_unit_cube(MPI.COMM_WORLD, 2, 2, 2)
    problem = ContactProblem(mesh, None, Material(E=1.0, nu=0.3, law="neo_hookean"))

    def velocity(x):
        return np.vstack([-0.5 * (x[1] - 0.5) + 0.3 * (x[0] - 0.5), 0.5 * (x[0] - 0.5),
                          0.2 * (x[2] - 0.5) ** 2])  # fmt: skip

    problem.set_initial_conditions(velocity=velocity)
    columns = (*HISTORY_COLUMNS, "momentum_x", "momentum_z", *angular_momentum_columns(3))
    values = history(problem, 40, columns=columns)
    energy = values["energy"]
    assert np.max(np.abs(energy - energy[0])) < 1e-9 * energy[0]
    for name in columns[len(HISTORY_COLUMNS) :]:
        assert np.max(np.abs(values[name] - values[name][0])) < 1e-9 * 0.4, name


@pytest.mark.mpi
def test_dropped_disk_on_two_ranks_equals_one():
    """Through the impact, 2 ranks give the serial history to 1e-9 of each column's
    largest value (sums in another order, amplified through Newton's tolerance 1e-10 and the
    contact switches; measured below 1e-12)."""
    columns = (*HISTORY_COLUMNS, *FINITE_COLUMNS)
    parallel = dropped_disk(t_end=11.5).run(columns=columns)
    serial = dropped_disk(comm=MPI.COMM_SELF, t_end=11.5).run(columns=columns)
    assert np.max(serial["contact_force"]) > 0
    for name in ("energy", "energy_theta", "contact_force", "det_F_min"):
        scale = np.max(np.abs(serial[name]))
        assert np.max(np.abs(np.asarray(parallel[name]) - serial[name])) < 1e-9 * scale, name
