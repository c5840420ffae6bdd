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
# This demo reproduces the comparison figure of the talk of Chouly, Hild &
# Renard ("A Nitsche finite element method for dynamic contact", M2AN 49,
# 2015), "Mixed(+CN) vs Nitsche(+CN) vs Nitsche-Hybrid", on the 1D bar with
# multiple impacts of `demos/bar_1d.py`, and adds the method the talk
# compares the hybrid scheme with in its conclusion: the modified mass
# method of Khenous, Laborde & Renard (2008).
#
# It shows how to
#
# - run the same problem with several contact methods, time schemes and
#   mass matrices through `nitsche_dolfinx.cases.bar_simulation`;
# - measure each run against the exact solution (errors at the contact point,
#   energy, penetration) and gather the numbers in one table;
# - draw the four panels of the talk: displacement, velocity and contact
#   pressure at $x = 0$, and the energy.
#
# ## The methods
#
# The bar $(0, 1)$ ($E = \rho = 1$, clamped at $x = 1$, wall at $x = 0$,
# $u_0 = 1/2 - x/2$, $v_0 = 0$) has an exact solution of period 3 and
# energy $1/8$: flight towards the wall for $0 \le s \le 1$ ($s = t \bmod 3$),
# contact with the pressure $-1/2$ for $1 \le s \le 2$, release for
# $2 \le s \le 3$. The runs, each into `OUT/<name>/history.csv`:
#
# | name | method | time scheme | mass |
# |---|---|---|---|
# | `mixed_cn` | Lagrange multiplier (Alart-Curnier) | Crank-Nicolson | consistent |
# | `nitsche_cn` | Nitsche, $\Theta = 1$ | Crank-Nicolson | consistent |
# | `nitsche_hybrid` | Nitsche, $\Theta = 1$ | hybrid | consistent |
# | `modified_mass` | Lagrange multiplier | Crank-Nicolson | redistributed |
# | `penalty_hybrid` (`--penalty`) | penalty, $\varepsilon = \gamma_0 h$ | hybrid | consistent |
#
# The *modified mass* method removes the mass of the contact node and gives
# it to its neighbours (total mass kept; here on the lumped mass matrix):
# the contact node then has no inertia, the semi-discrete problem is well
# posed, and Crank-Nicolson keeps $u_h(t, 0) \ge 0$ without oscillating.
# The mixed method with the consistent mass is the ill-posed semi-discrete
# problem of the talk's introduction.
# The defaults are the talk's: $\Theta = 1$, $\gamma_0 = 10^{-6}$, 100 P1
# elements, $\tau = 0.015$, $T = 6$. The table the demo prints, and what it
# shows, are in `docs/results.md`.
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

from nitsche_dolfinx import cases
from nitsche_dolfinx.arguments import add_terminal_arguments, finite_float
from nitsche_dolfinx.cases import BAR_COLUMNS
from nitsche_dolfinx.errors import one_line_errors
from nitsche_dolfinx.exact import BAR_ENERGY, bar_contact_values
from nitsche_dolfinx.parameters import OutputParameters
from nitsche_dolfinx.plotting import bar_panels, latex_number, pyplot, save
from nitsche_dolfinx.schemes import make_scheme


@dataclass(frozen=True)
class Run:
    """One contact method of the comparison."""

    name: str  # folder and CSV name
    label: str  # legend
    method: str  # "nitsche", "penalty" or "mixed"
    scheme: str  # "cn" or "hybrid"
    mass: str  # "consistent" or "redistributed"
    color: str
    zorder: int = 1  # the smooth curves on top of the oscillating ones
    linestyle: str = "-"


RUNS = (
    Run("mixed_cn", "Mixed + CN", "mixed", "cn", "consistent", "tab:orange", 1),
    Run("nitsche_cn", "Nitsche + CN", "nitsche", "cn", "consistent", "tab:red", 2),
    Run("nitsche_hybrid", "Nitsche hybrid", "nitsche", "hybrid", "consistent", "tab:blue", 3),
    Run("modified_mass", "Modified mass + CN", "mixed", "cn", "redistributed", "tab:green", 5),
)
PENALTY = Run(
    "penalty_hybrid", "Penalty + hybrid", "penalty", "hybrid", "consistent", "tab:purple", 4, "--"
)

