"""Benchmark of the explicit Verlet scheme's stable step: the measured critical step against
the package's estimate ``stable_dt`` (issue 29, docs/method.md section 12).

What it measures
----------------
For each case, variant Theta in {1, 0, -1} and Nitsche parameter gamma0 (``--factors``
times the case's base gamma0, by default 1e-3, 1e-2, 1e-1, 1, 10), it takes the estimate
of :class:`nitsche_dolfinx.steppers.explicit.ExplicitStepper`, ``stable_dt`` = 2 /
sqrt(lambda_max(D^-1
K)) (K: the affine terms plus the contact stiffness with all of Gamma_C active, lambda_max
by power iterations), and measures the critical step: the largest tau = r * stable_dt
whose run of 2,000 steps (``--steps``; t_end = 2000 tau) stays bounded.

The cases (serial, lumped mass, the Verlet scheme with ``force_dt``):

- ``bar20``, ``bar100``: the 1D bar of the talk (E = rho = 1, clamped at x = 1, wall at
  x = 0), P1, 20 or 100 cells. Base gamma0 = 0.1, the explicit bar's value of
  tests/test_verlet.py and docs/method.md section 12 (``bar_problem``'s default 1e-6 is
  the implicit figure's: its explicit step would be 1e-5, and its sweep would never reach
  the coercivity limit gamma0 E = 1).
- ``disk-p1``: the disk of the impact test (``impact_problem(dim=2)``: radius 20,
  lambda = mu = 20, so E = 50, rho = 1, f = -0.1 e_y, plane y = 0), P1 on straight
  triangles (geometric order 1), mesh size 8 (``--disk-mesh-size``).
- ``disk-p2``: the same disk, P2 on curved triangles (HRZ lumped mass).
- ``ball-p2``: the ball (``impact_problem(dim=3)``), P2 (HRZ) on curved tetrahedra, mesh
  size 8 (``--ball-mesh-size``; the talk's coarse ball, 2,625 DOFs).

The disk and the ball take impact_problem's default gamma0 = 1e-3 as base (gamma0 E =
0.05).

**Repeated impacts.** A run of 2,000 steps at the stiff end of the sweep covers a short
time (0.3 time units for bar100 at gamma0 = 1e-4, 11 for the P2 disk at 1e-6), so every case
starts at its first impact instead of before it: the bar with u0 = 0 and v0 = -1/2 on [0, 1)
(the talk's exact solution at t = 1: impacts at t = 0, 3, 6, ...), the disk and the ball
touching the plane (u0 = 0) with v0 = -1 along the normal (the talk's impact speed after
its fall of 5; the gravity f is kept, so a body that rebounds falls back after about 2 v /
g = 20). With a stiff contact the contact nodes then bounce off the obstacle many times
within one macroscopic contact (the contact force switches off and on). An *impact* below
is a contact onset: a time level with a contact force after one without; each run's count
of impacts and of status changes (levels where the contact area changes) is recorded.

**Bounded.** With E = kinetic + elastic + potential (the ``energy`` column; the bar has no
potential) and E_Theta (``energy_theta``), both equal at t = 0 to the initial kinetic
energy (u0 = 0: no elastic energy, no Nitsche term), a run is

- (a) *not blown up*: the stepper did not raise
  :class:`nitsche_dolfinx.steppers.explicit.UnstableStep` (kinetic + |elastic| above 100 times its
  largest value up to 100 steps before, or not finite) and every E and E_Theta is finite;
- (b F) *energy-bounded by F*: (a), and max_n E^n <= F E^0 and max_n E_Theta^n <= F
  E_Theta^0, for F = 1.1 and F = 2. Both energies are watched because each misses a
  growth: E_Theta (for Theta = 1) stays near E^0 while E grows 10^4-fold when A_Theta
  loses its coercivity (bar, gamma0 E = 1), and E_Theta for Theta = -1 is not a norm.

(a) is blind to a growth slower than 100-fold in 100 steps, such as the energy an impact
pumps in a run with many: runs passed (a) with E grown up to 1e28-fold in their 2,000 steps.
Each row's CSV gives the largest E / E^0 of its (a)-critical run.

**The search**, separately for each criterion, on r = tau / stable_dt: r ascends the grid
0.1, 0.2, ..., 1.0, 1.1, 1.25, 1.5, 1.75, 2 until every criterion has failed once; the
criterion's measured limit lies between its last passing grid point below its first failure
and that failure, and is bisected there (geometric midpoints) until the bracket is 1% wide
(``--tolerance``); the measured critical step is the bracket's lower end, r_c stable_dt.
Runs are shared between the criteria. The bisection assumes one threshold inside the
bracket; the grid below it passed. It need not hold: the energy an impact pumps depends on
where the contact starts between two steps, so E grows with tau by fits and starts, and a
round-off change of the steps moves a measured (b) limit by several per cent; the rows say
where a run above the limit passed again. A criterion failing at r = 0.1 reports "< 0.1"; one
passing at r = 2, ">= 2". When (b 2) fails at r = 0.1 the row is run at r = 0.05 too: a
row whose (b 2) fails there grows at every step (``grows``: A_Theta not coercive, or the
contact terms not stable); no estimate can serve it.

The acceptance of issue 29: the estimate is never above the measured limit and never below
0.6 of it, i.e. stable_dt / tau_c in [0.6, 1]. The table gives that ratio for (a), (b 1.1)
and (b 2).

**The linear limits** (dense eigenvalues, rows up to ``--max-dense`` DOFs): of
D^-1/2 K D^-1/2 over the dofs with a mass, K the all-active operator of the estimate
(``tau_all`` = 2 / sqrt(max Re lambda); for Theta != 1 it is not symmetric: also its
largest |Im lambda|) and K the affine terms alone, no point in contact (``tau_none``,
and its smallest eigenvalue ``lam_min_none``: negative, A_Theta not coercive out of
contact). ``est/lin`` is stable_dt / min(tau_all, tau_none): above 1, the estimate is above
the limit of a contact state that exists (a power iteration short of lambda_max, or a
contact state stiffer than the all-active one).

Usage::

    python benchmarks/verlet_stability.py --quick                 # 7 rows, about a minute
    python benchmarks/verlet_stability.py                         # 75 rows, 20-30 minutes
    python benchmarks/verlet_stability.py --cases bar100 disk-p2 --thetas 1 --out DIR

Written to ``OUT`` (default ``out/verlet_stability``): ``verlet_stability.csv`` (one row per
case, Theta and gamma0, written as measured), ``runs.csv`` (every run), ``verlet_stability.md``
(the table and its conclusions, also printed) and ``verlet_stability.png`` (stable_dt / tau_c
against gamma0 E). Serial only.
"""

