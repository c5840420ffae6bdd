# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
#       format_version: '1.5'
# ---

# # Two elastic bars colliding: contact between two deformable bodies in 1D
#
# Two identical bars of length $L = 1$, $E = \rho = 1$ (wave speed $c = 1$),
# on $(-1, 0)$ and $(g, 1 + g)$, move towards each other with speeds $+v_0$ and
# $-v_0$. When they touch, a compression wave runs from the contact point to
# each free end and back: the bars stay in contact for $2L/c = 2$ under the
# constant contact force $\rho c v_0$, then separate with their velocities
# exchanged, and the energy is what it was.
#
# It shows how to
#
# - build two bodies in one mesh and pair their facing ends with
#   `ContactProblem.add_contact_pair` (`nitsche_dolfinx.twobody.two_bars_problem`);
# - record the total momentum and each bar's mean velocity;
# - measure the errors of the contact duration, the exit velocities and the
#   energy under refinement, at a fixed ratio tau / h (`--refine N`);
# - draw the energies and the bars in space and time, coloured by their velocity
#   (`pictures.Worldlines`, a callback of the run).
#
# The pair is Nitsche's contact law of the rigid obstacle with the relative
# displacement of the two ends; unbiased, each end is slave in turn with weight
# 1/2 (docs/method.md section 11). With the hybrid scheme and $\Theta = 1$,
# $E_\Theta$ never increases.

# +
import argparse
import csv
import os

import numpy as np
from mpi4py import MPI

from nitsche_dolfinx import Simulation
from nitsche_dolfinx.arguments import (
    add_method_arguments,
    add_terminal_arguments,
    check_output_folder,
    finite_float,
    method_parameters,
    scheme_from_arguments,
)
from nitsche_dolfinx.errors import one_line_errors
from nitsche_dolfinx.history import History
from nitsche_dolfinx.parameters import require
from nitsche_dolfinx.pictures import Worldlines, render_worldlines
from nitsche_dolfinx.plotting import energy_figure, latex_number, pyplot
from nitsche_dolfinx.twobody import (
    LOWER_BODY,
    UPPER_BODY,
    add_body_velocity_probes,
    two_bars_problem,
)

#: The columns of history.csv (the output contract of the two-body demos), then the parts
#: of the energy for its figure.
COLUMNS = (
    "t", "energy", "energy_theta", "contact_force", "momentum", "v_left", "v_right",
    "newton_iterations", "kinetic", "elastic", "potential",
)  # fmt: skip
# -


def make_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        description="Two elastic bars colliding: Nitsche contact between two bodies (1D).",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    add_method_arguments(parser, gamma0=1e-6, degree=1, dt=0.015, t_end=4.0)
    parser.add_argument("--nx", type=int, default=100, help="cells per bar")
    parser.add_argument("--v0", type=finite_float, default=0.5, help="speed of each bar")
    parser.add_argument("--gap", type=finite_float, default=0.1, help="initial gap")
    parser.add_argument("--variant", choices=("unbiased", "biased"), default="unbiased")
    parser.add_argument(
        "--refine", type=int, default=0, metavar="N",
        help="also run N refinements (nx doubled, dt halved) and write OUT/refinement.csv",
    )  # fmt: skip
    parser.add_argument("--out", default=os.path.join("out", "two_bars_1d"), help="output folder")
    add_terminal_arguments(parser, output_every=0)
    parser.add_argument("--no-plot", action="store_true", help="do not draw the figure")
    return parser


def check_arguments(args) -> None:
    """Every flag in range and the output folder writable, before any computing."""
    method_parameters(args)
    require(args.nx >= 1, "nx", args.nx, "each bar needs at least one cell")
    require(args.v0 > 0, "v0", args.v0, "the bars must move towards each other")
    require(args.gap >= 0, "gap", args.gap, "the gap must be >= 0")
    require(0 <= args.refine <= 6, "refine", args.refine, "from 0 to 6 refinements")
    check_output_folder(args.out)


# ## One run
#
# The pair's history: energies, the contact force, the total momentum
# $\sum_i (M v)_i$ and the mean velocity of each bar.


def run(args, nx: int, dt: float, out: str | None, quiet: bool, callback=None) -> History:
    problem, cells = two_bars_problem(
        nx=nx, v0=args.v0, gap=args.gap, degree=args.degree, gamma0=args.gamma0,
        nitsche_theta=args.nitsche_theta, variant=args.variant,
        gamma0_scaling=args.gamma0_scaling,
    )  # fmt: skip
    simulation = Simulation(
        problem, scheme_from_arguments(args), dt=dt, t_end=args.t_end, progress=not quiet,
        max_step_cuts=args.max_step_cuts,
    )  # fmt: skip
    add_body_velocity_probes(simulation, cells, {LOWER_BODY: "v_left", UPPER_BODY: "v_right"})
    return simulation.run(
        out=out, columns=COLUMNS, output_every=args.output_every, callback=callback
    )


