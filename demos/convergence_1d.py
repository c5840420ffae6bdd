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
# dynamic contact", M2AN 49, 2015) ends its 1D experiments with error curves
# for the bar with multiple impacts of `demos/bar_1d.py`, refined in space
# and time together ($\tau / h$ fixed): the displacement in
# $\ell^2(\tau; L^2(\Omega))$ and $\ell^2(\tau; H^1(\Omega))$, the contact
# pressure and the energy. This demo measures them for four methods.
#
# It shows how to
#
# - refine space and time together and run each level with
#   `nitsche_dolfinx.cases.bar_simulation`;
# - measure space-time errors against an exact solution with a `callback`
#   called by `run()` after every step;
# - add a probe of our own (the normal stress at the wall) to a simulation;
# - report observed orders and draw log-log error curves with slope marks.
#
# ## The study
#
# Levels $N = 25, 50, 100, 200, 400$ P1 cells ($h = 1/N$) with
# $\tau = 1.5\, h$ (`--levels`, `--ratio`), over one period of the exact
# solution, $T = 3$ (`--t-end`): one flight, one contact phase and one
# release. Nitsche is the symmetric variant $\Theta = 1$ with the talk's
# $\gamma_0 = 10^{-6}$ (`--gamma0`). The methods (`--methods`):
#
# | name | method | time scheme | mass |
# |---|---|---|---|
# | `hybrid` | Nitsche | hybrid | consistent |
# | `cn` | Nitsche | Crank-Nicolson | consistent |
# | `mixed` | Lagrange multiplier | Crank-Nicolson | consistent |
# | `modified_mass` | Lagrange multiplier | Crank-Nicolson | redistributed |
#
# The errors, with $t^n = n \tau$, $n = 0, \dots, T/\tau$, $u$ the exact
# solution and $e^n = u_h^n - u(t^n)$:
#
# - $\ell^2(\tau; L^2)$: $\big(\sum_n \tau \|e^n\|^2_{L^2(0,1)}\big)^{1/2}$;
# - $\ell^2(\tau; H^1)$: $\big(\sum_n \tau |e^n|^2_{H^1(0,1)}\big)^{1/2}$ with
#   the $H^1$ *seminorm* $\|\partial_x e^n\|_{L^2}$ (a norm here, as $e^n$
#   vanishes at the clamped end; it dominates the full norm, which adds the
#   $L^2$ error, 30 times smaller);
# - contact pressure: $\big(\sum_n \tau |\lambda_h^n - \sigma(t^n)|^2\big)^{1/2}$
#   at $x = 0$, with the recorded pressure $\lambda_h$ (Nitsche:
#   $-\frac{1}{\gamma_h}[P_\gamma(u_h)]_+$; mixed: the multiplier); and the same
#   with the normal stress of the discrete displacement at the wall,
#   $\sigma_n(u_h^n) = E\, \partial_x u_h^n(0)$, which is what Nitsche's
#   method makes the pressure equal to;
# - energy: $\max_n |E^{h,n} - 1/8|$.
#
# The space integrals are exact: the exact solution is piecewise linear in
# $x$ with at most two kinks, among $x = s$, $s - 1$, $2 - s$ and $3 - s$
# ($s = t \bmod 3$), so each cell is cut at those kinks and each piece is
# integrated by a 4-point Gauss rule, exact for the polynomials there.
#
# The table the demo prints with the defaults, and the observed orders, are
# in `docs/results.md`.
#
# ## Implementation

# +
import argparse
import csv
import os
import time
from dataclasses import dataclass

import numpy as np
from mpi4py import MPI

from nitsche_dolfinx import BAR_CONTACT, BoundaryAverage, cases
from nitsche_dolfinx.arguments import add_terminal_arguments, finite_float
from nitsche_dolfinx.errors import one_line_errors
from nitsche_dolfinx.exact import BAR_ENERGY, BarSpaceTimeErrors, bar_contact_values
from nitsche_dolfinx.parameters import OutputParameters
from nitsche_dolfinx.plotting import latex_number, pyplot, save
from nitsche_dolfinx.schemes import make_scheme


@dataclass(frozen=True)
class Method:
    """One method of the study."""

    name: str
    label: str
    method: str  # "nitsche" or "mixed"
    scheme: str  # "hybrid" or "cn"
    mass: str  # "consistent" or "redistributed"
    color: str
    marker: str