from __future__ import annotations

import argparse
import csv
import functools
import gc
import math
import os
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

import nitsche_dolfinx
from nitsche_dolfinx import Simulation
from nitsche_dolfinx.cases import bar_problem, impact_problem
from nitsche_dolfinx.meshing import ball_mesh, disk_mesh
from nitsche_dolfinx.model import ContactProblem
from nitsche_dolfinx.output import assembled_matrix
from nitsche_dolfinx.physics import DirichletDofs
from nitsche_dolfinx.steppers import UnstableStep, VerletScheme, contact_stiffness_form

#: The history columns a run watches.
COLUMNS = ["t", "energy", "energy_theta", "contact_force", "contact_area"]
#: r = tau / stable_dt ascends this grid before the bisection.
GRID = (0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.1, 1.25, 1.5, 1.75, 2.0)
#: The step of the check "grows at every step" (as a share of stable_dt).
TINY = 0.05
#: The criteria: (a) no blow-up, (b F) energies within F times their initial value.
CRITERIA = {"a": None, "b1.1": 1.1, "b2": 2.0}
#: The acceptance of issue 29: stable_dt / measured limit in this interval.
ACCEPTED = (0.6, 1.0)
#: The Nitsche variants of the sweep.
THETAS = (1.0, 0.0, -1.0)
#: gamma0 as factors of the case's base value.
FACTORS = (1e-3, 1e-2, 1e-1, 1.0, 10.0)
#: The rows of ``--quick``: (case, Theta, factor).
QUICK_ROWS = (
    ("bar20", 1.0, 1e-2),
    ("bar20", 0.0, 1e-2),
    ("bar20", -1.0, 1e-2),
    ("bar20", 1.0, 10.0),
    ("bar100", 1.0, 1.0),
    ("disk-p2", 1.0, 1.0),
    ("disk-p2", 1.0, 10.0),
)


