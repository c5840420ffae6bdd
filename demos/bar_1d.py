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
# This demo reproduces the one-dimensional test of Chouly, Hild & Renard,
# "A Nitsche finite element method for dynamic contact" (M2AN 49, 2015): an
# elastic bar, clamped at one end and compressed, is released from rest at a
# distance 1/2 from a rigid wall; it hits the wall, stays in contact with it
# for a while, bounces back, and does so again and again.
# The exact solution is known, so we can see what each time scheme does to
# the displacement, the velocity, the contact pressure and the energy.
#
# It shows how to
#
# - build a `ContactProblem`: a material, a Dirichlet condition and a rigid
#   obstacle;
# - march it in time with the hybrid scheme (or the theta, Newmark or
#   Crank-Nicolson schemes) with a `Simulation`;
# - record values at the contact point with `BoundaryAverage` probes and
#   write them to `history.csv`;
# - compare with the exact solution and with Crank-Nicolson.
#
# ## Equation and problem definition
#
# On $\Omega = (0, 1)$, with Young's modulus $E = 1$, density $\rho = 1$ and
# no load, find $u(t, x)$ such that
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
# where $u_n = -u(t, 0)$ is the displacement towards the wall and
# $\sigma_n(u) = u_x(t, 0)$ the normal stress. The exact solution
# (Dabaghi, Petrov, Pousin & Renard 2014) has period 3 and energy $1/8$. With
# $s = t \bmod 3$, the end $x = 0$ flies towards the wall with speed $1/2$
# for $0 \le s \le 1$, stays on it with the pressure $\sigma_n = -1/2$ for
# $1 \le s \le 2$, and leaves it with speed $1/2$ for $2 \le s \le 3$.
#
# Nitsche's method puts the three contact conditions into the weak form as one
# term, $\int_{\Gamma_C} \frac{1}{\gamma_h}[P_\gamma(u_h)]_+ P_{\Theta\gamma}(v_h)$
# with $P_\gamma(u) = u_n - g - \gamma_h \sigma_n(u)$ and $\gamma_h = \gamma_0 h_T$
# (docs/method.md section 2). The hybrid scheme takes the bulk terms at the
# midpoint and switches the contact term per quadrature point; with $\Theta = 1$
# it never increases the energy $E_\Theta^h$ (docs/method.md sections 3 and 4).
#
# The defaults are the parameters of the talk's figures: $\Theta = 1$,
# $\gamma_0 = 10^{-6}$, 100 P1 elements, $\tau = 0.015$, $T = 6$. What the
# demo prints with them (the hybrid scheme loses 1 % at the impacts, Nitsche
# + Crank-Nicolson gains 7 %) is discussed in `docs/results.md`.
#
# ## Implementation
#
# The library does all the work; this script only sets up the problem and
# looks at the result.

# +
import argparse
import os

import numpy as np
from mpi4py import MPI

from nitsche_dolfinx import cases
from nitsche_dolfinx.arguments import (
    add_method_arguments,
    add_run_arguments,
    add_terminal_arguments,
    check_output_folder,
    method_parameters,
    scheme_from_arguments,
)
from nitsche_dolfinx.cases import BAR_COLUMNS as COLUMNS
from nitsche_dolfinx.checkpoint import has_checkpoint
from nitsche_dolfinx.errors import one_line_errors
from nitsche_dolfinx.exact import bar_contact_values
from nitsche_dolfinx.parameters import CONTACT_METHODS, MASS_MATRICES
from nitsche_dolfinx.plotting import bar_panels, latex_number, pyplot, save

# Names of the schemes in the figure and the summary
SCHEME_LABELS = {"hybrid": "hybrid", "cn": "Crank-Nicolson"}
# -

# ### Command line
#
# Every parameter of the method and of the scheme is a flag; the defaults are
# those of the talk. `--method` also offers the penalty method and the mixed
# method (a Lagrange multiplier, Crank-Nicolson only), and `--mass` the lumped
# and the redistributed (modified) mass of Khenous, Laborde & Renard.