METHODS = {
    m.name: m
    for m in (
        Method("hybrid", "Nitsche hybrid", "nitsche", "hybrid", "consistent", "tab:blue", "o"),
        Method("cn", "Nitsche + CN", "nitsche", "cn", "consistent", "tab:red", "s"),
        Method("mixed", "Mixed + CN", "mixed", "cn", "consistent", "tab:orange", "^"),
        Method(
            "modified_mass", "Modified mass + CN", "mixed", "cn", "redistributed", "tab:green", "D"
        ),
    )
}

# The errors, in the order of the table and the CSV, with their headers
ERRORS = {
    "error_l2_l2": "l2(L2) u",
    "error_l2_h1": "l2(H1) u",
    "error_pressure": "l2 lambda_h(.,0)",
    "error_stress": "l2 sigma_n(u_h)(.,0)",
    "error_energy": "max \\|E - 1/8\\|",
}
# -

# ### Space-time errors, accumulated step by step
#
# `nitsche_dolfinx.exact.BarSpaceTimeErrors` is called once at $t = 0$ and
# then by `run()` after every step: it evaluates $u_h$ and $\partial_x u_h$ on
# the cells this rank owns against the exact $u$ and its strain (`bar_strain`,
# with its kinks), and sums over the ranks.


# ### One level
#
# A level is one run of `cases.bar_simulation` with its own probe of
# $\sigma_n(u_h)$ at $x = 0$ (the stress on the contact boundary, averaged
# over it: on a 1D mesh, its value at the point).


def run_level(
    method: Method,
    nx: int,
    ratio: float,
    t_end: float,
    gamma0: float,
    degree: int = 1,
    out: str | None = None,
    output_every: int = 0,
) -> dict:
    """Errors of ``method`` with ``nx`` cells and tau = ratio / nx over (0, t_end); with
    ``out``, its history and (every ``output_every`` steps) its fields are written there."""
    start = time.perf_counter()
    h = 1.0 / nx
    dt = ratio * h
    simulation = cases.bar_simulation(
        make_scheme(method.scheme),
        method=method.method,
        mass=method.mass,
        dt=dt,
        t_end=t_end,
        nx=nx,
        degree=degree,
        gamma0=gamma0,
        nitsche_theta=1.0,
    )
    problem = simulation.problem
    stress = problem.contacts[0].sigma_n(simulation.u)
    simulation.add_probe(
        "stress_contact", BoundaryAverage(problem.mesh, stress, problem.ds(BAR_CONTACT))
    )
    errors = BarSpaceTimeErrors(simulation)
    errors(simulation)  # t = 0
    history = simulation.run(out=out, callback=errors, output_every=output_every)
    _, _, sigma = bar_contact_values(history["t"])
    return {
        "method": method.name,
        "N": nx,
        "h": h,
        "tau": dt,
        "error_l2_l2": np.sqrt(errors.l2_squared),
        "error_l2_h1": np.sqrt(errors.h1_squared),
        "error_pressure": np.sqrt(dt * np.sum((history["sigma_contact"] - sigma) ** 2)),
        "error_stress": np.sqrt(dt * np.sum((history["stress_contact"] - sigma) ** 2)),
        "error_energy": np.max(np.abs(history["energy"] - BAR_ENERGY)),
        "newton_iterations": history.mean_newton_iterations(),
        "wall_seconds": time.perf_counter() - start,
    }


def observed_orders(rows: list[dict], name: str) -> list[float]:
    """log(e_{k-1} / e_k) / log(h_{k-1} / h_k) between consecutive levels (NaN for the
    first level, and where an error is zero)."""
    errors = np.array([row[name] for row in rows])
    ratios = np.array([rows[k - 1]["h"] / rows[k]["h"] for k in range(1, len(rows))])
    with np.errstate(divide="ignore", invalid="ignore"):
        return [np.nan, *(np.log(errors[:-1] / errors[1:]) / np.log(ratios))]


# ### Command line


