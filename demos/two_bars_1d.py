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
#   `ContactProblem.add_contact_pair` (`nitsche_dolfinx.cases.two_bodies.two_bars_problem`);
# - record the total momentum and each bar's mean velocity, and declare each bar a
#   body (`ContactProblem.add_body`) for its momentum and centre of mass;
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
import os

from mpi4py import MPI

from nitsche_dolfinx import Simulation
from nitsche_dolfinx.cases import (
    LOWER_BODY,
    UPPER_BODY,
    add_body_velocity_probes,
    two_bars_errors,
    two_bars_problem,
)
from nitsche_dolfinx.cli import (
    add_method_arguments,
    add_terminal_arguments,
    check_output_folder,
    finite_float,
    method_parameters,
    one_line_errors,
    scheme_from_arguments,
    scheme_mass,
    step_taken,
)
from nitsche_dolfinx.common import require
from nitsche_dolfinx.output import History, body_columns
from nitsche_dolfinx.post import (
    Worldlines,
    energy_figure,
    figure_title,
    refinement_table,
    render_worldlines,
    two_bars_figure,
    two_bars_summary,
    write_csv,
)

#: The columns of history.csv (the output contract of the two-body demos), then the parts
#: of the energy for its figure and the bodies' columns (the right bar's, the left one's).
COLUMNS = (
    "t", "energy", "energy_theta", "contact_force", "momentum", "v_left", "v_right",
    "newton_iterations", "kinetic", "elastic", "potential",
    *body_columns(UPPER_BODY, 1), *body_columns(LOWER_BODY, 1),
)  # fmt: skip
# -


def make_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        description="Two elastic bars colliding: Nitsche contact between two bodies (1D).",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    add_method_arguments(parser, gamma0=1e-6, degree=1, dt=0.015, t_end=4.0, explicit_gamma0=0.5)
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
        gamma0_scaling=args.gamma0_scaling, mass=scheme_mass(args),
    )  # fmt: skip
    for tag in (UPPER_BODY, LOWER_BODY):
        problem.add_body(tag, cells)
    simulation = Simulation(
        problem, scheme_from_arguments(args), dt=dt, t_end=args.t_end, progress=not quiet,
        max_step_cuts=args.max_step_cuts,
    )  # fmt: skip
    if out == args.out:  # the main run: its step (--dt auto: the verlet scheme's) is --dt's
        args.dt = step_taken(simulation, quiet)
    add_body_velocity_probes(simulation, cells, {LOWER_BODY: "v_left", UPPER_BODY: "v_right"})
    return simulation.run(
        out=out, columns=COLUMNS, output_every=args.output_every, callback=callback
    )


# ## Against the exact solution
#
# The exact pair touches at $t_0 = g / (2 v_0)$ and separates at $t_0 + 2$; then
# the left bar moves at $-v_0$ and the right one at $+v_0$
# (`exact.two_bars_errors`: the relative errors of the contact duration, the exit
# velocities and the energy). `--refine N` runs $N$ refinements, $n_x$ doubled
# and $\tau$ halved each time, into `OUT/refinement.csv` (from the main run's
# $\tau$: with `--scheme verlet`, by default its share of the stable step it
# estimates, `--dt auto`).


def refinement(args) -> list[dict]:
    """The errors at nx, 2 nx, ... with tau / h fixed."""
    rows = []
    for level in range(args.refine + 1):
        nx, dt = args.nx * 2**level, args.dt / 2**level
        history = run(args, nx, dt, None, True)
        rows.append({"nx": nx, "dt": dt, **two_bars_errors(history, args.v0, args.gap)})
    return rows


# ## Main
#
# The run keeps every node at every time level (`pictures.Worldlines`) for the
# picture of the bars in space and time; then the errors, the velocities and the
# contact force against the exact ones, and the energy figure.


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
    errors = two_bars_errors(history, args.v0, args.gap)
    two_bars_summary(history, errors, 2 * (args.nx + 1), args.dt)
    print(f"history: {os.path.join(args.out, 'history.csv')}")
    if rows:
        path = os.path.join(args.out, "refinement.csv")
        write_csv(path, list(rows[0]), rows)
        refinement_table(rows)
        print(f"refinement: {path}")
    if not args.no_plot:
        two_bars_figure(history, args.v0, args.gap, os.path.join(args.out, "two_bars_1d.png"))
        title = figure_title(
            f"two bars, {args.variant}, {args.nx} cells each", gamma0=args.gamma0, dt=args.dt
        )
        energy_figure([history], ["two bars"], ["tab:blue"], title,
                      os.path.join(args.out, "energy.png"))  # fmt: skip
        path = os.path.join(args.out, "worldlines.png")
        render_worldlines(worldlines, f"two bars in space and time: {title}", path)


if __name__ == "__main__":
    main()
