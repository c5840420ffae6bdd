"""The explicit Verlet scheme (branch verlet, work in progress): against GetFEM's explicit
1D demo, its stable step, its automatic step, a blow-up, ranks and restarts."""

import os
import signal

import numpy as np
import pytest
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc

from nitsche_dolfinx import ParameterError, Simulation, read_history
from nitsche_dolfinx.cases import add_bar_probes, bar_problem, impact_problem
from nitsche_dolfinx.common import RunInterrupted
from nitsche_dolfinx.steppers import UnstableStep, VerletScheme, round_down

DATA = os.path.join(os.path.dirname(__file__), "data")
BAR_COLUMNS = ["t", "energy", "u_contact", "v_contact", "sigma_contact"]


def getfem_history(theta: int, mass: str) -> dict:
    stem = "getfem_verlet_bar" + ("" if mass == "lumped" else "_" + mass)
    path = os.path.join(DATA, f"{stem}_theta{theta}.csv")
    lines = [line for line in open(path) if not line.startswith("#")]
    names = lines[0].strip().split(",")
    values = np.array([[float(x) for x in line.split(",")] for line in lines[1:]])
    return dict(zip(names, values.T))


@pytest.mark.parametrize(
    "mass, theta",
    [("lumped", 0), ("lumped", 1), ("lumped", -1), ("redistributed", 0), ("redistributed", 1),
     ("redistributed", -1), ("consistent", 0)],
)  # fmt: skip
def test_the_bar_is_getfem_explicit_demo(mass, theta):
    """GetFEM 5.4.2's demo_dynamic_contact_1D.py, Nitsche (version 3) with beta = 0,
    gamma0_N = 5 (its gamma = gamma0_N / h, so our absolute gamma0 = 1/5), NX = 20,
    dt = 0.002 to T = 12 (6,000 steps, 4 impacts): the same history with the lumped mass
    (lump_mass_matrix=1), the redistributed one (and mass_matrix_type=1: the contact node
    massless, in equilibrium at each level; its velocity a backward difference) and the
    consistent one (lump_mass_matrix=0, mass_matrix_type=0: GetFEM solves it with MUMPS,
    we with CG to 1e-12, whose difference the history carries to 1.5e-12 of v and sigma,
    measured).

    The demo starts its force with no contact term at all (F_c = 0 at t = 0), where ours has
    the Theta consistency term: for Theta != 0 our stepper gets the demo's a0 = -M^-1 K u0.
    The two codes make the same arithmetic but for the order of the sums, whose round-off
    (1e-16 a step) the 6,000 steps carry to 1.2e-12 of v and sigma (measured; a numpy
    rewrite of the demo agrees with GetFEM to the same 1e-12): 1e-10, the issue's bound,
    raised to 1e-9, the least tolerance between two codes on any processor."""
    problem = bar_problem(nx=20, gamma0=1 / 5, mass=mass, nitsche_theta=float(theta))
    simulation = Simulation(problem, VerletScheme(mass_solver="cg"), dt=0.002, t_end=12.0)
    if theta != 0:
        stepper = simulation.stepper
        form = fem.form(-problem.bulk_stiffness(stepper.u, ufl.TestFunction(problem.V)))
        force = fem_petsc.assemble_vector(form)
        force.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        n = force.getLocalSize()
        stepper.a.x.array[:n] = force.array * stepper._mass.inverse[:n]
    add_bar_probes(simulation)
    history = simulation.run(columns=BAR_COLUMNS)
    theirs = getfem_history(theta, mass)
    ours = {name: np.asarray(history[name])[::20] for name in BAR_COLUMNS}
    assert np.array_equal(ours["t"], theirs["t"])
    for name, their in [("u_contact", "u"), ("v_contact", "v"), ("sigma_contact", "s"),
                        ("energy", "energy")]:  # fmt: skip
        scale = np.abs(theirs[their]).max()
        assert np.abs(ours[name] - theirs[their]).max() <= 1e-9 * scale, name
    if mass == "redistributed":  # the massless node's Jacobian is factorised again only
        # when its contact status changes: at the first step, at 4 impacts and 4 releases
        assert 1 <= simulation.stepper._massless.factorisations <= 9