@dataclass(frozen=True)
class Case:
    """A body of the sweep: its label, base gamma0, Young modulus and the problem of a
    (gamma0, Theta), started at its first impact."""

    name: str
    label: str
    base_gamma0: float
    E: float
    make: Callable[[float, float], ContactProblem]


def bar_at_impact(nx: int, gamma0: float, theta: float) -> ContactProblem:
    """The talk's bar at t = 1 of its exact solution: u0 = 0, v0 = -1/2 but at the clamp."""
    problem = bar_problem(nx=nx, gamma0=gamma0, nitsche_theta=theta, mass="lumped")
    problem.set_initial_conditions(
        displacement=lambda x: np.zeros(x.shape[1]),
        velocity=lambda x: np.where(x[0] < 1.0 - 1e-12, -0.5, 0.0),
    )
    return problem


@functools.cache
def body_mesh(dim: int, mesh_size: float, order: int):
    """The disk or the ball of the impact test, meshed once (COMM_SELF: serial)."""
    make = disk_mesh if dim == 2 else ball_mesh
    return make(mesh_size=mesh_size, order=order, comm=MPI.COMM_SELF)


def body_at_impact(
    dim: int, degree: int, mesh_size: float, gamma0: float, theta: float
) -> ContactProblem:
    """The impact test's disk or ball touching the plane, moving towards it at speed 1."""
    problem = impact_problem(
        dim=dim, degree=degree, gamma0=gamma0, nitsche_theta=theta, mass="lumped",
        mesh=body_mesh(dim, mesh_size, degree), comm=MPI.COMM_SELF,
    )  # fmt: skip
    velocity = [0.0] * dim
    velocity[-1] = -1.0
    problem.set_initial_conditions(displacement=[0.0] * dim, velocity=velocity)
    return problem


def make_cases(args) -> dict[str, Case]:
    disk, ball = args.disk_mesh_size, args.ball_mesh_size
    body_E = 50.0  # lambda = mu = 20
    return {
        "bar20": Case("bar20", "bar, P1, 20 cells", 0.1, 1.0,
                      functools.partial(bar_at_impact, 20)),
        "bar100": Case("bar100", "bar, P1, 100 cells", 0.1, 1.0,
                       functools.partial(bar_at_impact, 100)),
        "disk-p1": Case("disk-p1", f"disk, P1, h = {disk:g}", 1e-3, body_E,
                        functools.partial(body_at_impact, 2, 1, disk)),
        "disk-p2": Case("disk-p2", f"disk, P2 (HRZ), h = {disk:g}", 1e-3, body_E,
                        functools.partial(body_at_impact, 2, 2, disk)),
        "ball-p2": Case("ball-p2", f"ball, P2 (HRZ), h = {ball:g}", 1e-3, body_E,
                        functools.partial(body_at_impact, 3, 2, ball)),
    }  # fmt: skip


def simulation_of(problem: ContactProblem, tau: float, steps: int) -> Simulation:
    return Simulation(problem, VerletScheme(force_dt=True), dt=tau, t_end=steps * tau)


