"""Rayleigh damping C = alpha M + beta K (docs/method.md section 14): the first mode of a
clamped bar decays at the Rayleigh rate, the damping column accounts for the energy lost
(without and with contact), the explicit scheme's rate and stable step, restarts, ranks
and refusals."""

import os
import signal
import textwrap

import numpy as np
import pytest
from mpi4py import MPI

from nitsche_dolfinx import ContactProblem, Material, ParameterError, Simulation, read_history
from nitsche_dolfinx.cases import bar_problem, block_problem
from nitsche_dolfinx.common import RunInterrupted
from nitsche_dolfinx.config import ConfigError, build_simulation, history_columns, load_config
from nitsche_dolfinx.meshing import BAR_CLAMPED, bar_mesh
from nitsche_dolfinx.solvers import choose_linear_solver
from nitsche_dolfinx.steppers import UnstableStep, VerletScheme, make_scheme

COLUMNS = ["t", "energy", "energy_theta", "damping_dissipation", "energy_balance_residual"]
#: The first mode of the bar (0, 1) clamped at x = 1, free at x = 0 (E = rho = 1):
#: u = cos(pi x / 2), omega = pi / 2. The rates are compared with this omega: the P1 mesh
#: of 50 cells has the discrete omega_h = omega (1 +- (omega h)^2 / 24) = omega (1 +-
#: 4.1e-5) with the consistent (+) and lumped (-) mass, far below the 1%.
OMEGA = np.pi / 2
#: (alpha, beta): mass damping only, stiffness damping only, both; each a modal ratio
#: zeta of about 0.03 (the energy falls to about 0.3 over the 12 time units of a run).
COEFFICIENTS = {"alpha": (0.1, 0.0), "beta": (0.0, 0.04), "both": (0.05, 0.02)}


def rayleigh_ratio(alpha, beta, omega=OMEGA):
    """zeta = alpha / (2 omega) + beta omega / 2."""
    return alpha / (2 * omega) + beta * omega / 2


def clamped_bar(alpha, beta, nx=50, mass="consistent", comm=MPI.COMM_WORLD):
    """The bar (0, 1) clamped at x = 1, no contact, started in its first mode at rest."""
    mesh, tags = bar_mesh(nx, comm=comm)
    problem = ContactProblem(mesh, tags, Material(E=1.0, nu=0.0, rho=1.0), mass=mass)
    problem.add_dirichlet(BAR_CLAMPED, 0.0)
    problem.set_initial_conditions(displacement=lambda x: 0.01 * np.cos(OMEGA * x[0]))
    problem.set_damping(alpha=alpha, beta=beta)
    return problem


def measured_ratio(history, zeta):
    """The modal damping ratio that the energy's decay shows. For a damped mode, q(t) =
    exp(-zeta omega t) times a function of period T_d = 2 pi / omega_d, omega_d = omega
    sqrt(1 - zeta^2), so E(t) exp(2 zeta omega t) has the period T_d / 2 (E is quadratic in
    (q, q')): E at the last whole half period against E(0) gives zeta exactly. E there is
    interpolated linearly between levels: its relative error (omega tau)^2 zeta / 2 is
    below 1e-5 for the steps taken here."""
    t, energy = history["t"], history["energy"]
    half_period = np.pi / (OMEGA * np.sqrt(1 - zeta**2))
    t_k = np.floor(t[-1] / half_period) * half_period
    return np.log(energy[0] / np.interp(t_k, t, energy)) / (2 * OMEGA * t_k)


