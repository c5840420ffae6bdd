"""What the demos print and write about their runs: summaries of histories, tables of
errors and orders, CSV files of them.

Every function here is called on rank 0 with the histories returned by
:meth:`Simulation.run <nitsche_dolfinx.simulation.Simulation.run>` (or made step by
step, or read back with :func:`~nitsche_dolfinx.output.writers.read_history`); the numbers are
those of :class:`~nitsche_dolfinx.output.history.History` and :mod:`nitsche_dolfinx.cases.exact`.
"""

from __future__ import annotations

import csv
import os
from collections.abc import Sequence

import numpy as np

from ..cases.exact import bar_contact_errors, observed_orders

__all__ = [
    "written_to",
    "COMPARISON_COLUMNS",
    "CONVERGENCE_ERRORS",
    "bar_summary",
    "comparison_row",
    "comparison_table",
    "convergence_acceptance",
    "convergence_table",
    "friction_summary",
    "markdown_cell",
    "markdown_table",
    "refinement_table",
    "run_summary",
    "runs_table",
    "steps_text",
    "two_bars_summary",
    "write_csv",
]


def write_csv(path: str, columns: Sequence[str], rows: Sequence[dict]) -> None:
    """One line per row, numbers in full precision (text and integers as they are)."""
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(columns)
        for row in rows:
            writer.writerow([_cell(row[name]) for name in columns])


def _cell(value):
    if isinstance(value, (str, int, np.integer)):
        return value
    return repr(float(value))


def markdown_cell(text: str) -> str:
    """``text`` for a cell of a Markdown table: its bars escaped, which would end the cell."""
    return text.replace("|", "\\|")


def markdown_table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    """A Markdown table of text cells."""
    lines = ["| " + " | ".join(header) + " |", "|---" * len(header) + "|"]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines)


# -- one run, several runs -----------------------------------------------------------------


def run_summary(history, seconds: float) -> None:
    """Print the figures of one run: the energy at both ends and its change, the largest
    one-step rise of E_Theta, the largest contact force and penetration, the contact
    interval, the Newton iterations and the wall time."""
    t, energy, force = history["t"], history["energy"], history["contact_force"]
    interval = history.contact_interval()
    i = int(np.argmax(force))
    lines = [
        ("E(0), E(T)", f"{energy[0]:.10f}, {energy[-1]:.10f}"),
        ("E(T)/E(0) - 1", f"{history.energy_drift():+.3e}"),
        ("largest one-step rise of E_Theta", f"{np.max(np.diff(history['energy_theta'])):.2e}"),
        ("largest contact force", f"{force[i]:.4g} at t = {t[i]:.4g}"),
        ("largest penetration u_n - g", f"{np.max(history['penetration_max']):.3e}"),
        ("in contact", "never" if interval is None else "{:.4g} <= t <= {:.4g}".format(*interval)),
        ("Newton iterations per step", f"{history.mean_newton_iterations():.2f}"),
        ("wall time", f"{seconds:.2f} s"),
    ]
    for label, value in lines:
        print(f"{label:34s} {value}")


def steps_text(history) -> str:
    """``400 steps``, or ``400 steps (3 of them cut)`` when Newton needed cut steps."""
    cut = history.cut_steps()
    return f"{len(history) - 1} steps" + (f" ({cut} of them cut)" if cut else "")


def runs_table(runs: Sequence[tuple]) -> None:
    """Print one line per run ``(history, label, seconds)``: the first contact, the drifts
    of E and E_Theta over [0, T], the largest one-step rise of E_Theta, the largest
    penetration, the Newton iterations per step and the time loop's seconds."""
    print(
        f"{'run':40s} {'1st contact':>11s} {'E(T)/E(0)-1':>12s} {'E_Th drift':>11s} "
        f"{'max dE_Th/E_Th(0)':>17s} {'max penetr.':>11s} {'Newton':>6s} {'loop (s)':>8s}"
    )
    for history, label, seconds in runs:
        s = history.summary()
        first = "never" if np.isnan(s["first_contact"]) else f"{s['first_contact']:.3f}"
        print(
            f"{label:40s} {first:>11s} {s['energy_drift']:+12.3e} "
            f"{s['energy_theta_drift']:+11.3e} {s['largest_rise']:17.2e} "
            f"{history['penetration_max'].max():11.3e} {s['mean_newton_iterations']:6.2f} "
            f"{seconds:8.2f}"
        )