def run(case: Case, gamma0: float, theta: float, estimate: float, ratio: float, steps: int):
    """One run of ``steps`` steps of tau = ratio * estimate; its figures."""
    start = time.perf_counter()
    tau = ratio * estimate
    simulation = simulation_of(case.make(gamma0, theta), tau, steps)
    first = simulation.state(COLUMNS)
    energy0, theta0 = first["energy"], first["energy_theta"]
    largest = {"energy": energy0, "energy_theta": theta0}
    last = energy0
    finite, blew_up = True, False
    impacts = changes = 0
    touching, area = first["contact_force"] > 0, first["contact_area"]
    while not simulation.finished:
        try:
            simulation.step()
        except UnstableStep:
            blew_up = True
            break
        values = simulation.state(COLUMNS)
        for name in largest:
            if math.isfinite(values[name]):
                largest[name] = max(largest[name], values[name])
            else:
                finite = False
        if not finite:
            break
        last = values["energy"]
        now = values["contact_force"] > 0
        impacts += int(now and not touching)
        changes += int(values["contact_area"] != area)
        touching, area = now, values["contact_area"]
    record = {
        "case": case.name,
        "theta": theta,
        "gamma0": gamma0,
        "ratio": ratio,
        "tau": tau,
        "t_end": steps * tau,
        "steps_done": simulation.step_index,
        "blew_up": blew_up,
        "finite": finite,
        "max_energy": largest["energy"] / energy0,
        "max_energy_theta": largest["energy_theta"] / theta0,
        "end_energy": last / energy0,
        "impacts": impacts,
        "status_changes": changes,
        "seconds": time.perf_counter() - start,
    }
    del simulation
    gc.collect()
    return record


def passes(criterion: str, record: dict) -> bool:
    """Whether a run is bounded in the sense of ``criterion`` (module docstring)."""
    if record["blew_up"] or not record["finite"]:
        return False
    factor = CRITERIA[criterion]
    if factor is None:
        return True
    return record["max_energy"] <= factor and record["max_energy_theta"] <= factor


def search(evaluate: Callable[[float], dict], tolerance: float) -> dict:
    """The measured limit of each criterion: ``{criterion: (lo, hi)}`` in r, lo the largest
    passing r (None: even the grid's first fails), hi the first failing one (None: none
    up to the grid's top)."""
    cache: dict[float, dict] = {}

    def outcome(ratio: float) -> dict:
        if ratio not in cache:
            cache[ratio] = evaluate(ratio)
        return cache[ratio]

    last_pass: dict[str, float] = {}
    first_fail: dict[str, float] = {}
    for ratio in GRID:
        record = outcome(ratio)
        for criterion in CRITERIA:
            if criterion in first_fail:
                continue
            if passes(criterion, record):
                last_pass[criterion] = ratio
            else:
                first_fail[criterion] = ratio
        if len(first_fail) == len(CRITERIA):
            break
    brackets = {}
    for criterion in CRITERIA:
        lo, hi = last_pass.get(criterion), first_fail.get(criterion)
        while lo is not None and hi is not None and hi / lo > 1.0 + tolerance:
            middle = math.sqrt(lo * hi)
            if passes(criterion, outcome(middle)):
                lo = middle
            else:
                hi = middle
        brackets[criterion] = (lo, hi)
    return {"brackets": brackets, "runs": [cache[r] for r in sorted(cache)]}


def dense(matrix: PETSc.Mat) -> np.ndarray:
    """A serial PETSc matrix as a dense array."""
    aij = matrix.convert("aij")
    indptr, indices, values = aij.getValuesCSR()
    n = matrix.getSize()[0]
    array = np.zeros((n, n))
    rows = np.repeat(np.arange(n), np.diff(indptr))
    np.add.at(array, (rows, indices), values)
    aij.destroy()
    return array


