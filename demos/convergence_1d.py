# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
#       format_version: '1.5'
# ---

# # Convergence on the bouncing bar when $h, \tau \to 0$ with $\tau / h$ fixed
#
# The talk of Chouly, Hild & Renard ("A Nitsche finite element method for
# dynamic contact", M2AN 49, 2015) ends its 1D experiments with error curves for
# the bar with multiple impacts of `demos/bar_1d.py`, refined in space and time
# together ($\tau / h$ fixed): the displacement in $\ell^2(\tau; L^2(\Omega))$
# and $\ell^2(\tau; H^1(\Omega))$, the contact pressure and the energy. This demo
# measures them for four methods.
#
# It shows how to
#
# - refine space and time together, each level one run of the bar
#   (`nitsche_dolfinx.cases.one_body.bar_convergence_level`);
# - measure space-time errors against an exact solution with a callback that
#   `run()` calls after every step (`nitsche_dolfinx.cases.exact.BarSpaceTimeErrors`);
# - report observed orders and draw log-log error curves with slope marks.
#
# ## The study
#
# Levels $N = 25, 50, 100, 200, 400$ P1 cells ($h = 1/N$) with $\tau = 1.5\, h$
# (`--levels`, `--ratio`; `--dt` gives every level one $\tau$ instead), over one
# period of the exact solution, $T = 3$ (`--t-end`): a flight, a contact phase
# and a release. Nitsche is the symmetric variant $\Theta = 1$ with the talk's
# $\gamma_0 = 10^{-6}$. The methods (`--methods`, from `cases.BAR_METHODS`):
# `hybrid` (Nitsche, the hybrid scheme, or that of `--scheme`), `cn` (Nitsche +
# Crank-Nicolson), `mixed` (Lagrange multiplier + CN) and `modified_mass` (the
# same with the redistributed mass). With `--scheme verlet` (explicit, lumped
# mass), $\tau$ is by default on each level the scheme's share of the stable step
# it estimates there (`--dt auto`), and every method of the level takes it.
#
# The errors, with $t^n = n \tau$, $u$ the exact solution and $e^n = u_h^n - u(t^n)$:
#
# - $\ell^2(\tau; L^2)$: $\big(\sum_n \tau \|e^n\|^2_{L^2(0,1)}\big)^{1/2}$;
# - $\ell^2(\tau; H^1)$: the same with the $H^1$ *seminorm* $\|\partial_x e^n\|_{L^2}$
#   (a norm here, as $e^n$ vanishes at the clamped end);
# - contact pressure: $\big(\sum_n \tau |\lambda_h^n - \sigma(t^n)|^2\big)^{1/2}$ at
#   $x = 0$ with the recorded pressure $\lambda_h$ (Nitsche:
#   $-\frac{1}{\gamma_h}[P_\gamma(u_h)]_+$; mixed: the multiplier), and the same with
#   the normal stress of the discrete displacement, $\sigma_n(u_h^n) = E\, \partial_x
#   u_h^n(0)$, which is what Nitsche's method makes the pressure equal to;
# - energy: $\max_n |E^{h,n} - 1/8|$.
#
# The space integrals are exact: the exact solution is piecewise linear in $x$
# with at most two kinks, so each cell is cut at the kinks and each piece
# integrated by a 4-point Gauss rule. The table the demo prints with the
# defaults, and the observed orders, are in `docs/results.md`.

# +
import argparse
import os
import shutil
from dataclasses import replace

from mpi4py import MPI

from nitsche_dolfinx.cases import BAR_METHODS, bar_convergence_level, bar_simulation
from nitsche_dolfinx.cli import (
    add_method_arguments,
    add_terminal_arguments,
    finite_float,
    method_parameters,
    one_line_errors,
    scheme_from_arguments,
    step_taken,
)
from nitsche_dolfinx.common import require
from nitsche_dolfinx.post import (
    CONVERGENCE_ERRORS,
    convergence_acceptance,
    convergence_figure,
    convergence_table,
    figure_title,
    write_csv,
)

METHODS = ("hybrid", "cn", "mixed", "modified_mass")  # keys of BAR_METHODS
# -

# ### Command line


