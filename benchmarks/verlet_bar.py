"""The explicit Verlet scheme on the bar against the exact solution: errors under refinement
with tau / h fixed, next to the hybrid scheme at the same tau and at equal cost (issue 29).

    python benchmarks/verlet_bar.py [--levels 50 100 200 400 800] [--ratio 0.5]
                                    [--t-end 6] [--repeat 3] [--out out/verlet_bar]

What it measures
----------------
The talk's bar (docs/method.md section 5: E = rho = c = 1, clamped at x = 1, wall at x = 0,
u0 = 1/2 - x/2, exact solution of period 3, energy 1/8), N P1 cells (h = 1/N), to T = 6
(two periods, four impacts and releases). For each level:

- **verlet**: the Verlet scheme, lumped P1 mass, Theta = 1, gamma0 = 0.5 (``--gamma0``),
  tau = ``--ratio`` * h / c (0.5 h). Why gamma0 = 0.5: the stable step estimated by the
  package (``ExplicitStepper.stable_dt``, printed for each level) is limited by the
  contact stiffness 1/gamma_h like h sqrt(rho gamma0) when gamma0 is small (1e-6, the
  talk's value, gives 1.4e-3 h: 700 times more steps than here) and by the bulk, h / c,
  from gamma0 = 1/2 on; gamma0 E must stay below 1, where A_Thgamma loses its coercivity
  (docs/method.md section 12). At gamma0 = 0.5 the estimate is h / c within 0.2%, so
  tau = 0.5 h / c is half the estimated stable step (the share ``dt = "auto"`` takes, for
  the energy the switching of the contact status pumps below the linear bound). The
  estimates for other gamma0 on one mesh are printed first (``--scan-nx``).
- **verlet, redistributed**: the same with the redistributed mass (the contact node
  massless, in equilibrium at each level: docs/method.md section 12).
- **hybrid, same tau**: the hybrid scheme with its defaults (the talk's: consistent mass,
  Theta = 1, gamma0 = 1e-6; ``--hybrid-gamma0``, ``--hybrid-mass``) at the verlet tau.
- **hybrid, equal cost**: the same with the tau whose time loop takes as long as verlet's
  on this mesh: first tau_eq = tau * r, r the measured ratio of the two loops at the same
  tau (the same number of steps: the cost ratio per step); then, as a loop also has costs
  that do not scale with its steps and the Newton iterations per step change with tau,
  the number of steps T / tau_eq is scaled by the inverse of the measured ratio of the
  loops until they differ by less than 10% (``--match-tolerance``), at most twice
  (``--match-iterations``). The ratio reached is reported next to the loop time.

The time loop is ``Simulation.run`` with the bar's history columns (the step, the energies
and the probes at x = 0 at every level), no files written; its wall time is the smallest of
``--repeat`` runs (the runs of the compared schemes in turn: the machine may be shared), and
the time of the steps alone (``step_seconds``) is also reported. Set-up is not timed.

The errors are those of ``demos/convergence_1d.py`` (``cases.bar_convergence_level``,
``exact.BarSpaceTimeErrors``): u in l2(tau; L2) and l2(tau; H1), the recorded contact
pressure lambda_h at x = 0 in l2(tau) and max_n |E^n - 1/8|; and from the timed run's
history (``exact.bar_contact_errors``) u and v at x = 0 in l2(0, T). Observed orders are
log(e_{k-1} / e_k) / log(h_{k-1} / h_k) (``exact.observed_orders``); for the equal-cost
runs tau / h is not fixed (it follows the measured cost ratio).

Prints, and writes to ``OUT``: ``verlet_bar.csv`` (one row per level and run, full
precision), ``verlet_bar.md`` (the table with the orders in parentheses, the stable steps),
``stable_steps.csv`` (the gamma0 scan) and ``verlet_bar.png`` (errors against h, log-log).
Serial only; about 11 minutes with the defaults.

What it shows
-------------
(dolfinx 0.5.2, serial, the defaults; the table is in README.md.)

- Verlet's errors of u (l2(L2), l2(H1), u(., 0)) and of the energy decrease at every level,
  with the hybrid's orders (about 0.7, 1/3, 0.7; the energy 1.00) and within 6% of the
  hybrid's at the same tau in l2(L2) and l2(H1) (16% at x = 0 on the coarsest mesh). The
  hybrid at the same tau costs 8 to 18 times more (its ratio grows with N). At equal cost
  its tau goes down only from 0.07 to 0.01 while h goes from 1/50 to 1/800, so its errors
  hardly decrease: 4 to 7 times verlet's in l2(L2), 2 to 2.4 times in l2(H1). The loop
  times are those of a shared machine: the equal-cost tau at N = 800 came out 0.0095,
  0.012 and 0.016 in three runs.
- With the redistributed mass v(., 0) and lambda_h(., 0) converge (order 1/3), the
  energy error is half the lumped one's; its loop is 2.5 to 6 times the lumped one's (a
  Newton solve on the massless node a step).
- With the lumped mass, v(., 0) and lambda_h(., 0) converge for neither scheme in
  l2(0, T) at the time levels.
  For verlet the cause is the semi-discrete problem, not the step: in 1D P1 with Theta = 1
  the stiffness with the contact active decouples the contact node from the bar for every
  gamma0 (the -(1 - gamma0)/h of A_Thgamma between the first two nodes and the
  +(1 - gamma0)/h of the contact term cancel; the node is left on a spring
  (1 - gamma0)/(gamma0 h) to the wall, and the bar sees a clamped end). With the lumped
  mass h/2 the node is an undamped oscillator of period 2 pi h / sqrt(2 (1 - gamma0) /
  gamma0) (4.44 h / c here, as measured) which keeps the impact speed 1/2 as its amplitude
  through the contact phase: v_h(t, 0) swings between -1/2 and 1/2, lambda_h between -0.88
  and -0.12 (mean -0.500), whatever h (N = 200 and 400 alike) and tau (from 0.1 h to 0.9 h,
  u_h(t, 0) within +-0.35 h to +-0.39 h). The hybrid's lambda_h alternates between 0 and
  -1 to -1.6 from one level to the next (docs/results.md). The energy E oscillates with
  that node: max |E - 1/8| = 0.24 h, in contact; E(T) - 1/8 = -0.05 h.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np
from mpi4py import MPI

from nitsche_dolfinx import Simulation
from nitsche_dolfinx.cases import (
    BAR_COLUMNS,
    BAR_METHODS,
    BarMethod,
    bar_contact_errors,
    bar_convergence_level,
    bar_problem,
    bar_simulation,
    observed_orders,
)
from nitsche_dolfinx.post import (
    latex_number,
    markdown_table,
    pyplot,
    save,
    slope_triangle,
    write_csv,
)
from nitsche_dolfinx.steppers import HybridScheme, VerletScheme

#: The runs of a level: key, label, marker.
RUNS = {
    "verlet": ("Verlet, lumped", "o"),
    "verlet_redistributed": ("Verlet, redistributed", "D"),
    "hybrid_tau": ("hybrid, same tau", "s"),
    "hybrid_cost": ("hybrid, equal cost", "^"),
}

#: The errors: key, header (u and v at x = 0 from exact.bar_contact_errors, the others from
#: cases.bar_convergence_level).
ERRORS = {
    "error_l2_l2": "l2(L2) u",
    "error_l2_h1": "l2(H1) u",
    "error_u_contact": "u(.,0)",
    "error_v_contact": "v(.,0)",
    "error_pressure": "lambda_h(.,0)",
    "error_energy": "max \\|E-1/8\\|",
}

COLUMNS = [
    "run", "N", "h", "tau", "steps", "stable_dt", "gamma0", "mass", *ERRORS,
    "error_stress", "penetration_max", "newton_iterations", "loop_s", "steps_s",
    "loop_ratio", "study_s",
]  # fmt: skip


def stable_step(nx: int, gamma0: float) -> float:
    """The package's estimated stable step of the lumped P1 bar (Theta = 1)."""
    problem = bar_problem(nx=nx, gamma0=gamma0, mass="lumped")
    return Simulation(problem, VerletScheme(), dt="auto", t_end=1.0).stepper.stable_dt


