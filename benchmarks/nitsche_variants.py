"""Robustness of the Nitsche variants Theta = 1, 0, -1 against the Nitsche parameter gamma0.

What it measures
----------------
The 1D bar with multiple impacts of the talk (docs/method.md section 5: Omega = (0, 1),
E = rho = 1, clamped at x = 1, wall at x = 0, u0 = 1/2 - x/2, v0 = 0; 100 P1
elements, tau = 0.015, T = 6, i.e. two periods of the exact solution), marched
with the hybrid scheme (or another one, ``--scheme``) for every variant Theta in
{1, 0, -1} and every gamma0 of a log sweep (1e-6 ... 1e8 by default). Per run:

- ``converged``: whether every SNES solve converged. On the first
  :class:`nitsche_dolfinx.SolverError` the run stops; the step, time and SNES
  reason are recorded (the remaining columns then cover the steps done).
- ``max_newton``: the largest number of Newton iterations of a step.
- ``max_dEtheta``: the largest per-step increase of E_Theta (<= 0 up to round-off
  for the hybrid scheme with Theta = 1 and small gamma0).
- ``energy_rel_T``: (E(T) - E(0)) / E(0) for the energy E (``energy`` column).
- ``energy_rel_max``: max over t of (E(t) - E(0)) / E(0).
- ``penetration_max``: max over t of -u(t, 0) = u_n - g at the wall (> 0: penetration).
- ``l2_error``: sqrt(tau sum_n (u(t_n, 0) - u_exact(t_n, 0))^2), the l2(tau) error at
  the wall against :func:`nitsche_dolfinx.cases.exact.bar_contact_values`.

Conclusions printed per variant: the gamma0 values where Newton fails (the first
one in the sweep) and those where the energy is not bounded, meaning: the run
produced non-finite values, or E(T) is more than ``--energy-tolerance`` (10 %)
above the exact energy 1/8, or E(t) ever exceeds ``--blowup-factor`` (2) times 1/8.
Runs that stopped on a Newton failure are judged on the steps they did.

How to run
----------
From the repository root::

    PYTHONPATH=. python3 benchmarks/nitsche_variants.py
    PYTHONPATH=. python3 benchmarks/nitsche_variants.py --scheme cn --out cn.csv
    PYTHONPATH=. python3 benchmarks/nitsche_variants.py --gamma0 1e-6 1 100 --variants 1 -1

``--out FILE`` also writes the table as CSV (full precision). ``--max-it`` sets
SNES's ``snes_max_it`` (default 50, the library default). A full sweep (3 variants x
15 values of gamma0, 400 steps each) takes well under a minute.
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import sys
import time

import numpy as np
from petsc4py import PETSc

from nitsche_dolfinx import (
    BAR_CLAMPED,
    BAR_CONTACT,
    SCHEMES,
    ContactProblem,
    Material,
    PlaneObstacle,
    Simulation,
    SolverError,
    bar_mesh,
    make_scheme,
)
from nitsche_dolfinx.cases import BAR_ENERGY, bar_contact_values
from nitsche_dolfinx.output import BoundaryAverage

DEFAULT_GAMMA0 = [10.0**k for k in range(-6, 9)]
DEFAULT_VARIANTS = [1.0, 0.0, -1.0]

CSV_COLUMNS = (
    "scheme",
    "nitsche_theta",
    "gamma0",
    "converged",
    "steps_done",
    "num_steps",
    "fail_step",
    "fail_t",
    "fail_reason",
    "max_newton",
    "max_dEtheta",
    "energy_rel_T",
    "energy_rel_max",
    "penetration_max",
    "l2_error",
    "energy_bounded",
    "failed_after_blowup",
    "seconds",
)


def run_case(mesh, tags, scheme_args, nitsche_theta, gamma0, dt, t_end, petsc_options):
    """One simulation of the bar; returns a dict of the measured quantities."""
    start = time.perf_counter()
    scheme = make_scheme(*scheme_args)
    problem = ContactProblem(
        mesh, tags, Material(E=1.0, nu=0.0, rho=1.0), gamma0=gamma0, nitsche_theta=nitsche_theta
    )
    problem.add_dirichlet(BAR_CLAMPED, 0.0)
    problem.add_obstacle(PlaneObstacle([0.0], [1.0]), BAR_CONTACT)
    problem.set_initial_conditions(displacement=lambda x: 0.5 - x[0] / 2)

    result = {
        "scheme": scheme.describe(),
        "nitsche_theta": nitsche_theta,
        "gamma0": gamma0,
        "converged": True,
        "fail_step": "",
        "fail_t": "",
        "fail_reason": "",
    }
    records = []
    try:
        sim = Simulation(problem, scheme, dt=dt, t_end=t_end, petsc_options=petsc_options)
    except (SolverError, PETSc.Error) as error:  # the initial acceleration solve
        sim = None
        result.update(converged=False, fail_step=0, fail_t=0.0, fail_reason=_reason(error))
    if sim is not None:
        result["num_steps"] = sim.num_steps
        ds = problem.ds(BAR_CONTACT)
        sim.add_probe("u_contact", BoundaryAverage(mesh, sim.u[0], ds))
        records.append(sim.state())
        while sim.step_index < sim.num_steps:
            try:
                sim.step()
            except (SolverError, PETSc.Error) as error:
                result.update(
                    converged=False,
                    fail_step=sim.step_index + 1,
                    fail_t=sim.t + dt,
                    fail_reason=_reason(error),
                )
                break
            records.append(sim.state())
            if not np.all(np.isfinite(sim.u.x.array)):
                result.update(
                    converged=False,
                    fail_step=sim.step_index,
                    fail_t=sim.t,
                    fail_reason="non-finite displacement",
                )
                break
        sim.solver.destroy()
    else:
        result["num_steps"] = int(round(t_end / dt))
    result.update(_measures(records, dt))
    result["seconds"] = time.perf_counter() - start
    return result


def _forget_new_options(before) -> None:
    """Delete the PETSc options set since ``before`` (the solvers of a finished run).

    Every ``SNESSolver`` writes its options under a fresh prefix into the global
    PETSc options database and never removes them; PETSc 3.18 holds at most 512
    options, so without this clean-up the 29th run or so fails with PETSc error 55
    ("can not allocate enough space") while setting its options.
    """
    database = PETSc.Options()
    for name in set(database.getAll()) - set(before):
        database.delValue(name)


def _reason(error) -> str:
    if isinstance(error, SolverError):
        return f"{error.reason_name} ({error.iterations} its, |F| = {error.residual_norm:.2e})"
    return f"PETSc error {getattr(error, 'ierr', '?')}"


def _measures(records, dt) -> dict:
    """The quantities of the table from the history ``records`` (one dict per time level)."""
    nan = float("nan")
    if not records:
        return {
            "steps_done": 0,
            "max_newton": 0,
            "max_dEtheta": nan,
            "energy_rel_T": nan,
            "energy_rel_max": nan,
            "penetration_max": nan,
            "l2_error": nan,
        }
    t = np.array([r["t"] for r in records])
    u = np.array([r["u_contact"] for r in records])
    energy = np.array([r["energy"] for r in records])
    energy_theta = np.array([r["energy_theta"] for r in records])
    iterations = [r["newton_iterations"] for r in records[1:]]
    u_exact, _, _ = bar_contact_values(t)
    return {
        "steps_done": len(records) - 1,
        "max_newton": max(iterations, default=0),
        "max_dEtheta": float(np.diff(energy_theta).max()) if len(records) > 1 else nan,
        "energy_rel_T": float((energy[-1] - energy[0]) / energy[0]),
        "energy_rel_max": float((energy.max() - energy[0]) / energy[0]),
        "penetration_max": float((-u).max()),
        "l2_error": float(np.sqrt(dt * np.sum((u - u_exact) ** 2))),
    }


def energy_bounded(row, tolerance, blowup_factor) -> bool:
    """E stays bounded: finite, E(T) <= (1 + tolerance) / 8 and max E <= blowup_factor / 8."""
    e_end = BAR_ENERGY * (1.0 + row["energy_rel_T"])
    e_max = BAR_ENERGY * (1.0 + row["energy_rel_max"])
    if not (math.isfinite(e_end) and math.isfinite(e_max)):
        return False
    return e_end <= (1.0 + tolerance) * BAR_ENERGY and e_max <= blowup_factor * BAR_ENERGY


def _fmt(value, spec=".2e") -> str:
    if value == "" or value is None:
        return ""
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    return format(value, spec)


def markdown_table(rows) -> str:
    header = (
        "| Theta | gamma0 | converged | failure (step, t, reason) | max Newton "
        "| max dE_Theta | E(T)/E(0)-1 | max E/E(0)-1 | max pen. -u(t,0) | l2 err u(t,0) "
        "| E bounded |"
    )
    lines = [header, _separator(header)]
    for row in rows:
        partial = "" if row["converged"] else " *"
        failure = ""
        if not row["converged"]:
            failure = f"{row['fail_step']}, t={row['fail_t']:.3f}, {row['fail_reason']}"
        cells = [
            f"{row['nitsche_theta']:g}",
            f"{row['gamma0']:g}",
            "yes" if row["converged"] else "**no**",
            failure,
            str(row["max_newton"]),
            _fmt(row["max_dEtheta"]) + partial,
            _fmt(row["energy_rel_T"], "+.3e") + partial,
            _fmt(row["energy_rel_max"], "+.3e") + partial,
            _fmt(row["penetration_max"]) + partial,
            _fmt(row["l2_error"], ".3e") + partial,
            "yes" if row["energy_bounded"] else "**no**",
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _separator(header: str) -> str:
    return "|" + "---|" * (header.count("|") - 1)


def _list_values(values) -> str:
    return ", ".join(f"{v:g}" for v in values) if values else "none"


def conclusions(rows, variants, tolerance, blowup_factor) -> str:
    """Per variant: where Newton fails, where the energy is unbounded, penetration and error."""
    lines = []
    for theta in variants:
        mine = sorted((r for r in rows if r["nitsche_theta"] == theta), key=lambda r: r["gamma0"])
        if not mine:
            continue
        failed = [r for r in mine if not r["converged"]]
        unbounded = [r["gamma0"] for r in mine if not r["energy_bounded"]]
        ok = [r for r in mine if r["converged"] and r["energy_bounded"]]
        lines.append(f"- Theta = {theta:g}:")
        if failed:
            after = [r["gamma0"] for r in failed if r["failed_after_blowup"]]
            genuine = [r["gamma0"] for r in failed if not r["failed_after_blowup"]]
            lines.append(
                f"  Newton first fails at gamma0 = {failed[0]['gamma0']:g} "
                f"(all failures: {_list_values([r['gamma0'] for r in failed])}); "
                f"after E had already passed {blowup_factor:g}/8: {_list_values(after)}; "
                f"with E still bounded: {_list_values(genuine)}."
            )
        else:
            lines.append(
                f"  Newton converges at every step for all gamma0 up to {mine[-1]['gamma0']:g}."
            )
        if unbounded:
            lines.append(
                f"  Energy first unbounded at gamma0 = {unbounded[0]:g} "
                f"(all: {_list_values(unbounded)}; E(T) > {1 + tolerance:g}/8 or "
                f"max E > {blowup_factor:g}/8 or non-finite, judged on the steps done)."
            )
        else:
            lines.append(f"  Energy bounded for all gamma0 up to {mine[-1]['gamma0']:g}.")
        if ok:
            lines.append(
                "  Good runs, gamma0: max penetration / l2 error of u(t,0): "
                + ", ".join(
                    f"{r['gamma0']:g}: {r['penetration_max']:.2e} / {r['l2_error']:.2e}" for r in ok
                )
                + "."
            )
    return "\n".join(lines)


def parse_args(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--scheme", choices=SCHEMES, default="hybrid")
    parser.add_argument("--theta", type=float, default=1.0, help="theta of the theta-scheme")
    parser.add_argument("--beta", type=float, default=0.25, help="Newmark beta")
    parser.add_argument("--gamma", type=float, default=0.5, help="Newmark gamma")
    parser.add_argument(
        "--variants",
        type=float,
        nargs="+",
        default=DEFAULT_VARIANTS,
        help="values of the Nitsche variant Theta",
    )
    parser.add_argument(
        "--gamma0",
        type=float,
        nargs="+",
        default=DEFAULT_GAMMA0,
        help="values of the Nitsche parameter gamma0",
    )
    parser.add_argument("--nx", type=int, default=100)
    parser.add_argument("--dt", type=float, default=0.015)
    parser.add_argument("--t-end", type=float, default=6.0)
    parser.add_argument("--max-it", type=int, default=50, help="SNES snes_max_it")
    parser.add_argument(
        "--energy-tolerance",
        type=float,
        default=0.10,
        help="E(T) above (1 + this)/8 counts as unbounded",
    )
    parser.add_argument(
        "--blowup-factor",
        type=float,
        default=2.0,
        help="max E above this times 1/8 counts as unbounded",
    )
    parser.add_argument("--out", help="also write the table to this CSV file")
    return parser.parse_args(argv)


def main(argv=None) -> int:
    args = parse_args(argv)
    mesh, tags = bar_mesh(args.nx)
    scheme_args = (args.scheme, args.theta, args.beta, args.gamma)
    petsc_options = {"snes_max_it": args.max_it}
    rows = []
    start = time.perf_counter()
    for theta in args.variants:
        for gamma0 in sorted(args.gamma0):
            options_before = set(PETSc.Options().getAll())
            row = run_case(
                mesh, tags, scheme_args, theta, gamma0, args.dt, args.t_end, petsc_options
            )
            _forget_new_options(options_before)
            row["energy_bounded"] = energy_bounded(row, args.energy_tolerance, args.blowup_factor)
            row["failed_after_blowup"] = not row["converged"] and not (
                row["energy_rel_max"] + 1.0 <= args.blowup_factor
            )
            rows.append(row)
            print(
                f"Theta = {theta:g}, gamma0 = {gamma0:g}: "
                f"{'ok' if row['converged'] else 'FAILED ' + row['fail_reason']}, "
                f"{row['seconds']:.2f} s",
                file=sys.stderr,
                flush=True,
            )
    total = time.perf_counter() - start

    scheme = make_scheme(*scheme_args).describe()
    print(
        f"# Nitsche variants on the 1D bar: scheme {scheme}, nx = {args.nx}, "
        f"tau = {args.dt:g}, T = {args.t_end:g}, snes_max_it = {args.max_it}\n"
    )
    print(markdown_table(rows))
    print("\n`*`: the run stopped at the failed step; the value covers the steps done.\n")
    print("## Conclusions\n")
    print(conclusions(rows, args.variants, args.energy_tolerance, args.blowup_factor))
    print(f"\nTotal time {total:.1f} s for {len(rows)} runs.")

    if args.out:
        directory = os.path.dirname(args.out)
        if directory:
            os.makedirs(directory, exist_ok=True)
        with open(args.out, "w", newline="") as handle:
            writer = csv.DictWriter(handle, fieldnames=CSV_COLUMNS, extrasaction="ignore")
            writer.writeheader()
            for row in rows:
                writer.writerow(
                    {key: repr(v) if isinstance(v, float) else v for key, v in row.items()}
                )
    return 0


if __name__ == "__main__":
    sys.exit(main())