def linear_limits(problem: ContactProblem, stable_dt: float, max_dense: int) -> dict:
    """The limits of the two extreme contact states from dense eigenvalues of
    D^-1/2 K D^-1/2 (module docstring); NaN above ``max_dense`` dofs. K and D are
    assembled here as the stepper does: the affine terms, the all-active contact part
    (:func:`~nitsche_dolfinx.steppers.stable_step.contact_stiffness_form`), the lumped mass without
    the
    Dirichlet dofs."""
    nan = float("nan")
    with problem.mass_diagonal().localForm() as local:
        diagonal = local.array.copy()
    keep = diagonal > 0
    keep[DirichletDofs(problem).dofs] = False
    if keep.sum() > max_dense:
        return {k: nan for k in ("tau_all", "tau_none", "lam_min_none", "lam_min_all",
                                 "imag_all", "lam_est_over_all")}  # fmt: skip
    scale = np.outer(1.0 / np.sqrt(diagonal[keep]), 1.0 / np.sqrt(diagonal[keep]))
    trial, test = ufl.TrialFunction(problem.V), ufl.TestFunction(problem.V)
    affine = problem.bulk_stiffness(trial, test)
    for contact in problem.contacts:
        affine = affine + contact.affine_terms(trial, test)
    matrices = [assembled_matrix(affine), assembled_matrix(contact_stiffness_form(problem))]
    none, contact = (dense(matrix)[np.ix_(keep, keep)] * scale for matrix in matrices)
    for matrix in matrices:
        matrix.destroy()
    every = none + contact
    lam_none = np.linalg.eigvalsh((none + none.T) / 2)
    symmetric = np.abs(every - every.T).max() <= 1e-12 * np.abs(every).max()
    lam_all = np.linalg.eigvalsh(every) if symmetric else np.linalg.eigvals(every)
    top_all = float(np.max(lam_all.real))
    lam_est = 4.0 / stable_dt**2

    def limit(lam: float) -> float:
        return 2.0 / math.sqrt(lam) if lam > 0 else nan

    return {
        "tau_all": limit(top_all),
        "tau_none": limit(float(lam_none[-1])),
        "lam_min_none": float(lam_none[0]) / float(lam_none[-1]),
        "lam_min_all": float(np.min(lam_all.real)) / top_all,
        "imag_all": float(np.max(np.abs(lam_all.imag))) / top_all,
        "lam_est_over_all": lam_est / top_all,
    }


#: The columns of ``verlet_stability.csv``.
ROW_COLUMNS = (
    "case", "theta", "gamma0", "gamma0_E", "dofs", "stable_dt",
    "a_lo", "a_hi", "b1.1_lo", "b1.1_hi", "b2_lo", "b2_hi",
    "est_over_a", "est_over_b1.1", "est_over_b2", "grows", "tiny_max_energy",
    "a_max_energy", "a_max_energy_theta", "a_impacts", "a_status_changes", "a_t_end",
    "b1.1_impacts", "a_passes_above", "b1.1_passes_above", "b2_passes_above", "tau_all",
    "tau_none", "est_over_linear", "lam_min_none", "lam_min_all", "imag_all",
    "lam_est_over_all", "runs", "seconds",
)  # fmt: skip
#: The columns of ``runs.csv``.
RUN_COLUMNS = (
    "case", "theta", "gamma0", "ratio", "tau", "t_end", "steps_done", "blew_up", "finite",
    "max_energy", "max_energy_theta", "end_energy", "impacts", "status_changes", "seconds",
)  # fmt: skip


def measure_row(case: Case, theta: float, factor: float, args) -> tuple[dict, list[dict]]:
    """One row: the estimate, the search of every criterion, the linear limits."""
    start = time.perf_counter()
    gamma0 = case.base_gamma0 * factor
    simulation = simulation_of(case.make(gamma0, theta), 1.0, 1)
    estimate = simulation.stepper.stable_dt
    row = {"case": case.name, "theta": theta, "gamma0": gamma0, "gamma0_E": gamma0 * case.E}
    row["dofs"], row["stable_dt"] = simulation.dofs, estimate
    row.update(linear_limits(simulation.problem, estimate, args.max_dense))
    del simulation
    found = search(lambda r: run(case, gamma0, theta, estimate, r, args.steps), args.tolerance)
    runs = found["runs"]
    for criterion, (lo, hi) in found["brackets"].items():
        row[f"{criterion}_lo"], row[f"{criterion}_hi"] = lo, hi
        row[f"est_over_{criterion}"] = 1.0 / lo if lo is not None and hi is not None else None
        above = [
            r["ratio"] for r in runs if hi is not None and r["ratio"] > hi and passes(criterion, r)
        ]
        row[f"{criterion}_passes_above"] = max(above, default=None)
    row["grows"], row["tiny_max_energy"] = False, None
    if row["b2_lo"] is None:  # (b 2) fails at the grid's first point: and at 0.05?
        tiny = run(case, gamma0, theta, estimate, TINY, args.steps)
        runs.append(tiny)
        row["grows"] = not passes("b2", tiny)
        row["tiny_max_energy"] = tiny["max_energy"]
    for criterion, prefix in (("a", "a_"), ("b1.1", "b1.1_")):
        lo = row[f"{criterion}_lo"]
        at = next((r for r in runs if r["ratio"] == lo), None)
        if criterion == "a":
            for name in ("max_energy", "max_energy_theta", "impacts", "status_changes", "t_end"):
                row[prefix + name] = None if at is None else at[name]
        else:
            row[prefix + "impacts"] = None if at is None else at["impacts"]
    linear = min(row["tau_all"], row["tau_none"])
    row["est_over_linear"] = estimate / linear if math.isfinite(linear) else None
    row["runs"], row["seconds"] = len(runs), time.perf_counter() - start
    return row, runs