def timed_loop(scheme, nx: int, dt: float, t_end: float, gamma0: float, mass: str):
    """One time loop of the bar (``Simulation.run``, the bar's columns, no files): its wall
    time, the time of its steps alone and its history."""
    simulation = bar_simulation(scheme, mass=mass, dt=dt, t_end=t_end, nx=nx, gamma0=gamma0)
    start = time.perf_counter()
    history = simulation.run(columns=[*BAR_COLUMNS, "step_seconds"])
    loop = time.perf_counter() - start
    return loop, float(np.sum(history["step_seconds"][1:])), history


class Level:
    """The runs of one mesh (see the module docstring)."""

    def __init__(self, nx: int, args: argparse.Namespace):
        self.nx, self.args = nx, args
        self.tau = args.ratio / nx  # c = 1
        self.steps = round(args.t_end / self.tau)
        self.verlet = ("verlet", VerletScheme(), args.gamma0, "lumped")
        self.redistributed = ("verlet_redistributed", VerletScheme(), args.gamma0, "redistributed")
        self.hybrid = ("hybrid", HybridScheme(), args.hybrid_gamma0, args.hybrid_mass)
        self.times: dict[tuple, list] = {}
        self.histories: dict[tuple, object] = {}

    def time_in_turn(self, runs) -> None:
        """``--repeat`` rounds of the loops of ``runs`` ((run, tau) pairs), in turn."""
        for _ in range(self.args.repeat):
            for (name, scheme, gamma0, mass), tau in runs:
                loop, steps, history = timed_loop(
                    scheme, self.nx, tau, self.args.t_end, gamma0, mass
                )
                self.times.setdefault((name, tau), []).append((loop, steps))
                self.histories[(name, tau)] = history

    def fastest(self, name: str, tau: float) -> tuple[float, float]:
        """The smallest loop time of a run and the time of the steps in that loop."""
        return min(self.times[(name, tau)])

    def ratio(self, tau: float, name: str = "hybrid") -> float:
        """The fastest loop of run ``name`` at ``tau`` over verlet's fastest loop."""
        return self.fastest(name, tau)[0] / self.fastest("verlet", self.tau)[0]

    def equal_cost_step(self) -> float:
        """The hybrid's tau whose loop takes verlet's time: first tau times the cost ratio
        per step at the same tau; then, while the loops differ by more than
        ``--match-tolerance`` (a loop has costs that do not scale with the steps, and the
        Newton iterations per step change with tau), the number of steps scaled by the
        inverse of the measured ratio, at most ``--match-iterations`` times. T / tau is
        a whole number of steps."""
        args = self.args
        steps = max(1, round(self.steps / self.ratio(self.tau)))
        tried = set()
        for _ in range(args.match_iterations + 1):
            tau = args.t_end / steps
            tried.add(steps)
            self.time_in_turn([(self.verlet, self.tau), (self.hybrid, tau)])
            measured = self.ratio(tau)
            steps = max(1, round(steps / measured))
            if abs(measured - 1.0) <= args.match_tolerance or steps in tried:
                break
        return tau

    def measure(self) -> list[dict]:
        args, tau = self.args, self.tau
        stable = stable_step(self.nx, args.gamma0)
        if tau > stable:
            sys.exit(f"N = {self.nx}: tau = {tau:g} above the estimated stable step {stable:g}")
        # the cost per step of each scheme at the same tau, and the equal-cost tau
        self.time_in_turn([(self.verlet, tau), (self.redistributed, tau), (self.hybrid, tau)])
        tau_cost = self.equal_cost_step()
        methods = {
            "verlet": (BarMethod("Nitsche + Verlet", "nitsche", "verlet", "lumped"), tau),
            "verlet_redistributed": (
                BarMethod("Nitsche + Verlet", "nitsche", "verlet", "redistributed"),
                tau,
            ),
            "hybrid_tau": (BAR_METHODS["hybrid"], tau),
            "hybrid_cost": (BAR_METHODS["hybrid"], tau_cost),
        }
        rows = []
        for run, (method, dt) in methods.items():
            name, scheme, gamma0, mass = {"verlet": self.verlet,
                                          "verlet_redistributed": self.redistributed}.get(
                run, self.hybrid)  # fmt: skip
            method = BarMethod(method.label, method.method, method.scheme, mass)
            study = bar_convergence_level(method, self.nx, dt, args.t_end, gamma0, scheme=scheme)
            history = self.histories[(name, dt)]
            contact = bar_contact_errors(history, dt)
            loop, steps_s = self.fastest(name, dt)
            rows.append(
                {
                    **study,
                    "run": run,
                    "steps": len(history) - 1,
                    "stable_dt": stable if run == "verlet" else float("nan"),  # (lumped)
                    "gamma0": gamma0,
                    "mass": mass,
                    "error_u_contact": contact["error_u_contact"],
                    "error_v_contact": contact["error_v_contact"],
                    "penetration_max": contact["penetration_max"],
                    "loop_s": loop,
                    "steps_s": steps_s,
                    "loop_ratio": 1.0 if run == "verlet" else self.ratio(dt, name),
                    "study_s": study["wall_seconds"],
                }
            )
        return rows


