# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
#       format_version: '1.5'
# ---

# # Mixed + CN vs Nitsche + CN vs Nitsche hybrid vs modified mass, on the bouncing bar
#
# The comparison figure of the talk of Chouly, Hild & Renard ("A Nitsche finite
# element method for dynamic contact", M2AN 49, 2015), "Mixed(+CN) vs Nitsche(+CN)
# vs Nitsche-Hybrid", on the 1D bar with multiple impacts of `demos/bar_1d.py`,
# with the method the talk compares the hybrid scheme with in its conclusion: the
# modified mass method of Khenous, Laborde & Renard (2008).
#
# It shows how to
#
# - run one problem with several contact methods, time schemes and mass matrices
#   (`nitsche_dolfinx.cases.one_body.bar_simulation` and the table `cases.BAR_METHODS`);
# - measure each run against the exact solution (errors at the contact point,
#   energy, penetration) and gather the numbers in one table;
# - draw the four panels of the talk: displacement, velocity and contact
#   pressure at $x = 0$, and the energy.
#
# ## The methods
#
# The bar $(0, 1)$ ($E = \rho = 1$, clamped at $x = 1$, wall at $x = 0$,
# $u_0 = 1/2 - x/2$, $v_0 = 0$) has an exact solution of period 3 and energy
# $1/8$. The runs, each into `OUT/<name>/history.csv` (and the run of the studied
# scheme, `nitsche_hybrid` by default, also into `OUT/history.csv`):
#
# | name | method | time scheme | mass |
# |---|---|---|---|
# | `mixed_cn` | Lagrange multiplier (Alart-Curnier) | Crank-Nicolson | consistent |
# | `nitsche_cn` | Nitsche | Crank-Nicolson | consistent |
# | `nitsche_hybrid` | Nitsche | hybrid | consistent |
# | `modified_mass` | Lagrange multiplier | Crank-Nicolson | redistributed |
# | `penalty_hybrid` (`--penalty`) | penalty, $\varepsilon = \gamma_0 h$ | hybrid | consistent |
#
# The *modified mass* moves the mass of the contact node to its neighbours (on
# the lumped mass matrix): the contact node has no inertia, the semi-discrete
# problem is well posed, and Crank-Nicolson keeps $u_h(t, 0) \ge 0$ without
# oscillating. The mixed method with the consistent mass is the ill-posed
# semi-discrete problem of the talk's introduction. `--scheme` (and `--theta`,
# `--beta`, `--gamma`) changes the scheme of the hybrid runs, which are then
# named after it (`nitsche_theta`, ...); `--scheme verlet` takes the lumped mass,
# runs first, and its step (by default `--dt auto`, its share of the stable step it
# estimates) is every run's. The defaults are the talk's: Nitsche
# $\Theta = 1$, $\gamma_0 = 10^{-6}$, 100 P1 cells, $\tau = 0.015$, $T = 6$. The
# table the demo prints, and what it shows, are in `docs/results.md`.

# +
import argparse
import os
import shutil
import time
from dataclasses import replace

from mpi4py import MPI

from nitsche_dolfinx.cases import BAR_COLUMNS, BAR_METHODS
from nitsche_dolfinx.cases import one_body as cases
from nitsche_dolfinx.cli import (
    add_method_arguments,
    add_terminal_arguments,
    check_output_folder,
    method_parameters,
    one_line_errors,
    scheme_from_arguments,
    step_taken,
)
from nitsche_dolfinx.post import (
    COMPARISON_COLUMNS,
    comparison_figure,
    comparison_row,
    comparison_table,
    figure_title,
    write_csv,
)

COMPARED = ("mixed", "cn", "hybrid", "modified_mass")  # keys of BAR_METHODS, in this order
# -

# ### Command line