@pytest.mark.parametrize(
    "mass, linear_limit",
    [("lumped", 0.03162277660168381), ("consistent", 0.022577098581466722),
     ("redistributed", 0.050165466767866505)],
)  # fmt: skip
def test_stable_step_of_getfem_s_bar_for_each_mass(mass, linear_limit):
    """The estimate against 2 / sqrt(lambda_max) of GetFEM's own matrices for the demo's bar
    (NX = 20, gamma0_N = 5, theta_N = 0; dense generalized eigenvalues of its K + Nitsche's
    all-active stiffness and its mass, the Dirichlet row dropped; for the redistributed mass, of the
    massive dofs' block, as the estimate takes it (the exact Schur complement of the
    massless node gives 0.0501655, 3e-5 above, so the estimate is on the safe side)). The
    power iterations stop when the Rayleigh quotient moves by less than 1e-6 a step; on
    this 20-cell spectrum that leaves it within 1e-4 (measured: 2e-5)."""
    problem = bar_problem(nx=20, gamma0=1 / 5, mass=mass, nitsche_theta=0.0)
    simulation = Simulation(problem, VerletScheme(mass_solver="cg"), dt=0.002, t_end=0.002)
    assert abs(simulation.stepper.stable_dt / linear_limit - 1.0) <= 1e-4


def test_stable_step_of_the_bar_is_its_wave_crossing_where_the_bulk_limits():
    """gamma0 = 0.5 on the bar (1/gamma_h = 2 E / h): the bulk limits the step, whose bound
    for the lumped P1 bar is h / c (lambda_max -> 4 c^2 / h^2). The power iterations stop
    when the Rayleigh quotient moves by less than 1e-6 a step, which on the bar's clustered
    top of the spectrum leaves it 0.4% below lambda_max: the step 0.19% above h / c
    (measured); the automatic step is its safety share, rounded down to 3 digits."""
    simulation = Simulation(
        bar_problem(nx=100, gamma0=0.5, mass="lumped"), VerletScheme(), dt="auto", t_end=0.1
    )
    assert 0.01 <= simulation.stepper.stable_dt <= 0.01 * 1.005
    assert simulation.dt == round_down(0.5 * simulation.stepper.stable_dt) == 0.005


def test_a_step_above_the_stable_one_is_refused_and_a_blow_up_stops_the_run(tmp_path):
    """dt 1.7 times the estimate is refused, naming both; allowed, the run blows up and stops
    with UnstableStep, its history written to the level before."""
    problem = bar_problem(nx=100, gamma0=0.1, mass="lumped")
    refused = r"dt=0\.008: above the verlet scheme's stable step 0\.0047"
    with pytest.raises(ParameterError, match=refused):
        Simulation(problem, VerletScheme(), dt=0.008, t_end=6.0)
    simulation = Simulation(
        bar_problem(nx=100, gamma0=0.1, mass="lumped"), VerletScheme(force_dt=True),
        dt=0.02, t_end=20.0,
    )  # fmt: skip
    with pytest.raises(UnstableStep, match="the verlet steps blew up"):
        simulation.run(out=str(tmp_path), columns=["t", "energy"])
    written = read_history(os.path.join(tmp_path, "history.csv"))
    assert len(written["t"]) == simulation.step_index + 1 and np.isfinite(written["energy"]).all()


def disk(t_end):
    problem = impact_problem(dim=2, mesh_size=8.0, mass="lumped")
    return Simulation(problem, VerletScheme(safety=0.5), dt="auto", t_end=t_end)


DISK_COLUMNS = ["t", "energy", "energy_theta", "kinetic", "elastic", "contact_force"]