@pytest.mark.parametrize("case", COEFFICIENTS)
@pytest.mark.parametrize("scheme, mass", [("hybrid", "consistent"), ("cn", "lumped")])
def test_first_mode_decays_at_the_rayleigh_rate(scheme, mass, case):
    """The issue's acceptance: zeta = alpha / (2 omega) + beta omega / 2 within 1%. The
    hybrid and Crank-Nicolson schemes add no numerical damping of their own (the
    trapezoidal rule of the damped oscillator decays at the exact rate up to O((omega
    tau)^2) = 6e-4 here, relative): measured 1.2e-4 to 2.1e-4."""
    alpha, beta = COEFFICIENTS[case]
    zeta = rayleigh_ratio(alpha, beta)
    problem = clamped_bar(alpha, beta, mass=mass)
    history = Simulation(problem, make_scheme(scheme), dt=0.02, t_end=12.0).run(columns=COLUMNS)
    assert measured_ratio(history, zeta) == pytest.approx(zeta, rel=0.01)


@pytest.mark.parametrize(
    "scheme, mass",
    [("hybrid", "consistent"), ("cn", "lumped"), ("newmark", "consistent")],
)
def test_damping_column_accounts_for_the_energy_lost(scheme, mass):
    """Without contact the hybrid and CN schemes (Newmark's default (1/4, 1/2) is CN) keep
    E + damping_dissipation = E(0): the column is the steps' tau (v_m, C v_m), which the
    identity of docs/method.md section 14 says the energy loses. The run ends with a
    shorter step (12.01: a step of 0.01), whose damped diagonal mass (the lumped CN run)
    the solver sets again. The identity holds for any solution of the steps; the steps
    are linear here, solved in one Newton step by a direct solve (the solver's relative
    tolerance, 1e-10, would bound each step's error by 1e-10 of its forces' work): 1e-10
    of E(0) over the 600 steps is that tolerance. Measured: 8.6e-14. Compared to 1e-9 of
    E(0): sums of processor-dependent round-off."""
    alpha, beta = COEFFICIENTS["both"]
    problem = clamped_bar(alpha, beta, mass=mass)
    history = Simulation(problem, make_scheme(scheme), dt=0.02, t_end=12.01).run(columns=COLUMNS)
    assert history["t"][-1] - history["t"][-2] == pytest.approx(0.01)
    energy, dissipated = history["energy"], history["damping_dissipation"]
    assert dissipated[-1] > 0.5 * energy[0]  # most of the energy went
    assert np.abs(energy + dissipated - energy[0]).max() < 1e-9 * energy[0]
    # each step's share is in the balance column: E_Theta^{n+1} - E_Theta^n + D^n = 0
    assert np.abs(history["energy_balance_residual"]).max() < 1e-9 * energy[0]


@pytest.mark.parametrize("case", COEFFICIENTS)
def test_hybrid_with_contact_never_increases_energy_theta_plus_dissipation(case):
    """The bar of docs/method.md section 5 hitting the wall (hybrid, Theta = 1): E_Theta +
    damping_dissipation never rises (docs/method.md section 14: damping adds -tau (v_m, C
    v_m) to the identity of section 4, whose contact switches only dissipate); a rise of
    round-off only, 1e-9 of E_Theta(0) (measured 4e-14), through 130 to 170 steps in
    contact, and the contact switches dissipate too (it falls by more than the column)."""
    problem = bar_problem(nx=50, gamma0=1e-3)
    problem.set_damping(*COEFFICIENTS[case])
    history = Simulation(problem, make_scheme("hybrid"), dt=0.01, t_end=6.0).run(
        columns=[*COLUMNS, "contact_force"]
    )
    kept = history["energy_theta"] + history["damping_dissipation"]
    assert (history["contact_force"] > 0).sum() > 100
    assert np.diff(kept).max() < 1e-9 * kept[0]  # round-off of different levels
    assert kept[-1] < kept[0] - 1e-3 * kept[0]
    assert history["damping_dissipation"][-1] > 0.1 * kept[0]


