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
#
# The defaults are the talk's: $\Theta = 1$, $\gamma_0 = 10^{-6}$, 100 P1
# elements ($h = 0.01$), $\tau = 0.015$, $T = 6$ (two periods). Measured
# with them (dolfinx 0.5.2, serial; the table this demo prints also has the
# Newton iterations and the wall time), with errors at $x = 0$ in
# $\ell^2(0, T)$:
#
# | run | E(T)/E(0)-1 | max \|E-1/8\| | error u | error v | error pressure | penetration |
# |---|---|---|---|---|---|---|
# | Mixed + CN | +5.52% | 7.29e-03 | 1.84e-02 | 5.34e-01 | 5.45e-01 | 3.5e-18 |
# | Nitsche + CN | +7.02% | 8.78e-03 | 1.50e-02 | 6.23e-01 | 5.65e-01 | 9.8e-09 |
# | Nitsche hybrid | -1.01% | 1.26e-03 | 2.02e-02 | 4.06e-01 | 8.00e-01 | 9.5e-09 |
# | Modified mass + CN | -1.69% | 2.13e-03 | 2.75e-02 | 2.75e-01 | 1.81e-01 | 2.7e-15 |
# | Penalty + hybrid | -1.01% | 1.26e-03 | 2.02e-02 | 4.06e-01 | 8.00e-01 | 1.7e-08 |
#
# What they show, as the talk says:
#
# - **Mixed + CN** and **Nitsche + CN** are almost the same run (with
#   $\gamma_0 = 10^{-6}$ Nitsche is very close to the multiplier): the
#   contact point bounces on the wall during the contact phases instead of
#   staying on it, its velocity oscillates, and the energy is not conserved:
#   it loses a little at the first impact, then *grows* (+5.5% and +7.0% at
#   $T = 6$; over four periods, $T = 12$, +172% and +92%: the growth
#   accelerates).
# - **Nitsche hybrid** keeps the contact point on the wall to $10^{-8}$
#   (about $\gamma_h |\sigma_n|$), loses 1% of the energy, only at the
#   impacts, and never gains any. With this $\gamma_0$ the **penalty**
#   method ($\varepsilon = 10^{-8}$) with the hybrid scheme gives the same
#   numbers but the penetration, which is about $1.6\,\varepsilon$ instead.
# - **Modified mass + CN** keeps $u_h(t, 0)$ on the wall to round-off with no
#   oscillation at all and has the best contact pressure and velocity, but
#   it loses more energy: 1.3% in the very first step (its massless contact
#   node relaxes at once from $u_0$, whose stress $-1/2$ at the free end
#   $x = 0$ is not in equilibrium; the loss is $0.16\, h$), then a little at
#   each impact (-1.7% at $T = 6$, -1.9% at $T = 12$). Its displacement error
#   is the largest of the four at this $h$ but it converges a little faster
#   (`demos/convergence_1d.py`).
#
# Two things differ from the talk's figures, for known reasons:
#
# - the contact pressure of the Nitsche runs, $\lambda_h(t^n, 0)
#   = -\frac{1}{\gamma_h}[P_\gamma(u_h^n)]_+$, alternates at the time levels
#   between about 0 and about $-1$ during contact (hybrid) because the very
#   stiff constraint ($1/\gamma_h = 10^8$) makes $u_h^n(0)$ alternate around
#   the wall by $10^{-8}$; its mean over a contact phase is close to $-1/2$,
#   but its $\ell^2$ error is not small. The force the hybrid scheme applies
#   *over a step* is not a recorded column;
# - the velocity $\dot u_h(t, 0)$ of the modified mass run is that of a
#   massless node: Crank-Nicolson's kinematics
#   $\dot u^{n+1} = 2 (u^{n+1} - u^n)/\tau - \dot u^n$ would make it alternate
#   around the true velocity (by $\pm 2/3$ in flight, $\pm 1$ in contact)
#   although it plays no part in the dynamics (the node has no mass), so the
#   library records the mean velocity of the step, $(u^{n+1} - u^n)/\tau$, there.
#
# The five runs take half a second each.
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
from nitsche_dolfinx.arguments import finite_float, one_line_errors
from nitsche_dolfinx.cases import BAR_COLUMNS
from nitsche_dolfinx.exact import BAR_ENERGY, bar_contact_values
from nitsche_dolfinx.plotting import latex_number, pyplot, save
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
    history = simulation.run(out=os.path.join(args.out, spec.name), columns=BAR_COLUMNS)
    return history, time.perf_counter() - start