def _ratio_cell(lo, hi) -> str:
    """The measured r = tau_c / stable_dt of a criterion."""
    if lo is None:
        return f"< {hi:g}"
    if hi is None:
        return f">= {lo:g}"
    return f"{lo:.3f}"


def _estimate_cell(row: dict, criterion: str) -> str:
    """stable_dt / tau_c, bold outside the acceptance interval."""
    lo, hi = row[f"{criterion}_lo"], row[f"{criterion}_hi"]
    if lo is None:
        return f"**> {1 / hi:.3g}**"
    if hi is None:
        text = f"<= {1 / lo:.3g}"
        return f"**{text}**" if 1 / lo < ACCEPTED[0] else text
    value = 1 / lo
    inside = ACCEPTED[0] <= value <= ACCEPTED[1]
    return f"{value:.3f}" if inside else f"**{value:.3f}**"


def _number(value, spec: str = ".3g") -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    return format(value, spec)


def table(rows: list[dict], cases: dict[str, Case]) -> str:
    """The Markdown table: the estimate, the measured r = tau_c / stable_dt and
    stable_dt / tau_c of each criterion, and the linear limits."""
    header = (
        "| case | Theta | gamma0 | gamma0 E | stable_dt | r_c (a) | r_c (b 1.1) | r_c (b 2) "
        "| est/(a) | est/(b 1.1) | est/(b 2) | max E/E0 at r_c (a) | impacts (b 1.1) | est/lin "
        "| tau_all/est | tau_none/est | min eig none | max Im/Re all | note |"
    )
    lines = [header, "|" + "---|" * (header.count("|") - 1)]
    for row in rows:
        notes = []
        if row["grows"]:
            notes.append(f"grows at r = {TINY:g} (E x {row['tiny_max_energy']:.3g})")
        if row["lam_min_none"] is not None and row["lam_min_none"] < -1e-9:
            notes.append("A_Theta indefinite")
        for criterion in CRITERIA:
            again = row[f"{criterion}_passes_above"]
            if again is not None:
                notes.append(f"({criterion}) passes again at r = {again:.3g}")
        est = row["stable_dt"]
        lines.append(
            "| " + " | ".join([
                cases[row["case"]].label, f"{row['theta']:g}", f"{row['gamma0']:.3g}",
                f"{row['gamma0_E']:.3g}", f"{est:.4g}",
                *(_ratio_cell(row[f"{c}_lo"], row[f"{c}_hi"]) for c in CRITERIA),
                *(_estimate_cell(row, c) for c in CRITERIA),
                _number(row["a_max_energy"]), _number(row["b1.1_impacts"], "d"),
                _number(row["est_over_linear"], ".4f"),
                _number(row["tau_all"] / est, ".4f"), _number(row["tau_none"] / est, ".3f"),
                _number(row["lam_min_none"], ".2g"), _number(row["imag_all"], ".2g"),
                "; ".join(notes),
            ]) + " |"
        )  # fmt: skip
    return "\n".join(lines)