def friction_summary(history, mu: float) -> None:
    """Print where the energy of a frictional run went: the frictional work sum_n D^n, the
    smallest D^n (>= 0 up to round-off) and the largest residual of the balance
    E_Theta^(n+1) - E_Theta^n + D^n (docs/method.md section 4)."""
    work, balance = history["friction_dissipation"], history["energy_balance_residual"]
    print(
        f"friction (mu_f = {mu:g}): frictional work {work.sum():.6g}, smallest D^n "
        f"{work.min():+.3e}, largest |E_Th^(n+1) - E_Th^n + D^n| {abs(balance).max():.3e}"
    )


# -- the bar ------------------------------------------------------------------------------


def bar_summary(histories: Sequence, labels: Sequence[str], dt: float) -> None:
    """Print one line per bar run: the l2(0, T) error of u(t, 0), the relative energy
    change at T, the largest one-step increase of E_Theta (round-off for the hybrid
    scheme with Theta = 1) and the Newton iterations per step; then E(T) of each."""
    width = max(36, *map(len, labels))
    print(
        f"{'run':{width}s} {'l2 error u(.,0)':>16s} {'E(T)/E(0) - 1':>14s} "
        f"{'max step dE_Theta':>18s} {'Newton/step':>12s}"
    )
    for history, label in zip(histories, labels):
        error = bar_contact_errors(history, dt)["error_u_contact"]
        rise = np.max(np.diff(history["energy_theta"]))
        print(
            f"{label:{width}s} {error:16.4e} {history.energy_drift():+14.3%} "
            f"{rise:18.2e} {history.mean_newton_iterations():12.3f}"
        )
    print(
        "E(T) = " + ", ".join(f"{h[-1]['energy']:.5f} ({lab})" for h, lab in zip(histories, labels))
    )


#: The comparison's columns (``summary.csv``), with their headers in the Markdown table.
COMPARISON_COLUMNS = {
    "energy_drift": "E(T)/E(0)-1",
    "energy_error_max": "max \\|E - 1/8\\|",
    "error_u_contact": "l2 err u(.,0)",
    "error_v_contact": "l2 err v(.,0)",
    "error_sigma_contact": "l2 err pressure",
    "penetration_max": "max penetration",
    "newton_iterations": "Newton/step",
    "wall_seconds": "wall time (s)",
}


def comparison_row(history, seconds: float, dt: float) -> dict:
    """The figures of :data:`COMPARISON_COLUMNS` for one bar run."""
    errors = bar_contact_errors(history, dt)
    return {
        "energy_drift": history.energy_drift(),
        **errors,
        "newton_iterations": history.mean_newton_iterations(),
        "wall_seconds": seconds,
    }


def _comparison_cell(name: str, value: float) -> str:
    if name == "energy_drift":
        return f"{value:+.2%}"
    if name == "penetration_max":
        return f"{value:.1e}"
    if name in ("newton_iterations", "wall_seconds"):
        return f"{value:.2f}"
    return f"{value:.2e}"


def comparison_table(rows: Sequence[dict]) -> str:
    """The Markdown table of the comparison's rows (:func:`comparison_row` with ``label``)."""
    cells = [
        [row["label"], *(_comparison_cell(name, row[name]) for name in COMPARISON_COLUMNS)]
        for row in rows
    ]
    return markdown_table(["run", *COMPARISON_COLUMNS.values()], cells)


#: The errors of the convergence study
#: (:func:`~nitsche_dolfinx.cases.one_body.bar_convergence_level`),
#: in the order of its table and CSV, with their headers.
CONVERGENCE_ERRORS = {
    "error_l2_l2": "l2(L2) u",
    "error_l2_h1": "l2(H1) u",
    "error_pressure": "l2 lambda_h(.,0)",
    "error_stress": "l2 sigma_n(u_h)(.,0)",
    "error_energy": "max \\|E - 1/8\\|",
}