def scan(args) -> list[dict]:
    """The estimated stable step on ``--scan-nx`` cells for several gamma0."""
    h = 1.0 / args.scan_nx
    rows = []
    for gamma0 in args.scan_gamma0:
        stable = stable_step(args.scan_nx, gamma0)
        rows.append({"N": args.scan_nx, "gamma0": gamma0, "stable_dt": stable,
                     "stable_dt_over_h": stable / h})  # fmt: skip
        print(f"N = {args.scan_nx}, gamma0 = {gamma0:g}: stable step {stable:.4g} = "
              f"{stable / h:.4g} h / c", flush=True)  # fmt: skip
    return rows


def orders(rows: list[dict], run: str, error: str) -> list[float]:
    mine = [row for row in rows if row["run"] == run]
    return observed_orders([row["h"] for row in mine], [row[error] for row in mine])


def table(rows: list[dict]) -> str:
    """The Markdown table: one line per level and run, each error with its observed order
    (from the coarser level) in parentheses."""
    order = {(run, e): orders(rows, run, e) for run in RUNS for e in ERRORS}
    levels = sorted({row["N"] for row in rows})
    header = ["N", "run", "tau", "loop (s)", *ERRORS.values()]
    cells = []
    for k, nx in enumerate(levels):
        for run, (label, _) in RUNS.items():
            row = next(r for r in rows if r["N"] == nx and r["run"] == run)
            loop = f"{row['loop_s']:.2f}"
            if run != "verlet":
                loop += f" ({row['loop_ratio']:.2f}x)"
            line = [str(nx), label, f"{row['tau']:.3g}", loop]
            for error in ERRORS:
                p = order[(run, error)][k]
                line.append(f"{row[error]:.2e}" + ("" if np.isnan(p) else f" ({p:.2f})"))
            cells.append(line)
    return markdown_table(header, cells)


