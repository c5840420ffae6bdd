# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
#       format_version: '1.5'
# ---

# # The bouncing bar, step by step: the time loop written out
#
# The bar of `demos/bar_1d.py`, the 1D test of Chouly, Hild & Renard, "A Nitsche
# finite element method for dynamic contact" (M2AN 49, 2015): an elastic bar on
# $(0, 1)$, clamped at $x = 1$ and compressed, is released from rest at a distance
# $1/2$ from a rigid wall at $x = 0$, hits it, stays on it for a while, bounces
# back, and does so again and again. `bar_1d.py` runs it with one call,
# `Simulation.run`; here the time loop is written out, as in the dolfinx demos:
# one step, the diagnostics of the new time level, a row of `history.csv`, and
# every few steps the fields for ParaView.
#
# It shows how to
#
# - build the problem and a `Simulation` (scheme, $\tau$, $T$) with probes at $x = 0$;
# - march it with `Simulation.step()` until `Simulation.finished`;
# - read a time level: `Simulation.state()` (energies, contact force, probes, the
#   same numbers on every rank), `Simulation.t`, `Simulation.u`, `Simulation.v`;
# - write the history with `HistoryWriter` and the fields with `SolutionWriter`;
# - do all of it with the shortcut `Simulation.run` (`--run`): the same history,
#   to the bit (`tests/test_demos.py` checks it, serially and on two ranks).
#
# The contact is Nitsche's: the term
# $\int_{\Gamma_C} \frac{1}{\gamma_h}[P_\gamma(u_h)]_+ P_{\Theta\gamma}(v_h)$ with
# $P_\gamma(u) = u_n - g - \gamma_h \sigma_n(u)$, $\gamma_h = \gamma_0 h_T$, and the
# hybrid scheme by default (docs/method.md sections 2 to 4). The defaults are the
# talk's: $\Theta = 1$, $\gamma_0 = 10^{-6}$, 100 P1 cells, $\tau = 0.015$, $T = 6$.

# +
import argparse
import os

from mpi4py import MPI

from nitsche_dolfinx import History, Simulation
from nitsche_dolfinx.cases import bar_contact_errors
from nitsche_dolfinx.cases import one_body as cases
from nitsche_dolfinx.cli import (
    add_method_arguments,
    add_terminal_arguments,
    check_output_folder,
    method_parameters,
    one_line_errors,
    scheme_from_arguments,
    scheme_mass,
    step_taken,
)
from nitsche_dolfinx.common import require
from nitsche_dolfinx.output import HistoryWriter, SolutionWriter
from nitsche_dolfinx.post import bar_figure, figure_title, written_to

# -

# ## Parameters
#
# Every parameter is a flag (`--help`); each is checked before anything is
# computed, and a bad one stops the demo with one line naming it.

parser = argparse.ArgumentParser(
    description="1D bouncing bar, the time loop written out.",
    formatter_class=argparse.ArgumentDefaultsHelpFormatter,
)
add_method_arguments(parser, gamma0=1e-6, degree=1, dt=0.015, t_end=6.0, explicit_gamma0=0.5)
parser.add_argument("--nx", type=int, default=100, help="number of cells")
parser.add_argument("--out", default=os.path.join("out", "bar_loop_1d"), help="output folder")
add_terminal_arguments(parser)  # --output-every N (the fields every N steps), --quiet
parser.add_argument("--run", action="store_true", help="Simulation.run instead of the loop")
args = parser.parse_args()
comm = MPI.COMM_WORLD

# ## The problem
#
# `cases.bar_problem` is a `ContactProblem` on $(0, 1)$ with
# `Material(E=1, nu=0, rho=1)`, `add_dirichlet(BAR_CLAMPED, 0.0)` at $x = 1$,
# `add_obstacle(PlaneObstacle([0.0], [1.0]), BAR_CONTACT)` at $x = 0$ and
# `set_initial_conditions(displacement=lambda x: 0.5 - x[0] / 2)`. The
# `Simulation` holds the time levels; `cases.add_bar_probes` adds to its state the
# displacement, the velocity and the contact pressure $\lambda_h$ at $x = 0$. With
# `--scheme verlet` (explicit, lumped mass), `--dt auto` is the scheme's share of the
# stable step it estimates: `simulation.dt`, printed with the number of steps.