@pytest.mark.mpi
@pytest.mark.parametrize("mass, degree", [("lumped", 2), ("redistributed", 1), ("consistent", 1)])
def test_the_disk_on_ranks_is_the_disk_serially(mass, degree):
    """The disk through its impact, P2 with the HRZ mass, P1 with the redistributed mass
    (its massless contact nodes solved across the ranks) and with the consistent one (CG):
    on 2 ranks as serially, to the round-off of the sums over the ranks and of the solves
    (measured to t = 40: 2.4e-14, 1.1e-14, 5.6e-14; compared to 1e-9, as it varies with
    the processor), with the same automatic step."""

    def run(comm):
        problem = impact_problem(dim=2, mesh_size=8.0, mass=mass, degree=degree, comm=comm)
        scheme = VerletScheme(mass_solver="cg")
        return Simulation(problem, scheme, dt="auto", t_end=20.0).run(columns=DISK_COLUMNS)

    history = run(MPI.COMM_WORLD)
    serial_history = run(MPI.COMM_SELF)  # the same disk on this rank alone
    assert np.array_equal(history["t"], serial_history["t"])
    for name in DISK_COLUMNS[1:]:
        scale = np.abs(serial_history[name]).max()
        assert np.abs(history[name] - serial_history[name]).max() <= 1e-9 * scale, name


def test_an_interrupted_disk_restarts_to_the_bit(tmp_path):
    """SIGTERM in contact (step 150, t = 14.2), then a restart: the uninterrupted history."""
    straight = disk(20.0).run(out=str(tmp_path / "straight"), columns=DISK_COLUMNS)

    def stop(simulation):
        if simulation.step_index == 150:
            os.kill(os.getpid(), signal.SIGTERM)

    with pytest.raises(RunInterrupted):
        disk(20.0).run(out=str(tmp_path / "run"), columns=DISK_COLUMNS, callback=stop)
    disk(20.0).run(out=str(tmp_path / "run"), columns=DISK_COLUMNS, restart=True)
    written = read_history(str(tmp_path / "run" / "history.csv"))
    assert straight["contact_force"][150] > 0
    for name in DISK_COLUMNS:
        assert np.array_equal(written[name], straight[name]), name


@pytest.mark.parametrize(
    "problem, refused",
    [
        (
            lambda: bar_problem(nx=10),
            "mass='consistent': the verlet scheme with the "
            "consistent mass needs a linear solve a step: say which \\(mass_solver='cg'\\)",
        ),
        (lambda: bar_problem(nx=10, mass="lumped", method="penalty"), "method='penalty'"),
        (lambda: impact_problem(dim=2, mass="lumped", friction=0.2), "friction=0.2"),
    ],
    ids=["consistent", "penalty", "friction"],
)
def test_what_the_explicit_steps_do_not_take_is_refused_in_one_line(problem, refused):
    with pytest.raises(ParameterError, match=refused):
        Simulation(problem(), VerletScheme(), dt="auto", t_end=1.0)


def test_auto_is_the_verlet_scheme_s_and_its_step_is_said_at_start(capsys):
    from nitsche_dolfinx import HybridScheme

    with pytest.raises(ParameterError, match="dt='auto': an automatic step is the verlet"):
        Simulation(bar_problem(nx=10), HybridScheme(), dt="auto", t_end=1.0)
    simulation = Simulation(
        bar_problem(nx=100, gamma0=0.5, mass="lumped"), VerletScheme(), dt="auto", t_end=0.02,
        progress=True,
    )  # fmt: skip
    simulation.run(columns=["t"])
    if MPI.COMM_WORLD.rank == 0:
        said = capsys.readouterr()
        assert "verlet(safety=0.5): stable dt = 0.01" in said.out + said.err


@pytest.mark.parametrize(
    "flags, dt",
    [(["--scheme", "verlet"], "auto"), (["--dt", "0.001", "--scheme", "verlet"], 0.001),
     (["--scheme", "verlet", "--dt", "0.001"], 0.001), (["--scheme", "hybrid"], 0.015)],
)  # fmt: skip
def test_an_explicit_scheme_makes_the_demo_step_auto_unless_dt_is_given(flags, dt):
    """docs/method.md section 12: with --scheme verlet, --dt defaults to the estimate."""
    import argparse

    from nitsche_dolfinx.cli import add_method_arguments

    parser = argparse.ArgumentParser()
    add_method_arguments(parser, gamma0=1e-6, degree=1, dt=0.015, t_end=6.0)
    assert parser.parse_args(flags).dt == dt