def test_friction_and_damping_share_the_balance():
    """The block sliding with friction on the plane (hybrid, Theta = 1), damped: both
    dissipations enter energy_balance_residual = E_Theta^{n+1} - E_Theta^n + D^n + D_d^n,
    which stays within the guarded Newton's tolerance, 1e-8 of E(0) (as without damping,
    tests/test_friction.py; measured 1.5e-10), while damping takes a share of the energy
    comparable to friction's."""
    problem = block_problem(friction=0.2, v0=1.0)
    problem.set_damping(alpha=0.2, beta=1e-3)
    history = Simulation(problem, make_scheme("hybrid"), dt=0.05, t_end=1.0).run(
        columns=[*COLUMNS, "friction_dissipation"]
    )
    energy = history["energy"][0]
    assert history["damping_dissipation"][-1] > 0.1 * history["friction_dissipation"].sum()
    assert np.abs(history["energy_balance_residual"]).max() < 1e-8 * energy


@pytest.mark.parametrize("case", COEFFICIENTS)
def test_verlet_decays_at_the_rayleigh_rate(case):
    """The explicit scheme (lumped mass; alpha M at v^{n+1}, beta K at v^{n+1/2}) at tau =
    0.002, below half of its stable step with the strongest beta (0.0047): zeta within 1%
    (measured 8e-6 to 4e-5: the half-step lag of beta K v changes the rate at second
    order). Its E + damping_dissipation stays within (omega tau)^2 E(0) = 1e-5 of E(0)
    (measured 4.1e-6):
    the column is exactly the damping's share of the kinetic energy's change, and the
    scheme keeps its shadow energy, not E, which differs by tau^2/8 |a|_M^2 <= (omega
    tau)^2/4 E for this mode."""
    alpha, beta = COEFFICIENTS[case]
    zeta = rayleigh_ratio(alpha, beta)
    problem = clamped_bar(alpha, beta, mass="lumped")
    simulation = Simulation(problem, VerletScheme(), dt=0.002, t_end=12.0)
    assert simulation.stepper.stable_dt > 4 * 0.002 / 2
    history = simulation.run(columns=COLUMNS)
    assert measured_ratio(history, zeta) == pytest.approx(zeta, rel=0.01)
    energy, dissipated = history["energy"], history["damping_dissipation"]
    assert np.abs(energy + dissipated - energy[0]).max() < (OMEGA * 0.002) ** 2 * energy[0]


def test_verlet_auto_step_is_stable_with_strong_stiffness_damping():
    """beta = 0.5 on 50 cells: the highest mode (omega_max tau about 2 at the undamped
    step) has the modal ratio xi = beta omega_max / 2 = 50, and the central difference
    needs omega_max tau <= 2 (sqrt(1 + xi^2) - xi), about 1 / xi (docs/method.md section
    14): the automatic step shrinks 50-fold and the energy only falls; the undamped
    automatic step blows up within its first 200 steps."""
    undamped = Simulation(clamped_bar(0.0, 0.0, mass="lumped"), VerletScheme(), "auto", 1.0)
    damped = Simulation(clamped_bar(0.0, 0.5, mass="lumped"), VerletScheme(), "auto", 1.0)
    # omega_max tau <= 2 (sqrt(1 + xi^2) - xi) with omega_max = 2 / stable_dt (undamped)
    omega_max = 2 / undamped.stepper.stable_dt
    xi = 0.5 * omega_max / 2
    expected = 2 * (np.sqrt(1 + xi**2) - xi) / omega_max
    assert damped.stepper.stable_dt == pytest.approx(expected, rel=1e-6)
    assert damped.stepper.dt < undamped.stepper.dt / 40
    history = damped.run(columns=COLUMNS)
    assert np.all(np.isfinite(history["energy"]))
    # it falls, up to the round-off of two levels' energies: 1e-9 of E(0)
    assert np.diff(history["energy"]).max() <= 1e-9 * history["energy"][0]
    assert history["energy"][-1] < 0.95 * history["energy"][0]
    forced = Simulation(
        clamped_bar(0.0, 0.5, mass="lumped"), VerletScheme(force_dt=True),
        undamped.stepper.dt, 1.0,
    )  # fmt: skip
    with pytest.raises(UnstableStep):
        forced.run(columns=COLUMNS)