def make_parser() -> argparse.ArgumentParser:
    """The command-line parser of the demo."""
    parser = argparse.ArgumentParser(
        description="1D bouncing bar: convergence when h and tau go to 0 with tau/h fixed.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    parser.add_argument(
        "--levels",
        type=int,
        nargs="+",
        default=[25, 50, 100, 200, 400],
        help="numbers of cells N of the levels (h = 1/N)",
    )
    parser.add_argument("--ratio", type=finite_float, default=1.5, help="tau / h")
    parser.add_argument(
        "--t-end", type=finite_float, default=3.0, help="final time T (3: one period)"
    )
    parser.add_argument(
        "--gamma0", type=finite_float, default=1e-6, help="Nitsche parameter, gamma_h = gamma0 h"
    )
    parser.add_argument("--degree", type=int, default=1, help="Lagrange degree")
    parser.add_argument(
        "--methods",
        nargs="+",
        choices=list(METHODS),
        default=list(METHODS),
        help="methods to study",
    )
    parser.add_argument(
        "--out", default=os.path.join("out", "convergence_1d"), help="output folder"
    )
    add_terminal_arguments(parser, output_every=0)
    parser.add_argument("--no-plot", action="store_true", help="do not draw the figure")
    return parser


# ### Output: CSV, Markdown table with orders, acceptance check


def write_csv(rows: list[dict], path: str) -> None:
    """One line per method and level, full precision."""
    columns = ["method", "N", "h", "tau", *ERRORS, "newton_iterations", "wall_seconds"]
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(columns)
        for row in rows:
            writer.writerow(
                [row[c] if c in ("method", "N") else repr(float(row[c])) for c in columns]
            )


def markdown_table(results: dict[str, list[dict]]) -> str:
    """Errors and observed orders of every method and level."""
    header = ["method", "N", "tau"]
    for title in ERRORS.values():
        header += [title, "order"]
    header.append("time (s)")
    lines = ["| " + " | ".join(header) + " |", "|---" * len(header) + "|"]
    for name, rows in results.items():
        orders = {error: observed_orders(rows, error) for error in ERRORS}
        for k, row in enumerate(rows):
            cells = [METHODS[name].label, str(row["N"]), f"{row['tau']:.5f}"]
            for error in ERRORS:
                order = orders[error][k]
                cells += [f"{row[error]:.3e}", "" if np.isnan(order) else f"{order:.2f}"]
            cells.append(f"{row['wall_seconds']:.1f}")
            lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def acceptance(rows: list[dict]) -> str:
    """The check of the hybrid scheme: errors decrease at every level, and over the finest
    three levels the l2(L2) order is >= 0.6 and the l2(H1) order >= 0.25 (both steps)."""
    names = ("error_l2_l2", "error_l2_h1", "error_energy")
    decreasing = all(
        rows[k][name] < rows[k - 1][name] for name in names for k in range(1, len(rows))
    )
    l2 = observed_orders(rows, "error_l2_l2")[-2:]
    h1 = observed_orders(rows, "error_l2_h1")[-2:]
    passed = decreasing and len(rows) >= 3 and min(l2) >= 0.6 and min(h1) >= 0.25
    return (
        f"hybrid: errors of u and of the energy decrease at every level: {decreasing}; "
        f"orders over the finest three levels: l2(L2) {l2[0]:.2f}, {l2[1]:.2f} (>= 0.6), "
        f"l2(H1) {h1[0]:.2f}, {h1[1]:.2f} (>= 0.25): {'PASS' if passed else 'FAIL'}"
    )


# ### The figure
#
# Four log-log panels against $h$ (the talk's two figures): the two errors
# of $u$, the contact pressure (solid: $\lambda_h$, dashed: $\sigma_n(u_h)$)
# and the energy, with reference slopes $1/2$ and $1$.


def slope_triangle(ax, x0: float, y0: float, slope: float, label: str, width: float = 2.0):
    """A reference triangle of the given slope with its lower-left corner at (x0, y0)."""
    x1, y1 = x0 * width, y0 * width**slope
    ax.plot([x0, x1, x1, x0], [y0, y0, y1, y0], color="dimgray", lw=0.9)
    ax.text(x1 * 1.05, np.sqrt(y0 * y1), label, fontsize="small", color="dimgray", va="center")