def make_parser() -> argparse.ArgumentParser:
    """The command-line parser of the demo (flags of docs/method.md section 6)."""
    parser = argparse.ArgumentParser(
        description="1D bouncing bar: dynamic contact by Nitsche's method.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    parser.add_argument(
        "--method",
        choices=CONTACT_METHODS,
        default="nitsche",
        help="contact method (mixed: Lagrange multiplier, with --scheme cn)",
    )
    parser.add_argument("--mass", choices=MASS_MATRICES, default="consistent", help="mass matrix")
    add_method_arguments(parser, gamma0=1e-6, degree=1, dt=0.015, t_end=6.0)
    parser.add_argument("--nx", type=int, default=100, help="number of cells")
    parser.add_argument("--out", default=os.path.join("out", "bar_1d"), help="output folder")
    add_run_arguments(parser)
    add_terminal_arguments(parser)
    parser.add_argument("--no-plot", action="store_true", help="do not draw the figure")
    parser.add_argument(
        "--compare",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="also run Nitsche + Crank-Nicolson (into OUT/cn) for comparison",
    )
    return parser


# ### The problem
#
# The bar is the interval $(0, 1)$ with its end $x = 0$ tagged `BAR_CONTACT`
# and its end $x = 1$ tagged `BAR_CLAMPED`. In 1D, `nu = 0` makes the
# stress $\sigma(u) = E u_x$. The wall is the "plane" through $x = 0$ whose
# normal points to the admissible side, $x > 0$. The acceleration at $t = 0$
# is computed by the library from the equation, so only $u_0$ is given.
#
# Three probes record the values at $x = 0$: on a 1D mesh a boundary part is a
# single point, so the mean value over it is the point value. They are
# reduced over MPI, so every rank sees the same numbers.


def bar_simulation(args: argparse.Namespace, scheme_name: str, method: str):
    """The bar of docs/method.md section 5 with the parameters of ``args``: ``bar_mesh``,
    a ``ContactProblem`` with ``Material(E=1, nu=0, rho=1)``, ``add_dirichlet`` at
    ``BAR_CLAMPED``, ``add_obstacle(PlaneObstacle([0.0], [1.0]), BAR_CONTACT)``,
    ``set_initial_conditions``, then the scheme and the three probes at x = 0."""
    return cases.bar_simulation(
        scheme_from_arguments(args, scheme_name),
        method=method,
        mass=args.mass,
        dt=args.dt,
        t_end=args.t_end,
        nx=args.nx,
        degree=args.degree,
        gamma0=args.gamma0,
        nitsche_theta=args.nitsche_theta,
        gamma0_scaling=args.gamma0_scaling,
        max_step_cuts=args.max_step_cuts,
    )


# ### Running and measuring
#
# `Simulation.run` writes one row of `history.csv` per time level, $t = 0$
# included, and returns the same rows. From them we compute the numbers of
# the talk: the $\ell^2(0, T)$ error of the contact displacement,
# $\big(\sum_n \tau\, |u_h(t^n, 0) - u(t^n, 0)|^2\big)^{1/2}$, the relative
# energy change at $T$, the largest increase of $E_\Theta^h$ over one step
# (at most round-off for the hybrid scheme), and the mean number of Newton
# iterations per step.


def run(
    args: argparse.Namespace, scheme_name: str, out: str, method: str, main: bool = True
) -> dict:
    """Run the bar with the scheme ``scheme_name``, writing ``out/history.csv`` (the main
    run: with its progress and fields, as the flags ask).

    Returns:
        The run's ``label``, ``out`` and ``history`` (a :class:`History`).
    """
    sim = bar_simulation(args, scheme_name, method)
    sim.progress = main and not args.quiet
    restart = args.restart and (out == args.out or has_checkpoint(os.path.join(out, "checkpoint")))
    history = sim.run(
        out=out,
        columns=COLUMNS,
        output_every=args.output_every if main else 0,
        checkpoint_every=args.checkpoint_every,
        restart=restart,
    )
    label = SCHEME_LABELS.get(scheme_name, sim.scheme.describe())
    mass = "" if args.mass == "consistent" else f", {args.mass} mass"
    return {"label": f"{method.capitalize()} + {label}{mass}", "out": out, "history": history}


def measure(history, dt: float) -> dict:
    """Error, energy change, E_Theta increase and Newton iterations of one run."""
    u_exact, _, _ = bar_contact_values(history["t"])
    return {
        "error_u": np.sqrt(dt * np.sum((history["u_contact"] - u_exact) ** 2)),
        "energy_change": history.energy_drift(),
        "energy_theta_increase": np.max(np.diff(history["energy_theta"])),
        "newton_iterations": history.mean_newton_iterations(),
    }