def contact_velocity(spec: Run, history) -> tuple[np.ndarray, np.ndarray]:
    """Times and values of the velocity at x = 0 (for a massless contact node the library
    records the mean velocity of the step that ends there)."""
    return history["t"], history["v_contact"]


def measure(spec: Run, history, seconds: float, dt: float) -> dict:
    """The numbers of the summary table for one run."""
    t = history["t"]
    u_exact, _, sigma_exact = bar_contact_values(t)
    t_v, v = contact_velocity(spec, history)
    _, v_exact, _ = bar_contact_values(t_v)
    return {
        "energy_drift": history.energy_drift(),
        "energy_error_max": np.max(np.abs(history["energy"] - BAR_ENERGY)),
        "error_u_contact": np.sqrt(dt * np.sum((history["u_contact"] - u_exact) ** 2)),
        "error_v_contact": np.sqrt(dt * np.sum((v - v_exact) ** 2)),
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

    t_exact = np.linspace(0.0, args.t_end, 4001)  # fine, so that the kinks stay sharp
    exact = dict(zip(("u_contact", "v_contact", "sigma_contact"), bar_contact_values(t_exact)))
    panels = (
        ("u_contact", "displacement $u_h(t, 0)$"),
        ("v_contact", r"velocity $\dot u_h(t, 0)$"),
        ("sigma_contact", "contact pressure at $x = 0$"),
        ("energy", "energy $E^h$"),
    )
    fig = plt.figure(figsize=(14, 8.5), constrained_layout=True)
    grid = fig.add_gridspec(2, 6)
    # the displacement, a zoom on it, and the three other panels of the talk
    u_ax = fig.add_subplot(grid[0, 0:2])
    zoom = fig.add_subplot(grid[0, 2])
    axes = [u_ax, fig.add_subplot(grid[0, 3:]), fig.add_subplot(grid[1, :3])]
    axes.append(fig.add_subplot(grid[1, 3:]))
    for ax, (name, title) in zip(axes, panels):
        if name == "energy":
            ax.axhline(BAR_ENERGY, color="black", lw=1.5, label="exact", zorder=10)
        else:
            ax.plot(t_exact, exact[name], color="black", lw=1.5, label="exact", zorder=10)
        for spec, history in zip(specs, histories):
            t, values = history["t"], history[name]
            label = spec.label
            if name == "v_contact":
                t, values = contact_velocity(spec, history)
                if spec.mass == "redistributed":
                    label += r", $(u^{n+1} - u^n)/\tau$"
            ax.plot(
                t,
                values,
                color=spec.color,
                ls=spec.linestyle,
                lw=0.9,
                alpha=0.9,
                zorder=spec.zorder,
                label=label,
            )
        ax.set_title(title)
        ax.set_xlabel("time $t$")
        ax.grid(alpha=0.3)
    axes[1].legend(loc="upper left", fontsize="x-small")
    # who stays on the wall during the second contact phase
    zoom.plot(t_exact, exact["u_contact"], color="black", lw=1.5, zorder=0)  # under the runs
    for spec, history in zip(specs, histories):
        zoom.plot(history["t"], history["u_contact"], color=spec.color, ls=spec.linestyle, lw=0.9)
    zoom.set_xlim(3.95, 5.1)
    zoom.set_ylim(-3e-4, 6.5e-3)
    zoom.set_title("zoom: second contact", fontsize="medium")
    zoom.set_xlabel("time $t$")
    zoom.grid(alpha=0.3)
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