def conclusions(rows: list[dict], cases: dict[str, Case]) -> str:
    """The rows outside the acceptance interval, per criterion."""
    lines = []
    for criterion in CRITERIA:
        above, below = [], []
        for row in rows:
            lo, hi = row[f"{criterion}_lo"], row[f"{criterion}_hi"]
            name = f"{row['case']} Theta={row['theta']:g} gamma0={row['gamma0']:.3g}"
            if lo is None or (hi is not None and 1 / lo > ACCEPTED[1]):
                above.append(name + ("" if lo is None else f" ({1 / lo:.3f})"))
            elif 1 / lo < ACCEPTED[0]:
                below.append(name + f" ({1 / lo:.3f}{'' if hi is not None else ' or less'})")
        lines.append(f"- ({criterion}): estimate above the measured limit in {len(above)} of "
                     f"{len(rows)} rows: {', '.join(above) or 'none'}")  # fmt: skip
        lines.append(f"  below {ACCEPTED[0]:g} of it in {len(below)}: "
                     f"{', '.join(below) or 'none'}")  # fmt: skip
    grows = [f"{r['case']} Theta={r['theta']:g} gamma0={r['gamma0']:.3g}" for r in rows
             if r["grows"]]  # fmt: skip
    lines.append(f"- grows at every step (E above 2 E0 at r = {TINY:g}): "
                 f"{', '.join(grows) or 'none'}")  # fmt: skip
    return "\n".join(lines)