def print_summary(results: list[dict], dt: float) -> None:
    """One line of numbers per run."""
    print(
        f"{'run':36s} {'l2 error u(.,0)':>16s} {'E(T)/E(0) - 1':>14s} "
        f"{'max step dE_Theta':>18s} {'Newton/step':>12s}"
    )
    for result in results:
        m = measure(result["history"], dt)
        print(
            f"{result['label']:36s} {m['error_u']:16.4e} {m['energy_change']:+14.3%} "
            f"{m['energy_theta_increase']:18.2e} {m['newton_iterations']:12.3f}"
        )
    print(
        "E(T) = " + ", ".join(f"{r['history'][-1]['energy']:.5f} ({r['label']})" for r in results)
    )


# ### The figure
#
# Four panels as in the talk: displacement, velocity and contact pressure at
# $x = 0$, and the energy, each against time and over the exact solution.
# matplotlib is optional: without it the demo only skips the figure.


def plot(results: list[dict], args: argparse.Namespace, path: str) -> None:
    """Draw u(t, 0), v(t, 0), lambda_h(t, 0) and the energy of every run into ``path``."""
    plt = pyplot()
    if plt is None:
        return
    # the main run is drawn last, on top of the Crank-Nicolson comparison
    styles = [{"color": "tab:blue", "lw": 1.1, "alpha": 0.9, "zorder": 2}]
    styles += [{"color": "tab:red", "lw": 0.9, "alpha": 0.8, "zorder": 1}] * (len(results) - 1)
    fig, axes = plt.subplots(2, 2, figsize=(12, 7.5), sharex=True, constrained_layout=True)
    histories = [result["history"] for result in results]
    labels = [result["label"] for result in results]
    bar_panels(axes.flat, histories, labels, styles, args.t_end)
    # E_Theta of the main run: the hybrid scheme guarantees that it never increases
    main = results[0]["history"]
    axes[1, 1].plot(
        main["t"],
        main["energy_theta"],
        color="tab:cyan",
        lw=1.1,
        ls="--",
        zorder=2,
        label=rf"$E_\Theta^h$, {results[0]['label']}",
    )
    for ax in axes[1]:
        ax.set_xlabel("time $t$")
    axes[1, 1].legend(loc="upper left", fontsize="small")
    fig.suptitle(
        rf"1D bouncing bar, Nitsche $\Theta = {args.nitsche_theta:g}$, "
        rf"$\gamma_0 = {latex_number(args.gamma0)}$, P{args.degree}, "
        rf"$h = {latex_number(1 / args.nx)}$, $\tau = {latex_number(args.dt)}$"
    )
    save(fig, path, dpi=150)


# ### Main
#
# The main run uses the chosen scheme; unless it already is Crank-Nicolson,
# a second run with Nitsche + Crank-Nicolson and the same parameters goes to
# `OUT/cn` for the comparison. Every flag is checked before anything is
# computed: a bad one stops the demo with a one-line message naming it (exit
# status 2). A Newton failure or SIGINT/SIGTERM stops it after the last complete
# step with its state saved in `OUT/checkpoint` (`--checkpoint-every K` also
# saves it every K steps); `--restart` continues from there.


def check_arguments(args: argparse.Namespace) -> None:
    """Every flag in range and the output folder writable, before any computing."""
    method_parameters(args)
    if args.nx < 1:
        raise ValueError(f"the bar needs at least one cell, got --nx {args.nx}")
    check_output_folder(args.out)


def main(argv: list[str] | None = None) -> None:
    """Run the demo with the command-line arguments ``argv``."""
    parser = make_parser()
    args = parser.parse_args(argv)
    with one_line_errors(parser):
        check_arguments(args)
        results = [run(args, args.scheme, args.out, args.method)]
        if args.compare and (args.scheme, args.method) != ("cn", "nitsche"):
            results.append(run(args, "cn", os.path.join(args.out, "cn"), "nitsche", main=False))

    if MPI.COMM_WORLD.rank == 0:
        print_summary(results, args.dt)
        for result in results:
            print(f"history: {os.path.join(result['out'], 'history.csv')}")
        if args.output_every > 0:
            print(f"fields: {os.path.join(args.out, 'solution.xdmf')}")
        if not args.no_plot:
            plot(results, args, os.path.join(args.out, "bar_1d.png"))


if __name__ == "__main__":
    main()