def damped_bar(scheme, comm=MPI.COMM_WORLD):
    """The bar hitting the wall with both dampings: hybrid, or verlet on the lumped mass."""
    if scheme == "verlet":
        problem = bar_problem(nx=50, gamma0=0.5, mass="lumped", comm=comm)
        problem.set_damping(*COEFFICIENTS["both"])
        return Simulation(problem, VerletScheme(), dt="auto", t_end=3.0)
    problem = bar_problem(nx=50, gamma0=1e-3, comm=comm)
    problem.set_damping(*COEFFICIENTS["both"])
    return Simulation(problem, make_scheme("hybrid"), dt=0.02, t_end=3.0)


@pytest.mark.parametrize("scheme", ["hybrid", "verlet"])
def test_an_interrupted_damped_run_restarts_to_the_bit(tmp_path, scheme):
    """SIGTERM in the middle of the run, then a restart: the uninterrupted history, the
    cumulative damping_dissipation included, to the bit (the running total is saved with
    the clock; the explicit scheme's level force is computed from the level's arrays)."""
    straight = damped_bar(scheme).run(out=str(tmp_path / "straight"), columns=COLUMNS)
    stop_at = len(straight["t"]) // 2

    def stop(simulation):
        if simulation.step_index == stop_at:
            os.kill(os.getpid(), signal.SIGTERM)

    out = str(tmp_path / "run")
    with pytest.raises(RunInterrupted):
        damped_bar(scheme).run(out=out, columns=COLUMNS, callback=stop)
    damped_bar(scheme).run(out=out, columns=COLUMNS, restart=True)
    written = read_history(os.path.join(out, "history.csv"))
    assert straight["damping_dissipation"][stop_at] > 0
    for name in COLUMNS:
        if name == "energy_balance_residual":  # 0 at the first level of a run (the restart)
            continue
        assert np.array_equal(written[name], straight[name]), name


@pytest.mark.mpi
@pytest.mark.parametrize("scheme", ["hybrid", "verlet"])
def test_ranks_give_the_serial_history(scheme):
    """The damped bar with contact on every rank of the communicator and on this rank alone:
    the same history to 1e-9 of each column's largest value (the sums' order differs), the
    balance residual, a difference of energies, to 1e-9 of the energy."""
    history = damped_bar(scheme).run(columns=COLUMNS)
    serial = damped_bar(scheme, MPI.COMM_SELF).run(columns=COLUMNS)
    assert np.array_equal(history["t"], serial["t"])
    for name in COLUMNS[1:]:
        of = "energy_theta" if name == "energy_balance_residual" else name
        scale = np.abs(serial[of]).max()
        assert np.abs(history[name] - serial[name]).max() <= 1e-9 * scale, name


@pytest.mark.parametrize(
    "keywords, refused",
    [
        ({"alpha": -1.0}, "damping_alpha=-1.0: the damping coefficient alpha must be >= 0"),
        ({"beta": "0.1"}, "damping_beta='0.1': the damping coefficient beta must be a number"),
        ({"alpha": float("nan")}, "damping_alpha=nan: the damping coefficient alpha must be "
                                  "finite"),
        ({"beta": True}, "damping_beta=True: the damping coefficient beta must be a number"),
    ],
)  # fmt: skip
def test_bad_coefficients_are_refused_in_the_api(keywords, refused):
    problem = clamped_bar(0.0, 0.0, nx=4)
    with pytest.raises(ParameterError, match=refused) as caught:
        problem.set_damping(**keywords)
    assert "\n" not in str(caught.value)


TOML = """
    [mesh]
    generator = "bar"
    nx = 10

    [material]
    E = 1.0
    nu = 0.0

    [scheme]
    name = "cn"
    dt = 0.1
    t_end = 0.6

    [[dirichlet]]
    tag = 2
    value = [0.0]

    [initial]
    velocity = [1.0]

    [damping]
"""


