# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
#       format_version: '1.5'
# ---

# # The bouncing bar: dynamic contact by Nitsche's method in 1D
#
# The one-dimensional test of Chouly, Hild & Renard, "A Nitsche finite element
# method for dynamic contact" (M2AN 49, 2015): an elastic bar, clamped at one end
# and compressed, is released from rest at a distance 1/2 from a rigid wall; it
# hits the wall, stays on it for a while, bounces back, and does so again and
# again. The exact solution is known, so we see what each time scheme does to the
# displacement, the velocity, the contact pressure and the energy.
#
# It shows how to
#
# - build the bar's `ContactProblem` and `Simulation` (`nitsche_dolfinx.cases.one_body`);
# - run it with `Simulation.run`, with checkpoints and restarts, and with the
#   hybrid, theta, Newmark or Crank-Nicolson scheme, the penalty or the mixed
#   method, a lumped or redistributed mass;
# - compare with the exact solution and with Crank-Nicolson.
#
# `demos/bar_loop_1d.py` writes the same run's time loop out, step by step.
#
# ## Equation and problem definition
#
# On $\Omega = (0, 1)$, with $E = \rho = 1$ and no load, find $u(t, x)$ with
#
# $$
# \begin{align}
# \ddot u - u_{xx} &= 0 && \text{in } (0, T) \times (0, 1), \\
# u(t, 1) &= 0, \\
# u_n \le 0, \quad \sigma_n(u) \le 0, \quad u_n\, \sigma_n(u) &= 0 && \text{at } x = 0, \\
# u(0, x) = \tfrac12 - \tfrac x2, \quad \dot u(0, x) &= 0,
# \end{align}
# $$
#
# where $u_n = -u(t, 0)$ and $\sigma_n(u) = u_x(t, 0)$. The exact solution has
# period 3 and energy $1/8$: with $s = t \bmod 3$, the end $x = 0$ flies to the
# wall with speed $1/2$ for $0 \le s \le 1$, stays on it with the pressure $-1/2$
# for $1 \le s \le 2$, and leaves it with speed $1/2$ for $2 \le s \le 3$.
# Nitsche's method writes the contact conditions as the term
# $\int_{\Gamma_C} \frac{1}{\gamma_h}[P_\gamma(u_h)]_+ P_{\Theta\gamma}(v_h)$,
# $P_\gamma(u) = u_n - g - \gamma_h \sigma_n(u)$, $\gamma_h = \gamma_0 h_T$; with
# $\Theta = 1$ the hybrid scheme never increases the energy $E_\Theta^h$
# (docs/method.md sections 2 to 4). The defaults are the talk's: $\Theta = 1$,
# $\gamma_0 = 10^{-6}$, 100 P1 cells, $\tau = 0.015$, $T = 6$; what they give is
# in `docs/results.md`.

# +
import argparse
import os

from mpi4py import MPI

from nitsche_dolfinx.cases import BAR_COLUMNS
from nitsche_dolfinx.cases import one_body as cases
from nitsche_dolfinx.cli import (
    add_mass_argument,
    add_method_arguments,
    add_run_arguments,
    add_terminal_arguments,
    check_output_folder,
    method_parameters,
    one_line_errors,
    scheme_from_arguments,
    step_taken,
)
from nitsche_dolfinx.common import CONTACT_METHODS, require
from nitsche_dolfinx.output import has_checkpoint
from nitsche_dolfinx.post import bar_figure, bar_summary, figure_title, written_to

# Names of the schemes in the figure and the summary
SCHEME_LABELS = {"hybrid": "hybrid", "cn": "Crank-Nicolson"}
# -

# ### Command line
#
# Every parameter is a flag. `--method` also offers the penalty method and the
# mixed method (a Lagrange multiplier, Crank-Nicolson only), `--mass` the lumped
# and the redistributed (modified) mass of Khenous, Laborde & Renard.


def make_parser() -> argparse.ArgumentParser:
    """The command-line parser of the demo (flags of docs/method.md section 6)."""
    parser = argparse.ArgumentParser(
        description="1D bouncing bar: dynamic contact by Nitsche's method.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    parser.add_argument(
        "--method", choices=CONTACT_METHODS, default="nitsche",
        help="contact method (mixed: Lagrange multiplier, with --scheme cn)",
    )  # fmt: skip
    add_mass_argument(parser)
    add_method_arguments(parser, gamma0=1e-6, degree=1, dt=0.015, t_end=6.0, explicit_gamma0=0.5)
    parser.add_argument("--nx", type=int, default=100, help="number of cells")
    parser.add_argument("--out", default=os.path.join("out", "bar_1d"), help="output folder")
    add_run_arguments(parser)
    add_terminal_arguments(parser)
    parser.add_argument(
        "--compare", action=argparse.BooleanOptionalAction, default=True,
        help="also run Nitsche + Crank-Nicolson (into OUT/cn) for comparison",
    )  # fmt: skip
    return parser