def plot(results: dict[str, list[dict]], args: argparse.Namespace, path: str) -> None:
    """Draw the error curves of every method into ``path``."""
    plt = pyplot()
    if plt is None:
        return
    panels = (
        (("error_l2_l2",), r"$u$ in $\ell^2(\tau; L^2(0, 1))$"),
        (("error_l2_h1",), r"$u$ in $\ell^2(\tau; H^1(0, 1))$ (seminorm)"),
        (
            ("error_pressure", "error_stress"),
            r"pressure at $x = 0$ in $\ell^2(\tau)$: $\lambda_h$ (solid), $\sigma_n(u_h)$ (dashed)",
        ),
        (("error_energy",), r"energy: $\max_n |E^{h,n} - 1/8|$"),
    )
    fig, axes = plt.subplots(2, 2, figsize=(12, 9.5))
    fig.subplots_adjust(left=0.07, right=0.97, top=0.92, bottom=0.1, hspace=0.28, wspace=0.2)
    for ax, (names, title) in zip(axes.flat, panels):
        low = np.inf
        for name, rows in results.items():
            method = METHODS[name]
            h = np.array([row["h"] for row in rows])
            for error, style in zip(names, ("-", "--")):
                values = np.array([row[error] for row in rows])
                ax.loglog(
                    h,
                    values,
                    color=method.color,
                    marker=method.marker,
                    ls=style,
                    ms=5,
                    label=method.label if style == "-" else None,
                )
                low = min(low, values.min())
        # the reference slopes, below every curve, over the finest levels
        h = np.sort([row["h"] for row in next(iter(results.values()))])
        slope_triangle(ax, h[0] * 1.15, low / 1.8, 0.5, "1/2")
        slope_triangle(ax, h[0] * 1.15 * 2.0**1.6, low / 1.8, 1.0, "1")
        ax.set_xticks(h)
        ax.set_xticks([], minor=True)
        ax.set_xticklabels([f"1/{round(1 / x)}" for x in h])
        ax.set_title(title, fontsize="medium")
        ax.set_xlabel("$h$")
        ax.grid(alpha=0.3, which="both")
    fig.legend(*axes[0, 0].get_legend_handles_labels(), loc="lower center", ncol=len(results))
    fig.suptitle(
        rf"1D bouncing bar: convergence with $\tau = {args.ratio:g}\,h$ over "
        rf"$(0, {args.t_end:g})$, Nitsche $\Theta = 1$, $\gamma_0 = {latex_number(args.gamma0)}$, "
        rf"P{args.degree}"
    )
    save(fig, path, dpi=150)


# ### Main


def main(argv: list[str] | None = None) -> None:
    """Run the demo with the command-line arguments ``argv``."""
    parser = make_parser()
    args = parser.parse_args(argv)
    if len(args.levels) < 2 or min(args.levels) < 1:
        parser.error(f"--levels needs at least two positive numbers of cells, got {args.levels}")
    levels = sorted(args.levels)
    comm = MPI.COMM_WORLD
    results = {}
    with one_line_errors(parser):
        OutputParameters(args.output_every)  # checked before any run
        for name in args.methods:
            results[name] = []
            for nx in levels:
                # the fields only when asked for, each level in a folder of its own
                out = os.path.join(args.out, name, f"N{nx}") if args.output_every else None
                row = run_level(
                    METHODS[name], nx, args.ratio, args.t_end, args.gamma0, args.degree,
                    out, args.output_every,
                )  # fmt: skip
                results[name].append(row)
                if comm.rank == 0 and not args.quiet:  # one line per level: its progress
                    print(
                        f"{name:14s} N = {nx:4d}: l2(L2) {row['error_l2_l2']:.3e}, "
                        f"l2(H1) {row['error_l2_h1']:.3e} ({row['wall_seconds']:.1f} s)",
                        flush=True,
                    )
    if comm.rank != 0:
        return
    os.makedirs(args.out, exist_ok=True)
    write_csv(
        [row for rows in results.values() for row in rows],
        os.path.join(args.out, "convergence.csv"),
    )
    table = markdown_table(results)
    with open(os.path.join(args.out, "convergence.md"), "w") as f:
        f.write(table + "\n")
    print(table)
    if "hybrid" in results and len(levels) >= 3:
        print(acceptance(results["hybrid"]))
    print(f"table: {os.path.join(args.out, 'convergence.csv')}")
    if not args.no_plot:
        plot(results, args, os.path.join(args.out, "convergence_1d.png"))


if __name__ == "__main__":
    main()