# Columns of OUT/summary.csv, with their headers in the Markdown table
SUMMARY_COLUMNS = {
    "energy_drift": "E(T)/E(0)-1",
    "energy_error_max": "max \\|E - 1/8\\|",
    "error_u_contact": "l2 err u(.,0)",
    "error_v_contact": "l2 err v(.,0)",
    "error_sigma_contact": "l2 err pressure",
    "penetration_max": "max penetration",
    "newton_iterations": "Newton/step",
    "wall_seconds": "wall time (s)",
}
# -

# ### Command line


def make_parser() -> argparse.ArgumentParser:
    """The command-line parser of the demo."""
    parser = argparse.ArgumentParser(
        description="1D bouncing bar: mixed, Nitsche, hybrid and modified mass methods compared.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    parser.add_argument("--nx", type=int, default=100, help="number of cells")
    parser.add_argument("--dt", type=finite_float, default=0.015, help="time step tau")
    parser.add_argument("--t-end", type=finite_float, default=6.0, help="final time T")
    parser.add_argument(
        "--gamma0",
        type=finite_float,
        default=1e-6,
        help="Nitsche parameter, gamma_h = gamma0 h (penalty: eps = gamma0 h)",
    )
    parser.add_argument(
        "--penalty", action="store_true", help="also run the penalty method with the hybrid scheme"
    )
    parser.add_argument(
        "--out", default=os.path.join("out", "compare_methods_1d"), help="output folder"
    )
    add_terminal_arguments(parser, output_every=0)
    parser.add_argument("--no-plot", action="store_true", help="do not draw the figure")
    return parser


# ### Running and measuring
#
# Every run is `cases.bar_simulation` with the method, the scheme and the
# mass of its row; the Nitsche variant is the symmetric one, $\Theta = 1$
# (the mixed method ignores $\gamma_0$). The errors at the contact point are
# $\ell^2(0, T)$ norms over the time levels, e.g.
# $\big(\sum_n \tau |u_h(t^n, 0) - u(t^n, 0)|^2\big)^{1/2}$; the penetration
# is $\max_n (-u_h(t^n, 0))$. The wall time includes building the problem
# (and compiling its forms when they are not in the cache yet).


def run(spec: Run, args: argparse.Namespace):
    """Run ``spec``, writing ``OUT/<name>/history.csv``; its History and wall time."""
    start = time.perf_counter()
    simulation = cases.bar_simulation(
        make_scheme(spec.scheme),
        method=spec.method,
        mass=spec.mass,
        dt=args.dt,
        t_end=args.t_end,
        nx=args.nx,
        gamma0=args.gamma0,
        nitsche_theta=1.0,
    )
    out = os.path.join(args.out, spec.name)
    history = simulation.run(out=out, columns=BAR_COLUMNS, output_every=args.output_every)
    seconds = time.perf_counter() - start
    if not args.quiet and MPI.COMM_WORLD.rank == 0:  # one line per run: its progress
        print(f"{spec.label:20s} {len(history) - 1} steps in {seconds:.2f} s", flush=True)
    return history, seconds


def measure(spec: Run, history, seconds: float, dt: float) -> dict:
    """The numbers of the summary table for one run."""
    t = history["t"]
    u_exact, _, sigma_exact = bar_contact_values(t)
    _, v_exact, _ = bar_contact_values(t)
    return {
        "energy_drift": history.energy_drift(),
        "energy_error_max": np.max(np.abs(history["energy"] - BAR_ENERGY)),
        "error_u_contact": np.sqrt(dt * np.sum((history["u_contact"] - u_exact) ** 2)),
        "error_v_contact": np.sqrt(dt * np.sum((history["v_contact"] - v_exact) ** 2)),
        "error_sigma_contact": np.sqrt(dt * np.sum((history["sigma_contact"] - sigma_exact) ** 2)),
        "penetration_max": max(-np.min(history["u_contact"]), 0.0),
        "newton_iterations": history.mean_newton_iterations(),
        "wall_seconds": seconds,
    }


def format_value(name: str, value: float) -> str:
    """A summary value as text for the Markdown table."""
    if name == "energy_drift":
        return f"{value:+.2%}"
    if name == "penetration_max":
        return f"{value:.1e}"
    if name in ("newton_iterations", "wall_seconds"):
        return f"{value:.2f}"
    return f"{value:.2e}"


def write_summary(specs: list[Run], rows: list[dict], out: str) -> str:
    """Write ``summary.csv`` (full precision) and ``summary.md``; return the Markdown table."""
    with open(os.path.join(out, "summary.csv"), "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["run", "label", *SUMMARY_COLUMNS])
        for spec, row in zip(specs, rows):
            writer.writerow(
                [spec.name, spec.label, *(repr(float(row[c])) for c in SUMMARY_COLUMNS)]
            )
    lines = [
        "| run | " + " | ".join(SUMMARY_COLUMNS.values()) + " |",
        "|---" * (len(SUMMARY_COLUMNS) + 1) + "|",
    ]
    for spec, row in zip(specs, rows):
        values = " | ".join(format_value(c, row[c]) for c in SUMMARY_COLUMNS)
        lines.append(f"| {spec.label} | {values} |")
    table = "\n".join(lines)
    with open(os.path.join(out, "summary.md"), "w") as f:
        f.write(table + "\n")
    return table


# ### The figure
#
# The four panels of the talk, each over the exact solution (black), and a
# zoom on the displacement during the second contact phase. The velocity of
# the modified mass run is its mean velocity over each step (see above).
# matplotlib is optional.


def plot(specs: list[Run], histories: list, args: argparse.Namespace, path: str) -> None:
    """Draw u(t, 0), v(t, 0), the contact pressure and the energy of every run into ``path``."""
    plt = pyplot()
    if plt is None:
        return
    fig = plt.figure(figsize=(14, 8.5), constrained_layout=True)
    grid = fig.add_gridspec(2, 6)
    # the displacement, a zoom on it, and the three other panels of the talk
    zoom = fig.add_subplot(grid[0, 2])
    axes = [fig.add_subplot(grid[0, 0:2]), fig.add_subplot(grid[0, 3:])]
    axes += [fig.add_subplot(grid[1, :3]), fig.add_subplot(grid[1, 3:])]
    labels = [
        spec.label + (r", $(u^{n+1} - u^n)/\tau$" if spec.mass == "redistributed" else "")
        for spec in specs
    ]
    styles = [
        {"color": s.color, "ls": s.linestyle, "lw": 0.9, "alpha": 0.9, "zorder": s.zorder}
        for s in specs
    ]
    bar_panels(axes, histories, labels, styles, args.t_end)
    for ax in axes:
        ax.set_xlabel("time $t$")
    axes[1].legend(loc="upper left", fontsize="x-small")
    # who stays on the wall during the second contact phase
    bar_panels([zoom], histories, labels, styles, args.t_end)
    zoom.set_xlim(3.95, 5.1)
    zoom.set_ylim(-3e-4, 6.5e-3)
    zoom.set_title("zoom: second contact", fontsize="medium")
    zoom.set_xlabel("time $t$")
    fig.suptitle(
        rf"1D bouncing bar: Nitsche $\Theta = 1$, $\gamma_0 = {latex_number(args.gamma0)}$, "
        rf"P1, $h = {latex_number(1 / args.nx)}$, $\tau = {latex_number(args.dt)}$"
    )
    save(fig, path, dpi=150)


# ### Main


def main(argv: list[str] | None = None) -> None:
    """Run the demo with the command-line arguments ``argv``."""
    parser = make_parser()
    args = parser.parse_args(argv)
    specs = list(RUNS) + ([PENALTY] if args.penalty else [])
    with one_line_errors(parser):
        OutputParameters(args.output_every)  # checked before any run
        runs = [run(spec, args) for spec in specs]
    if MPI.COMM_WORLD.rank != 0:
        return
    rows = [
        measure(spec, history, seconds, args.dt) for spec, (history, seconds) in zip(specs, runs)
    ]
    histories = [history for history, _ in runs]
    print(write_summary(specs, rows, args.out))
    print(
        f"summary: {os.path.join(args.out, 'summary.csv')}, {os.path.join(args.out, 'summary.md')}"
    )
    if not args.no_plot:
        plot(specs, histories, args, os.path.join(args.out, "compare_methods_1d.png"))


if __name__ == "__main__":
    main()