# ## Against the exact solution
#
# The exact pair touches at $t_0 = g / (2 v_0)$ and separates at $t_0 + 2$;
# after it the left bar moves at $-v_0$ and the right one at $+v_0$.


def errors(history: History, args) -> dict:
    touching = history["t"][history["contact_force"] > 0]
    start = args.gap / (2 * args.v0)
    duration = (touching.max() - touching.min()) if len(touching) else 0.0
    after = history["t"] > start + 2.0 + 0.2
    exit_error = np.nan
    if after.any():
        exit_error = (
            max(
                np.abs(history["v_right"][after] - args.v0).max(),
                np.abs(history["v_left"][after] + args.v0).max(),
            )
            / args.v0
        )
    energy = history["energy"]
    return {
        "contact_start": touching.min() if len(touching) else np.nan,
        "duration_error": abs(duration - 2.0) / 2.0,
        "exit_velocity_error": exit_error,
        "energy_error": abs(energy[-1] - energy[0]) / energy[0],
        "momentum_max": np.abs(history["momentum"]).max() / args.v0,
        "newton": history.mean_newton_iterations(),
    }


def print_summary(history: History, args) -> None:
    e = errors(history, args)
    print(f"{2 * (args.nx + 1)} DOFs, {len(history) - 1} steps of tau = {args.dt:g}")
    print(f"contact from t = {e['contact_start']:.4f}, duration error {e['duration_error']:.3e}")
    print(f"exit velocities, largest relative error {e['exit_velocity_error']:.3e}")
    print(f"energy change {e['energy_error']:.3e}, largest |momentum| / v0 {e['momentum_max']:.1e}")
    print(f"largest one-step rise of E_Theta {history.largest_rise():.2e}")
    print(f"Newton iterations per step {e['newton']:.2f}")


def refinement(args) -> list[dict]:
    """The errors at nx, 2 nx, ... with tau / h fixed."""
    rows = []
    for level in range(args.refine + 1):
        nx, dt = args.nx * 2**level, args.dt / 2**level
        rows.append({"nx": nx, "dt": dt, **errors(run(args, nx, dt, None, True), args)})
    return rows


def plot(history: History, args, path: str) -> None:
    plt = pyplot()
    if plt is None:
        return
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    t = history["t"]
    start = args.gap / (2 * args.v0)
    exact = np.where((t > start) & (t < start + 2), 0.0, np.where(t < start, 1.0, -1.0))
    top.plot(t, history["v_right"], label="right bar")
    top.plot(t, history["v_left"], label="left bar")
    top.plot(t, -args.v0 * exact, "k:", lw=0.8, label="exact (end states)")
    top.set_ylabel("mean velocity")
    top.legend()
    bottom.plot(t, history["contact_force"], label="contact force")
    bottom.axhline(args.v0, color="k", ls=":", lw=0.8, label=r"$\rho c v_0$")
    bottom.set_xlabel("t")
    bottom.legend()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> None:
    parser = make_parser()
    args = parser.parse_args(argv)
    with one_line_errors(parser):
        check_arguments(args)
        worldlines = Worldlines()  # every node at every time level, for the picture
        history = run(args, args.nx, args.dt, args.out, args.quiet, worldlines)
        rows = refinement(args) if args.refine else []
    if MPI.COMM_WORLD.rank != 0:
        return
    print_summary(history, args)
    print(f"history: {os.path.join(args.out, 'history.csv')}")
    if rows:
        path = os.path.join(args.out, "refinement.csv")
        with open(path, "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
        print(f"{'nx':>6} {'dt':>9} {'duration':>10} {'exit v':>10} {'energy':>10}")
        for row in rows:
            print(
                f"{row['nx']:6d} {row['dt']:9.3g} {row['duration_error']:10.3e} "
                f"{row['exit_velocity_error']:10.3e} {row['energy_error']:10.3e}"
            )
        print(f"refinement: {path}")
    if not args.no_plot:
        plot(history, args, os.path.join(args.out, "two_bars_1d.png"))
        title = (
            rf"two bars, {args.variant}, $\gamma_0 = {latex_number(args.gamma0)}$, "
            rf"{args.nx} cells each, $\tau = {latex_number(args.dt)}$"
        )
        energy_figure([history], ["two bars"], ["tab:blue"], title,
                      os.path.join(args.out, "energy.png"))  # fmt: skip
        path = os.path.join(args.out, "worldlines.png")
        render_worldlines(worldlines, f"two bars in space and time: {title}", path)


if __name__ == "__main__":
    main()