def make_parser() -> argparse.ArgumentParser:
    """The command-line parser of the demo."""
    parser = argparse.ArgumentParser(
        description="1D bouncing bar: convergence when h and tau go to 0 with tau/h fixed.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    add_method_arguments(parser, gamma0=1e-6, degree=1, dt=None, t_end=3.0, explicit_gamma0=0.5)
    parser.add_argument(
        "--levels", type=int, nargs="+", default=[25, 50, 100, 200, 400],
        help="numbers of cells N of the levels (h = 1/N)",
    )  # fmt: skip
    parser.add_argument("--ratio", type=finite_float, default=1.5, help="tau / h (without --dt)")
    parser.add_argument(
        "--methods", nargs="+", choices=METHODS, default=list(METHODS), help="methods to study"
    )
    parser.add_argument(
        "--out", default=os.path.join("out", "convergence_1d"), help="output folder"
    )
    add_terminal_arguments(parser, output_every=0)
    return parser


def time_step(args: argparse.Namespace, nx: int) -> float | str:
    """tau of the level with ``nx`` cells: ``--dt`` (``auto``: see :func:`level_steps`), or
    ``--ratio`` times h."""
    return args.dt if args.dt is not None else args.ratio * (1.0 / nx)


def level_steps(args: argparse.Namespace, studied) -> dict[int, float]:
    """tau of every level. With ``--dt auto`` (the default of ``--scheme verlet``), the
    step the verlet scheme takes on that level (its share of the stable step it estimates
    on the level's mesh, about proportional to h): every method of the level takes it."""
    steps = {}
    for nx in sorted(args.levels):
        dt = time_step(args, nx)
        if dt == "auto":  # the level's explicit simulation, built for its step
            simulation = bar_simulation(
                studied, mass="lumped", dt=dt, t_end=args.t_end, nx=nx, degree=args.degree,
                gamma0=args.gamma0, nitsche_theta=args.nitsche_theta,
                gamma0_scaling=args.gamma0_scaling,
            )  # fmt: skip
            dt = step_taken(simulation, args.quiet)
        steps[nx] = dt
    return steps


def check_arguments(parser, args: argparse.Namespace) -> None:
    """Every flag in range, the time steps of the coarsest and the finest levels too."""
    if len(args.levels) < 2 or min(args.levels) < 1:
        parser.error(f"--levels needs at least two positive numbers of cells, got {args.levels}")
    require(args.ratio > 0, "ratio", args.ratio, "tau / h must be positive")
    for nx in (min(args.levels), max(args.levels)):
        method_parameters(argparse.Namespace(**{**vars(args), "dt": time_step(args, nx)}))


def figure_step(args: argparse.Namespace) -> float | str:
    """tau in the figure's title: ``--dt``, ``--ratio`` h, or the verlet scheme's share of
    the stable step."""
    if args.dt == "auto":
        return rf"{args.safety:g}\,\tau_{{\rm stable}}(h)"
    return rf"{args.ratio:g}\,h" if args.dt is None else args.dt


# ### The study
#
# Each level is `cases.bar_convergence_level`: a run of `cases.bar_simulation`
# with a probe of $\sigma_n(u_h)$ at $x = 0$ and a `BarSpaceTimeErrors` callback,
# which evaluates $u_h$ and $\partial_x u_h$ on the cells this rank owns after
# every step and sums over the ranks. One line per level shows the progress.


def study(args: argparse.Namespace, methods: dict, steps: dict[int, float]) -> dict:
    """The rows of every level of every method (``methods``: key to BarMethod; ``steps``:
    the number of cells of each level to its tau)."""
    results = {}
    for name, method in methods.items():
        results[name] = []
        for nx in sorted(args.levels):
            # each level's history (and its fields when asked for) in a folder of its own
            out = os.path.join(args.out, name, f"N{nx}")
            row = bar_convergence_level(
                method, nx, steps[nx], args.t_end, args.gamma0, args.degree, out,
                args.output_every, scheme_from_arguments(args, method.scheme),
                nitsche_theta=args.nitsche_theta, gamma0_scaling=args.gamma0_scaling,
                max_step_cuts=args.max_step_cuts,
            )  # fmt: skip
            results[name].append({"method": name, **row})
            if MPI.COMM_WORLD.rank == 0 and not args.quiet:
                print(
                    f"{name:14s} N = {nx:4d}: l2(L2) {row['error_l2_l2']:.3e}, "
                    f"l2(H1) {row['error_l2_h1']:.3e} ({row['wall_seconds']:.1f} s)",
                    flush=True,
                )
    return results


# ### Main
#
# Each level's history goes to `OUT/<method>/N<cells>/history.csv`, the finest
# level of the first method's also to `OUT/history.csv`. The errors go to
# `OUT/convergence.csv` (full precision) and, with the observed
# orders $\log(e_{k-1}/e_k) / \log(h_{k-1}/h_k)$, to `OUT/convergence.md`; the
# hybrid scheme is checked against the orders the talk reports; the figure has
# four log-log panels against $h$ with reference slopes $1/2$ and $1$.


def main(argv: list[str] | None = None) -> None:
    """Run the demo with the command-line arguments ``argv``."""
    parser = make_parser()
    args = parser.parse_args(argv)
    with one_line_errors(parser):
        studied = scheme_from_arguments(args)  # the scheme of the hybrid method
    methods = {name: BAR_METHODS[name] for name in args.methods}
    if "hybrid" in methods:
        methods["hybrid"] = methods["hybrid"].with_scheme(studied)
        if studied.explicit:  # verlet: with the lumped mass
            hybrid = methods["hybrid"]
            methods["hybrid"] = replace(hybrid, label=f"{hybrid.label}, lumped mass", mass="lumped")
    with one_line_errors(parser):
        check_arguments(parser, args)
        results = study(args, methods, level_steps(args, studied))
    if MPI.COMM_WORLD.rank != 0:
        return
    os.makedirs(args.out, exist_ok=True)
    columns = ["method", "N", "h", "tau", *CONVERGENCE_ERRORS, "newton_iterations", "wall_seconds"]
    rows = [row for rows in results.values() for row in rows]
    write_csv(os.path.join(args.out, "convergence.csv"), columns, rows)
    # OUT/history.csv (the output contract): the finest level of the first method
    finest = os.path.join(args.out, args.methods[0], f"N{max(args.levels)}", "history.csv")
    shutil.copyfile(finest, os.path.join(args.out, "history.csv"))
    labels = {name: method.label for name, method in methods.items()}
    table = convergence_table(results, labels)
    with open(os.path.join(args.out, "convergence.md"), "w") as f:
        f.write(table + "\n")
    print(table)
    if "hybrid" in results and len(args.levels) >= 3:
        print(convergence_acceptance(results["hybrid"]))
    print(f"table: {os.path.join(args.out, 'convergence.csv')}")
    if not args.no_plot:
        title = figure_title(
            rf"1D bouncing bar, convergence over $(0, {args.t_end:g})$", args.nitsche_theta,
            args.gamma0, args.degree, dt=figure_step(args),
        )  # fmt: skip
        convergence_figure(results, labels, title, os.path.join(args.out, "convergence_1d.png"))


if __name__ == "__main__":
    main()