def figure(rows: list[dict], title: str, path: str) -> None:
    """The errors against h, log-log, one panel per error, one curve per run."""
    plt = pyplot()
    if plt is None:
        return
    fig, axes = plt.subplots(2, 3, figsize=(13, 8))
    h = np.array(sorted({row["h"] for row in rows}))
    for ax, (error, header) in zip(axes.flat, ERRORS.items()):
        low = np.inf
        for run, (label, marker) in RUNS.items():
            mine = sorted((r for r in rows if r["run"] == run), key=lambda r: r["h"])
            values = np.array([r[error] for r in mine])
            ax.loglog([r["h"] for r in mine], values, marker=marker, label=label)
            low = min(low, values.min())
        slope_triangle(ax, h[0] * 1.15, low / 1.8, 0.5, "1/2")
        slope_triangle(ax, h[0] * 1.15 * 2.0**1.6, low / 1.8, 1.0, "1")
        ax.set_title(header.replace("\\|", "|"), fontsize="medium")
        ax.set_xlabel("$h$")
        ax.grid(alpha=0.3, which="both")
    fig.legend(*axes[0, 0].get_legend_handles_labels(), loc="lower center", ncol=len(RUNS))
    fig.suptitle(title)
    fig.subplots_adjust(left=0.06, right=0.98, top=0.9, bottom=0.12, hspace=0.3, wspace=0.25)
    save(fig, path, dpi=110)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n")[0],
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    parser.add_argument("--levels", type=int, nargs="+", default=[50, 100, 200, 400, 800],
                        help="numbers of cells N (h = 1/N)")  # fmt: skip
    parser.add_argument("--ratio", type=float, default=0.5, help="verlet's tau / (h / c)")
    parser.add_argument("--t-end", type=float, default=6.0, help="final time T")
    parser.add_argument("--gamma0", type=float, default=0.5, help="verlet's gamma0")
    parser.add_argument("--hybrid-gamma0", type=float, default=1e-6, help="hybrid's gamma0")
    parser.add_argument("--hybrid-mass", choices=["consistent", "lumped"],
                        default="consistent", help="hybrid's mass matrix")  # fmt: skip
    parser.add_argument("--repeat", type=int, default=3, help="timed loops of each run")
    parser.add_argument(
        "--match-tolerance",
        type=float,
        default=0.1,
        help="equal cost: the loops' largest relative difference",
    )
    parser.add_argument(
        "--match-iterations",
        type=int,
        default=2,
        help="equal cost: corrections of the hybrid's tau at most",
    )
    parser.add_argument("--scan-nx", type=int, default=100, help="mesh of the gamma0 scan")
    parser.add_argument("--scan-gamma0", type=float, nargs="*",
                        default=[1e-6, 1e-3, 1e-2, 0.1, 0.25, 0.5, 0.75],
                        help="gamma0 of the stable-step scan (none: no scan)")  # fmt: skip
    parser.add_argument("--out", default=os.path.join("out", "verlet_bar"))
    parser.add_argument("--no-plot", action="store_true", help="do not draw the figure")
    args = parser.parse_args(argv)
    if MPI.COMM_WORLD.size > 1:
        parser.error("serial only: the loops are timed against each other")
    if len(args.levels) < 2 or min(args.levels) < 1 or args.repeat < 1:
        parser.error("--levels needs two or more positive N, --repeat a positive number")
    os.makedirs(args.out, exist_ok=True)
    start = time.perf_counter()
    if args.scan_gamma0:
        scanned = scan(args)
        write_csv(os.path.join(args.out, "stable_steps.csv"), list(scanned[0]), scanned)
    rows = []
    for nx in sorted(args.levels):
        level = Level(nx, args)
        new = level.measure()
        rows += new
        verlet, redistributed, same, cost = new
        print(
            f"N = {nx}: stable step {verlet['stable_dt']:.4g} (tau = {level.tau:.4g} = "
            f"{level.tau / verlet['stable_dt']:.3f} of it); loops: verlet {verlet['loop_s']:.2f} s "
            f"(steps alone {verlet['steps_s']:.2f} s), redistributed "
            f"{redistributed['loop_s']:.2f} s, hybrid same tau {same['loop_s']:.2f} s "
            f"(x{same['loop_ratio']:.2f}, Newton/step {same['newton_iterations']:.2f}), "
            f"hybrid tau {cost['tau']:.4g} {cost['loop_s']:.2f} s (x{cost['loop_ratio']:.2f})",
            flush=True,
        )
    write_csv(os.path.join(args.out, "verlet_bar.csv"), COLUMNS, rows)
    text = table(rows)
    stable = ", ".join(
        f"N = {r['N']}: {r['stable_dt']:.4g} ({r['stable_dt'] * r['N']:.4f} h)"
        for r in rows if r["run"] == "verlet"
    )  # fmt: skip
    with open(os.path.join(args.out, "verlet_bar.md"), "w") as f:
        f.write(text + f"\n\nEstimated stable steps of the verlet runs: {stable}.\n")
    print(text)
    print(f"estimated stable steps: {stable}")
    print(f"wall time {time.perf_counter() - start:.0f} s; table: "
          f"{os.path.join(args.out, 'verlet_bar.csv')}")  # fmt: skip
    if not args.no_plot:
        title = (
            f"bar, T = {args.t_end:g}: Verlet (lumped, "
            f"$\\gamma_0 = {latex_number(args.gamma0)}$, $\\tau = {args.ratio:g}\\,h/c$) and "
            f"hybrid ({args.hybrid_mass}, $\\gamma_0 = {latex_number(args.hybrid_gamma0)}$)"
        )
        figure(rows, title, os.path.join(args.out, "verlet_bar.png"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