def _orders(rows: Sequence[dict], name: str) -> list[float]:
    return observed_orders([row["h"] for row in rows], [row[name] for row in rows])


def convergence_table(results: dict, labels: dict) -> str:
    """The Markdown table of the errors and observed orders of every method
    (``results``: name to the rows of its levels; ``labels``: name to its label)."""
    header = ["method", "N", "tau"]
    for title in CONVERGENCE_ERRORS.values():
        header += [title, "order"]
    header.append("time (s)")
    cells = []
    for name, rows in results.items():
        orders = {error: _orders(rows, error) for error in CONVERGENCE_ERRORS}
        for k, row in enumerate(rows):
            line = [labels[name], str(row["N"]), f"{row['tau']:.4g}"]
            for error in CONVERGENCE_ERRORS:
                order = orders[error][k]
                line += [f"{row[error]:.3e}", "" if np.isnan(order) else f"{order:.2f}"]
            line.append(f"{row['wall_seconds']:.1f}")
            cells.append(line)
    return markdown_table(header, cells)


def convergence_acceptance(rows: Sequence[dict]) -> str:
    """The check of the hybrid scheme: errors decrease at every level, and over the finest
    three levels the l2(L2) order is >= 0.6 and the l2(H1) order >= 0.25 (both steps)."""
    names = ("error_l2_l2", "error_l2_h1", "error_energy")
    decreasing = all(
        rows[k][name] < rows[k - 1][name] for name in names for k in range(1, len(rows))
    )
    l2 = _orders(rows, "error_l2_l2")[-2:]
    h1 = _orders(rows, "error_l2_h1")[-2:]
    passed = decreasing and len(rows) >= 3 and min(l2) >= 0.6 and min(h1) >= 0.25
    return (
        f"hybrid: errors of u and of the energy decrease at every level: {decreasing}; "
        f"orders over the finest three levels: l2(L2) {l2[0]:.2f}, {l2[1]:.2f} (>= 0.6), "
        f"l2(H1) {h1[0]:.2f}, {h1[1]:.2f} (>= 0.25): {'PASS' if passed else 'FAIL'}"
    )


# -- two bars -----------------------------------------------------------------------------


def two_bars_summary(history, errors: dict, dofs: int, dt: float) -> None:
    """Print a run of two bars against the exact pair (``errors``:
    :func:`~nitsche_dolfinx.cases.exact.two_bars_errors`)."""
    e = errors
    print(f"{dofs} DOFs, {len(history) - 1} steps of tau = {dt:g}")
    print(f"contact from t = {e['contact_start']:.4f}, duration error {e['duration_error']:.3e}")
    print(f"exit velocities, largest relative error {e['exit_velocity_error']:.3e}")
    print(f"energy change {e['energy_error']:.3e}, largest |momentum| / v0 {e['momentum_max']:.1e}")
    print(f"largest one-step rise of E_Theta {history.largest_rise():.2e}")
    print(f"Newton iterations per step {e['newton']:.2f}")


def refinement_table(rows: Sequence[dict]) -> None:
    """Print the errors of two bars at each refinement (rows of ``nx``, ``dt`` and
    :func:`~nitsche_dolfinx.cases.exact.two_bars_errors`)."""
    print(f"{'nx':>6} {'dt':>9} {'duration':>10} {'exit v':>10} {'energy':>10}")
    for row in rows:
        print(
            f"{row['nx']:6d} {row['dt']:9.3g} {row['duration_error']:10.3e} "
            f"{row['exit_velocity_error']:10.3e} {row['energy_error']:10.3e}"
        )


def written_to(out: str, output_every: int, histories=None) -> str:
    """Where a run wrote its outputs, a line each: the histories (``OUT/history.csv``, or
    those of the folders ``histories``), and the fields when ``output_every`` > 0."""
    lines = [f"history: {os.path.join(folder, 'history.csv')}" for folder in histories or [out]]
    if output_every > 0:
        lines.append(f"fields: {os.path.join(out, 'solution.xdmf')}")
    return "\n".join(lines)