def make_parser() -> argparse.ArgumentParser:
    """The command-line parser of the demo."""
    parser = argparse.ArgumentParser(
        description="1D bouncing bar: mixed, Nitsche, hybrid and modified mass methods compared.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    add_method_arguments(parser, gamma0=1e-6, degree=1, dt=0.015, t_end=6.0, explicit_gamma0=0.5)
    parser.add_argument("--nx", type=int, default=100, help="number of cells")
    parser.add_argument(
        "--penalty", action="store_true", help="also run the penalty method with the hybrid scheme"
    )
    parser.add_argument(
        "--out", default=os.path.join("out", "compare_methods_1d"), help="output folder"
    )
    add_terminal_arguments(parser, output_every=0)
    return parser


# ### Running and measuring
#
# Every run is `cases.bar_simulation` with the method, the scheme and the mass of
# its row (the mixed method ignores $\gamma_0$ and $\Theta$). `reports.comparison_row`
# measures it: the $\ell^2(0, T)$ errors at the contact point over the time levels,
# e.g. $\big(\sum_n \tau |u_h(t^n, 0) - u(t^n, 0)|^2\big)^{1/2}$, the penetration
# $\max_n (-u_h(t^n, 0))$, the energy and the wall time (which includes building
# the problem, and compiling its forms when they are not in the cache yet).


def run(method: cases.BarMethod, out: str, args: argparse.Namespace) -> tuple:
    """Run ``method``, writing ``out/history.csv``; its History and wall time."""
    start = time.perf_counter()
    simulation = cases.bar_simulation(
        scheme_from_arguments(args, method.scheme), method=method.method, mass=method.mass,
        dt=args.dt, t_end=args.t_end, nx=args.nx, degree=args.degree, gamma0=args.gamma0,
        nitsche_theta=args.nitsche_theta, gamma0_scaling=args.gamma0_scaling,
        max_step_cuts=args.max_step_cuts,
    )  # fmt: skip
    args.dt = step_taken(simulation, args.quiet)  # the first run's (--dt auto) is the others'
    history = simulation.run(out=out, columns=BAR_COLUMNS, output_every=args.output_every)
    seconds = time.perf_counter() - start
    if not args.quiet and MPI.COMM_WORLD.rank == 0:  # one line per run: its progress
        print(f"{method.label:20s} {len(history) - 1} steps in {seconds:.2f} s", flush=True)
    return history, seconds


# ### Main
#
# The runs, then the table (`OUT/summary.csv` in full precision, `OUT/summary.md`)
# and the four panels of the talk over the exact solution, with a zoom on the
# displacement during the second contact phase (matplotlib is optional).


def main(argv: list[str] | None = None) -> None:
    """Run the demo with the command-line arguments ``argv``."""
    parser = make_parser()
    args = parser.parse_args(argv)
    with one_line_errors(parser):
        studied = scheme_from_arguments(args)  # the scheme of the hybrid runs
    keys = [*COMPARED, "penalty"] if args.penalty else list(COMPARED)
    methods = {}  # the hybrid runs with the scheme of --scheme, each run once
    for key in keys:
        method = BAR_METHODS[key]
        if method.scheme == "hybrid":
            method = method.with_scheme(studied)
            if studied.explicit:  # verlet: with the lumped mass
                method = replace(method, label=f"{method.label}, lumped mass", mass="lumped")
        if method.name not in (m.name for m in methods.values()):
            methods[key] = method
    names = {key: method.name for key, method in methods.items()}
    # the runs of the studied scheme first: with --dt auto, the step of the verlet run is
    # the step of every run
    order = sorted(methods, key=lambda key: methods[key].scheme != studied.name)
    with one_line_errors(parser):
        method_parameters(args)
        check_output_folder(args.out)
        runs = {key: run(methods[key], os.path.join(args.out, names[key]), args) for key in order}
    if MPI.COMM_WORLD.rank != 0:
        return
    # OUT/history.csv (the output contract): the run of the studied scheme
    shutil.copyfile(os.path.join(args.out, names[order[0]], "history.csv"),
                    os.path.join(args.out, "history.csv"))  # fmt: skip
    rows = [
        {"run": names[key], "label": method.label, **comparison_row(*runs[key], args.dt)}
        for key, method in methods.items()
    ]
    write_csv(os.path.join(args.out, "summary.csv"), ["run", "label", *COMPARISON_COLUMNS], rows)
    table = comparison_table(rows)
    with open(os.path.join(args.out, "summary.md"), "w") as f:
        f.write(table + "\n")
    print(table)
    print(
        f"summary: {os.path.join(args.out, 'summary.csv')}, {os.path.join(args.out, 'summary.md')}"
    )
    if not args.no_plot:
        title = figure_title(
            "1D bouncing bar", args.nitsche_theta, args.gamma0, args.degree, 1 / args.nx, args.dt
        )
        path = os.path.join(args.out, "compare_methods_1d.png")
        comparison_figure(methods, [runs[key][0] for key in methods], title, path, args.t_end)


if __name__ == "__main__":
    main()