def configured(tmp_path, damping: str):
    path = tmp_path / "damped.toml"
    path.write_text(textwrap.dedent(TOML) + damping + "\n")
    config = load_config(str(path))
    return config, build_simulation(config, progress=False, source="damped.toml")


@pytest.mark.parametrize(
    "damping, refused",
    [
        ("alpha = -1.0", "[damping] alpha = -1.0: the damping coefficient alpha must be >= 0"),
        ('alpha = "x"', "[damping] alpha must be a number"),
        ("beta = nan", "[damping] beta = nan: the damping coefficient beta must be finite"),
        ("beta = -inf", "[damping] beta = -inf: the damping coefficient beta must be finite"),
        ("gamma = 1.0", "[damping] unknown key 'gamma'"),
    ],
)
def test_bad_coefficients_are_refused_in_toml(tmp_path, damping, refused):
    with pytest.raises(ConfigError) as caught:
        configured(tmp_path, damping)
    assert refused in str(caught.value)
    assert "\n" not in str(caught.value)


def test_toml_damping_is_the_api_s(tmp_path):
    """[damping] alpha, beta give the API's run, the column among the default ones."""
    config, simulation = configured(tmp_path, "alpha = 0.5\nbeta = 0.01")
    columns = history_columns(config, simulation)
    assert "damping_dissipation" in columns
    from_toml = simulation.run(columns=columns)
    mesh, tags = bar_mesh(10)
    problem = ContactProblem(mesh, tags, Material(E=1.0, nu=0.0))
    problem.add_dirichlet(BAR_CLAMPED, [0.0])
    problem.set_initial_conditions(velocity=[1.0])
    problem.set_damping(alpha=0.5, beta=0.01)
    from_api = Simulation(problem, make_scheme("cn"), dt=0.1, t_end=0.6).run(columns=columns)
    for name in ("energy", "damping_dissipation"):  # the same problem twice: bitwise
        assert np.array_equal(from_toml[name], from_api[name]), name
    assert from_api["damping_dissipation"][-1] > 0.1 * from_api["energy"][0]


def test_stiffness_damping_counts_in_the_choice_of_the_linear_solver():
    """The step's Jacobian weighs K by tau^2 + 2 beta tau (CN, hybrid): "auto" takes
    cg-jacobi only while the mass dominates that Jacobian (Courant number sqrt(tau^2 + 2
    beta tau) c / h at most 1; here 0.5 undamped, 2.3 with beta = 0.1)."""
    assert choose_linear_solver(clamped_bar(0.0, 0.0), 0.01) == "cg-jacobi"
    assert choose_linear_solver(clamped_bar(1.0, 0.0), 0.01) == "cg-jacobi"
    assert choose_linear_solver(clamped_bar(0.0, 0.1), 0.01) == "lu"


def test_no_damping_writes_no_term_and_no_column():
    """Without set_damping the problem has no damping term (the compiled forms and the
    histories of undamped runs are those of before) and no damping_dissipation column."""
    problem = bar_problem(nx=10)
    assert problem.damping is None and problem.damping_force(problem.x, problem.x) is None
    simulation = Simulation(problem, make_scheme("hybrid"), dt=0.1, t_end=0.2)
    assert "damping_dissipation" not in simulation.state()


def test_what_the_explicit_steps_cannot_damp_is_refused():
    """Stiffness damping with the redistributed mass (the massless nodes' equilibrium has
    no damping force) and damping with the mixed method are refused in one line."""
    problem = bar_problem(nx=10, gamma0=0.5, mass="redistributed")
    problem.set_damping(beta=0.01)
    with pytest.raises(ParameterError, match="damping_beta=0.01: the verlet scheme takes"):
        Simulation(problem, VerletScheme(), dt="auto", t_end=0.1)
    with pytest.raises(ParameterError, match="method='mixed': damping is for Nitsche"):
        bar_problem(nx=10, method="mixed").set_damping(alpha=0.1)