# ### The problem, and a run
#
# `cases.bar_simulation` builds the `ContactProblem` on $(0, 1)$: `Material(E=1,
# nu=0, rho=1)`, `add_dirichlet(BAR_CLAMPED, 0.0)` at $x = 1$,
# `add_obstacle(PlaneObstacle([0.0], [1.0]), BAR_CONTACT)` at $x = 0$,
# `set_initial_conditions` with $u_0$; then the `Simulation` and three probes
# (`BoundaryAverage`) of $u$, $\dot u$ and $\lambda_h$ at $x = 0$.
# `Simulation.run` writes one row of `history.csv` per time level, $t = 0$
# included, and returns the rows as a `History`. It is the time loop of
# `demos/bar_loop_1d.py` (the same history, to the bit) with step cutting when
# Newton fails, checkpoints, restarts and clean stops on SIGINT/SIGTERM.


def run(args: argparse.Namespace, scheme: str, out: str, method: str, main: bool = True):
    """Run the bar with ``scheme`` and ``method``, writing ``out/history.csv`` (the main
    run: with its progress and fields, as the flags ask); its History and label."""
    sim = cases.bar_simulation(
        scheme_from_arguments(args, scheme), method=method, mass=args.mass, dt=args.dt,
        t_end=args.t_end, nx=args.nx, degree=args.degree, gamma0=args.gamma0,
        nitsche_theta=args.nitsche_theta, gamma0_scaling=args.gamma0_scaling,
        max_step_cuts=args.max_step_cuts,
    )  # fmt: skip
    sim.progress = main and not args.quiet
    if main:  # its step (--dt auto: the verlet scheme's) is the comparison's, the summary's
        args.dt = step_taken(sim, args.quiet)
    restart = args.restart and (out == args.out or has_checkpoint(os.path.join(out, "checkpoint")))
    history = sim.run(
        out=out, columns=BAR_COLUMNS, output_every=args.output_every if main else 0,
        checkpoint_every=args.checkpoint_every, restart=restart,
    )  # fmt: skip
    label = SCHEME_LABELS.get(scheme, sim.scheme.describe())
    mass = "" if args.mass == "consistent" else f", {args.mass} mass"
    return history, f"{method.capitalize()} + {label}{mass}"


# ### Main
#
# The main run uses the chosen scheme; unless it is Crank-Nicolson, Nitsche +
# Crank-Nicolson runs with the same parameters and the main run's step into `OUT/cn`
# (with `--scheme verlet`, `--dt` is by default `auto`: the estimated stable step's
# share, printed at the start with the number of steps). A bad flag stops the
# demo with one line naming it before anything is computed (exit status 2); a
# Newton failure or SIGINT/SIGTERM stops it after the last complete step, saved in
# `OUT/checkpoint` (also every `--checkpoint-every K` steps); `--restart` goes on.


def check_arguments(args: argparse.Namespace) -> None:
    """Every flag in range and the output folder writable, before any computing."""
    method_parameters(args)
    require(args.nx >= 1, "nx", args.nx, "the bar needs at least one cell")
    check_output_folder(args.out)


def main(argv: list[str] | None = None) -> None:
    """Run the demo with the command-line arguments ``argv``."""
    parser = make_parser()
    args = parser.parse_args(argv)
    outs = [args.out]
    with one_line_errors(parser):
        check_arguments(args)
        runs = [run(args, args.scheme, args.out, args.method)]
        if args.compare and (args.scheme, args.method) != ("cn", "nitsche"):
            outs.append(os.path.join(args.out, "cn"))
            runs.append(run(args, "cn", outs[1], "nitsche", main=False))
    if MPI.COMM_WORLD.rank != 0:
        return

    # ### The result
    #
    # One line per run: the $\ell^2(0, T)$ error of $u_h(t, 0)$, the energy change,
    # the largest one-step increase of $E_\Theta^h$ and the Newton iterations; then the
    # four panels of the talk, $u_h$, $\dot u_h$ and $\lambda_h$ at $x = 0$ and the
    # energy, each over the exact solution (matplotlib is optional).
    histories, labels = zip(*runs)
    bar_summary(histories, labels, args.dt)
    print(written_to(args.out, args.output_every, outs))
    if not args.no_plot:
        title = figure_title(
            "1D bouncing bar", args.nitsche_theta, args.gamma0, args.degree, 1 / args.nx, args.dt
        )
        bar_figure(histories, labels, title, os.path.join(args.out, "bar_1d.png"), args.t_end)


if __name__ == "__main__":
    main()