def test_two_bars_are_one_bar_on_a_wall_with_half_gamma0():
    """Contact between bodies, stepped explicitly: two mirror-image P1 bars at +-v0 with
    gamma0 (lumped mass, the unbiased pair: its partner-tested terms carried by T^T) are,
    term by term, one bar on a rigid wall with gamma0 / 2 (docs/method.md section 11):
    the same contact force and twice the energies, step by step, and the same stable step
    (the symmetric mode is the wall's; power iterations from other starts: 1e-4). Not to
    round-off: the two computations (other meshes, the pair's coupling through T against
    the plane's terms; the pair's gap and normal are exact here) differ by 1.1e-12 of the
    peak force at the second step, and the switching of the contact nodes grows that to
    4.4e-8 of the peak over 800 steps (the energies 1.6e-9; measured, the same with
    another BLAS kernel): 1e-6. A missing or wrong partner term changes them by their
    size."""
    from nitsche_dolfinx import ContactProblem, Material, PlaneObstacle
    from nitsche_dolfinx.cases import two_bars_problem
    from nitsche_dolfinx.meshing import bar_mesh

    pair, _ = two_bars_problem(nx=20, v0=0.5, gamma0=0.2, mass="lumped")
    mesh, tags = bar_mesh(20)
    wall = ContactProblem(mesh, tags, Material(E=1.0, nu=0.0, rho=1.0), 1, 0.1, 1.0,
                          mass="lumped")  # fmt: skip
    wall.add_obstacle(PlaneObstacle([0.0], [1.0]), 1)
    wall.set_initial_conditions(velocity=[-0.5])
    runs = [Simulation(p, VerletScheme(), dt=0.004, t_end=3.2) for p in (pair, wall)]
    assert abs(runs[0].stepper.stable_dt / runs[1].stepper.stable_dt - 1.0) <= 1e-4
    two, one = (run.run(columns=["t", "energy", "energy_theta", "contact_force"]) for run in runs)
    force = one["contact_force"].max()
    assert force > 0.4
    np.testing.assert_allclose(two["contact_force"], one["contact_force"], rtol=0,
                               atol=1e-6 * force)  # fmt: skip
    for column in ("energy", "energy_theta"):
        np.testing.assert_allclose(two[column], 2 * one[column], rtol=1e-6)


@pytest.mark.mpi
@pytest.mark.parametrize("along_axis", [True, False], ids=["axis", "closest"])
def test_two_disks_on_ranks_are_the_disks_serially(along_axis):
    """The two P2 disks (HRZ mass) through their impact, each rank with a part of both
    contact surfaces: partners across the cut, as serially to round-off (1e-9). The
    surfaces are paired once: paired again as they slide, the pairing depends on the
    state, whose round-off it amplifies (measured here 4e-11; tests/test_sliding.py
    checks the pairing that follows the sliding on 2 ranks)."""
    from nitsche_dolfinx.cases import two_bodies_problem

    runs = []
    for comm in (MPI.COMM_WORLD, MPI.COMM_SELF):
        problem, _ = two_bodies_problem(dim=2, mesh_size=8.0, gap=1.0, along_axis=along_axis,
                                        comm=comm, mass="lumped", follow=False)  # fmt: skip
        runs.append(Simulation(problem, VerletScheme(), dt="auto", t_end=4.0).run())
    parallel, serial = runs
    assert serial["contact_force"].max() > 0
    for column in ("energy", "energy_theta", "contact_force", "penetration_max"):
        scale = np.abs(serial[column]).max()
        assert np.abs(parallel[column] - serial[column]).max() <= 1e-9 * scale, column