def plot(rows: list[dict], path: str) -> None:
    """stable_dt / tau_c of (a) and (b 1.1) against gamma0 E, one panel per case: filled
    markers where the limit was found, hollow where it is above r = 2 (stable_dt / tau_c
    at most the value drawn); the rows that fail at r = 0.1 are left out."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(dict.fromkeys(row["case"] for row in rows))
    figure, axes = plt.subplots(1, len(names), figsize=(3.2 * len(names), 3.4), squeeze=False)
    for axis, name in zip(axes[0], names):
        for theta, colour in zip(THETAS, ("C0", "C1", "C2")):
            mine = sorted((r for r in rows if r["case"] == name and r["theta"] == theta),
                          key=lambda r: r["gamma0"])  # fmt: skip
            if not mine:
                continue
            x = np.array([r["gamma0_E"] for r in mine])
            for criterion, marker, line in (("a", "o", "-"), ("b1.1", "s", "--")):
                lo = [r[f"{criterion}_lo"] for r in mine]
                y = np.array([1 / v if v else np.nan for v in lo])
                found = np.array([r[f"{criterion}_hi"] is not None for r in mine])
                axis.semilogx(x, y, line, color=colour)
                axis.semilogx(x[found], y[found], marker, color=colour, linestyle="none",
                              label=f"Theta={theta:g} ({criterion})")  # fmt: skip
                axis.semilogx(x[~found], y[~found], marker, color=colour, linestyle="none",
                              markerfacecolor="none")  # fmt: skip
        axis.axhspan(*ACCEPTED, color="grey", alpha=0.2)
        axis.set_title(name, fontsize=9)
        axis.set_xlabel("gamma0 E")
        axis.set_ylim(0, 3.5)
        axis.grid(True, alpha=0.3)
    axes[0][0].set_ylabel("stable_dt / measured tau_c")
    axes[0][-1].legend(fontsize=6)
    figure.tight_layout()
    figure.savefig(path, dpi=90)
    plt.close(figure)


def package_version() -> str:
    """The git commit of the package measured (``-dirty``: with local changes), if known."""
    try:
        described = subprocess.run(
            ["git", "describe", "--always", "--dirty"], capture_output=True, text=True,
            cwd=os.path.dirname(os.path.abspath(nitsche_dolfinx.__file__)), check=True,
        )  # fmt: skip
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return described.stdout.strip()


def _cell(value):
    return repr(value) if isinstance(value, float) else ("" if value is None else value)


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a handful of rows (~2 min)")
    parser.add_argument(
        "--cases", nargs="+", default=["bar20", "bar100", "disk-p1", "disk-p2", "ball-p2"]
    )
    parser.add_argument("--thetas", type=float, nargs="+", default=list(THETAS))
    parser.add_argument("--factors", type=float, nargs="+", default=list(FACTORS),
                        help="gamma0 as factors of the case's base gamma0")  # fmt: skip
    parser.add_argument("--steps", type=int, default=2000, help="steps of a run")
    parser.add_argument("--tolerance", type=float, default=0.01, help="bisection bracket")
    parser.add_argument("--disk-mesh-size", type=float, default=8.0)
    parser.add_argument("--ball-mesh-size", type=float, default=8.0)
    parser.add_argument("--max-dense", type=int, default=3000,
                        help="dense eigenvalues up to this many dofs")  # fmt: skip
    parser.add_argument("--out", default=os.path.join("out", "verlet_stability"))
    return parser


def main() -> None:
    args = _parser().parse_args()
    if MPI.COMM_WORLD.size > 1:
        sys.exit("verlet_stability.py runs serially")
    cases = make_cases(args)
    if args.quick:
        plan = list(QUICK_ROWS)
    else:
        plan = [(c, t, f) for c in args.cases for t in args.thetas for f in args.factors]
    os.makedirs(args.out, exist_ok=True)
    version = package_version()
    start = time.perf_counter()
    rows = []
    with (
        open(os.path.join(args.out, "verlet_stability.csv"), "w", newline="") as row_file,
        open(os.path.join(args.out, "runs.csv"), "w", newline="") as run_file,
    ):
        row_writer = csv.DictWriter(row_file, fieldnames=ROW_COLUMNS)
        run_writer = csv.DictWriter(run_file, fieldnames=RUN_COLUMNS)
        row_writer.writeheader()
        run_writer.writeheader()
        for name, theta, factor in plan:
            row, runs = measure_row(cases[name], theta, factor, args)
            rows.append(row)
            row_writer.writerow({k: _cell(row[k]) for k in ROW_COLUMNS})
            row_file.flush()
            for record in runs:
                run_writer.writerow({k: _cell(record[k]) for k in RUN_COLUMNS})
            run_file.flush()
            print(
                f"{name} Theta={theta:g} gamma0={row['gamma0']:.3g}: stable_dt "
                f"{row['stable_dt']:.4g}, r_c (a) {_ratio_cell(row['a_lo'], row['a_hi'])}, "
                f"(b 1.1) {_ratio_cell(row['b1.1_lo'], row['b1.1_hi'])}, "
                f"(b 2) {_ratio_cell(row['b2_lo'], row['b2_hi'])}; {row['runs']} runs, "
                f"{row['seconds']:.1f} s",
                file=sys.stderr, flush=True,
            )  # fmt: skip
    total = time.perf_counter() - start
    report = "\n".join([
        "# The Verlet scheme's stable step: measured against the estimate\n",
        f"Package {version}. {args.steps} steps a run (t_end = {args.steps} tau), "
        "bisection to "
        f"{100 * args.tolerance:g}%; r_c = tau_c / stable_dt; est/(x) = stable_dt / tau_c of "
        f"criterion x (accepted: [{ACCEPTED[0]:g}, {ACCEPTED[1]:g}], out of it in bold); "
        "impacts (b 1.1): contact onsets of the (b 1.1)-critical run; est/lin = stable_dt / "
        "min(tau_all, tau_none); min eig none: the smallest eigenvalue of D^-1 K without "
        "contact over the largest; max Im/Re all: of D^-1 K all active (docstring of "
        "benchmarks/verlet_stability.py).\n",
        table(rows, cases),
        "\n## Conclusions\n",
        conclusions(rows, cases),
        f"\nTotal {total:.0f} s for {len(rows)} rows, "
        f"{sum(row['runs'] for row in rows)} runs.",
    ])  # fmt: skip
    print(report)
    with open(os.path.join(args.out, "verlet_stability.md"), "w") as handle:
        handle.write(report + "\n")
    plot(rows, os.path.join(args.out, "verlet_stability.png"))


if __name__ == "__main__":
    main()