with one_line_errors(parser):
    method_parameters(args)
    require(args.nx >= 1, "nx", args.nx, "the bar needs at least one cell")
    check_output_folder(args.out)
    problem = cases.bar_problem(
        nx=args.nx, degree=args.degree, gamma0=args.gamma0,
        nitsche_theta=args.nitsche_theta, gamma0_scaling=args.gamma0_scaling,
        mass=scheme_mass(args),
    )  # fmt: skip
    simulation = Simulation(
        problem, scheme_from_arguments(args), dt=args.dt, t_end=args.t_end,
        max_step_cuts=args.max_step_cuts,
    )  # fmt: skip
    cases.add_bar_probes(simulation)
    args.dt = step_taken(simulation, args.quiet)  # --dt auto: the verlet scheme's step

# ## The time loop
#
# The initial time level is the first row. Each `step()` solves one nonlinear
# problem (a semismooth Newton method) and moves `u`, `v`, `a` and `t` to the new
# level. `state()` is collective: every rank calls it, and gets the same numbers
# (energies, contact force, the probes; `simulation.u` and `simulation.v` are the
# Functions themselves). The history is written by rank 0, the fields by every
# rank together (the contact fields, pressure, gap and status, are projected onto
# $\Gamma_C$ for the levels written).

columns = cases.BAR_COLUMNS  # t, u_contact, v_contact, sigma_contact, energy, ...
with one_line_errors(parser):
    if args.run:  # the shortcut, which also cuts failed steps, checkpoints and restarts
        history = simulation.run(out=args.out, columns=columns, output_every=args.output_every)
    else:
        history = History()
        writer = HistoryWriter(os.path.join(args.out, "history.csv"), columns, comm)
        fields = None
        if args.output_every > 0:
            path = os.path.join(args.out, "solution.xdmf")
            fields = SolutionWriter(path, problem.mesh, simulation.output_fields())

        history.append(simulation.state())  # the level t = 0
        writer.write(history[-1])
        if fields is not None:
            fields.write(simulation.t)
        while not simulation.finished:
            simulation.step()
            row = simulation.state()
            history.append(row)
            writer.write(row)
            if fields is not None and simulation.step_index % args.output_every == 0:
                fields.write(simulation.t)
            if not args.quiet and comm.rank == 0 and simulation.step_index % 50 == 0:
                print(f"t = {simulation.t:7.3f}  u(t, 0) = {row['u_contact']:+.4f}  "
                      f"E = {row['energy']:.6f}  Newton {row['newton_iterations']}")  # fmt: skip
        writer.close()
        if fields is not None:
            fields.close()

# ## The result
#
# The exact solution at $x = 0$: flight with speed $1/2$ for $0 \le s \le 1$
# ($s = t \bmod 3$), on the wall with the pressure $-1/2$ for $1 \le s \le 2$,
# release for $2 \le s \le 3$; energy $1/8$. The hybrid scheme loses energy at
# the impacts only, and $E_\Theta^h$ never rises (docs/results.md).

if comm.rank == 0:
    error = bar_contact_errors(history, args.dt)["error_u_contact"]
    print(f"{len(history) - 1} steps; l2(0, T) error of u(t, 0): {error:.4e}; "
          f"E(T)/E(0) - 1 = {history.energy_drift():+.3%}; "
          f"largest one-step rise of E_Theta: {history.largest_rise():.2e}")  # fmt: skip
    print(written_to(args.out, args.output_every))
    if not args.no_plot:
        label = f"Nitsche + {simulation.scheme.describe()}"
        title = figure_title(
            "1D bouncing bar, step by step", args.nitsche_theta, args.gamma0, dt=args.dt
        )
        bar_figure([history], [label], title, os.path.join(args.out, "bar_loop_1d.png"), args.t_end)