def test_the_coercivity_bound_is_gamma0_E_on_the_bar_and_sufficient_on_the_disk():
    """The cell-wise bound of docs/method.md section 12: exactly gamma0 E in 1D P1 (the
    contact node's stiffness out of contact is (1 - gamma0 E) E / h). On the P2 disk it is
    proportional to gamma0, and where it is below 1 the operator of the affine terms is
    positive semidefinite (dense eigenvalues of D^-1/2 K D^-1/2: its smallest over its
    largest is round-off, -8e-16, at gamma0 E = 0.09; the operator turns indefinite
    between 0.12 and 0.15, the bound reaches 1 at 0.098, measured)."""
    from nitsche_dolfinx.contact import coercivity_ratio
    from nitsche_dolfinx.output import assembled_matrix

    for gamma0 in (0.1, 0.5):
        assert coercivity_ratio(bar_problem(nx=20, gamma0=gamma0)) == pytest.approx(gamma0)
    assert coercivity_ratio(bar_problem(nx=20, gamma0=0.5, nitsche_theta=0.0)) == 0.0
    problem = impact_problem(dim=2, mesh_size=8.0, gamma0=0.09 / 50, mass="lumped",
                             comm=MPI.COMM_SELF)  # fmt: skip
    ratio = coercivity_ratio(problem)
    assert 0.9 < ratio < 1.0
    u, v = ufl.TrialFunction(problem.V), ufl.TestFunction(problem.V)
    affine = problem.bulk_stiffness(u, v) + problem.contacts[0].affine_terms(u, v)
    matrix = assembled_matrix(affine)  # held: the dense array is a view of its memory
    K = matrix.convert("dense").getDenseArray().copy()
    matrix.destroy()
    scale = 1.0 / np.sqrt(problem.mass_diagonal().array)
    values = np.linalg.eigvalsh(scale[:, None] * (K + K.T) / 2 * scale[None, :])
    assert values[0] >= -1e-9 * values[-1]  # LAPACK's round-off: 1e-9 of the largest


def test_beyond_the_coercivity_bound_a_run_says_so(capsys):
    """gamma0 E = 0.15 on the P2 disk (the bound 1.53): a note at the start, even quiet."""
    problem = impact_problem(dim=2, mesh_size=8.0, gamma0=3e-3, mass="lumped")
    simulation = Simulation(problem, VerletScheme(), dt="auto", t_end=0.5)
    simulation.run(columns=["t"])
    if MPI.COMM_WORLD.rank == 0:
        said = capsys.readouterr().err
        assert "gamma0 = 0.003 is beyond the coercivity bound of this mesh" in said
        assert "gamma0 below 0.00196 keeps A_Thgamma coercive" in said


def test_a_slow_growth_stops_when_the_energy_has_drifted_a_hundredfold(tmp_path):
    """dt 1.7 times the estimate on the bar (gamma0 = 0.1, forced): the energy grows by a
    few percent a step, which the window of 100 steps lets through; with nothing feeding
    the bar energy, the run stops once it has drifted by 100 times its initial 1/8 (at
    step 841, measured), its history kept."""
    simulation = Simulation(bar_problem(nx=100, gamma0=0.1, mass="lumped"),
                            VerletScheme(force_dt=True), dt=0.008, t_end=40.0)  # fmt: skip
    with pytest.raises(UnstableStep, match="the energy drifted by .* more than 100 times its"):
        simulation.run(out=str(tmp_path), columns=["t", "energy"])
    written = read_history(os.path.join(tmp_path, "history.csv"))
    assert 500 < len(written["t"]) < 5000 and np.isfinite(written["energy"]).all()
    assert abs(written["energy"][-1] - 0.125) > 100 * 0.125


@pytest.mark.mpi
def test_the_bar_on_ranks_is_the_bar_serially():
    """The bar on 2 ranks, its wall on one of them (the other holds no cell of Gamma_C),
    through two impacts: as serially to round-off (1e-9)."""
    columns = ["t", "energy", "energy_theta", "contact_force"]

    def run(comm):
        problem = bar_problem(nx=100, gamma0=0.5, mass="lumped", comm=comm)
        return Simulation(problem, VerletScheme(), dt="auto", t_end=4.0).run(columns=columns)

    parallel, serial = run(MPI.COMM_WORLD), run(MPI.COMM_SELF)
    assert serial["contact_force"].max() > 0
    for name in columns[1:]:
        scale = np.abs(serial[name]).max()
        assert np.abs(parallel[name] - serial[name]).max() <= 1e-9 * scale, name
