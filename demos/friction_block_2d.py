# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
#       format_version: '1.5'
# ---

# # A block sliding with Coulomb friction: dynamic frictional contact by Nitsche's method
#
# A stiff elastic block (2 x 1, plane strain, $E = 10^4$, $\nu = 0$, $\rho = 1$)
# rests on the rigid plane $y = 0$ under gravity $g = 1$ and is thrown along it
# with the velocity $v_0 e_x$. Coulomb friction of coefficient $\mu_f$ slows it
# down: a rigid block decelerates at $\mu_f g$ and stops at $t = v_0/(\mu_f g)$.
# With `--slope s` the volume force gets the component $s g$ along $x$ (an
# incline of angle $\arctan s$ seen in the frame of the plane): the block then
# decelerates at $g(\mu_f - s)$; started at rest it sticks when $s \le \mu_f$ and
# slides with the acceleration $g(s - \mu_f)$ otherwise.
#
# The contact and friction conditions are written with Nitsche's method
# (docs/method.md section 2): with $P_\gamma(u) = u_n - g - \gamma_h \sigma_n(u)$ and the
# tangential velocity $\dot u_t$ of the time scheme,
#
# $$
# \sigma_n = -\frac{1}{\gamma_h}[P_\gamma(u)]_+, \qquad
# \sigma_t = -\frac{1}{\gamma_h}\big[\dot u_t - \gamma_h \sigma_t(u)\big]_{\mu_f [P_\gamma(u)]_+},
# $$
#
# where $[x]_r$ is the projection onto the ball of radius $r$. The hybrid scheme
# (the default) takes the slip velocity $(u^{n+1} - u^n)/\tau$ and the threshold
# $\mu_f \Phi$ of its normal force, consistent with its midpoint.
#
# It shows how to
#
# - build a frictional `ContactProblem` with `friction=mu_f` (here through
#   `nitsche_dolfinx.cases.one_body.block_problem`);
# - follow where the energy goes: `friction_dissipation` (the work $D^n$ of the
#   friction term over a step) and `energy_balance_residual`
#   ($E_\Theta^{n+1} - E_\Theta^n + D^n$) in `history.csv`;
# - write the slip velocity and the friction traction on $\Gamma_C$ to
#   `solution.xdmf` for ParaView.
#
# Run it with `python demos/friction_block_2d.py --out out/block` (serially or
# under `mpirun -n 2`). The default run goes on to t = 7, past the stop at t = 5:
# the base then sticks while the block rings elastically. The stick band is 10^6
# times thinner than one step's change of velocity; the guarded Newton of
# `Simulation` (docs/method.md section 8) is what gets through the stop.

# +
from __future__ import annotations

import argparse
import os
import sys

from mpi4py import MPI

from nitsche_dolfinx import Simulation
from nitsche_dolfinx.cases import add_block_probes, block_problem
from nitsche_dolfinx.cli import (
    add_method_arguments,
    add_terminal_arguments,
    check_output_folder,
    finite_float,
    method_parameters,
    one_line_errors,
    scheme_from_arguments,
    scheme_mass,
)
from nitsche_dolfinx.output import FRICTION_HISTORY_COLUMNS
from nitsche_dolfinx.post import (
    Snapshot,
    energy_figure,
    figure_title,
    friction_summary,
    render_deformed,
)

#: ``history.csv`` columns: those of the 2D/3D demos, the energy balance, and the
#: block's mean velocity along the plane.
COLUMNS = (*FRICTION_HISTORY_COLUMNS, "mean_velocity")


def parse_arguments(argv=None) -> tuple[argparse.ArgumentParser, argparse.Namespace]:
    parser = argparse.ArgumentParser(
        prog="friction_block_2d.py",
        description="A stiff block sliding on a rigid plane with Coulomb friction.",
    )
    add_method_arguments(parser, gamma0=1e-7, degree=2, dt=0.05, t_end=7.0)
    parser.add_argument("--mu", type=finite_float, default=0.2, help="friction coefficient")
    parser.add_argument("--v0", type=finite_float, default=1.0, help="initial velocity along x")
    parser.add_argument(
        "--slope", type=finite_float, default=0.0, help="tangential gravity / normal gravity"
    )
    parser.add_argument("--E", type=finite_float, default=1e4, help="Young's modulus")
    parser.add_argument("--nx", type=int, default=8, help="cells along the block's width")
    parser.add_argument("--out", default="out/friction_block_2d", help="output folder")
    add_terminal_arguments(parser, draws="the energy figure and the picture")
    return parser, parser.parse_args(argv)


# -
# The block, its mean velocity as a history column, and the run, which keeps the
# fields of its last time level for the picture (a `Snapshot`):


# +
def run(args, snapshot):
    problem = block_problem(
        friction=args.mu,
        v0=args.v0,
        slope=args.slope,
        E=args.E,
        nx=args.nx,
        ny=max(1, args.nx // 2),
        degree=args.degree,
        gamma0=args.gamma0,
        nitsche_theta=args.nitsche_theta,
        gamma0_scaling=args.gamma0_scaling,
        mass=scheme_mass(args),
    )
    simulation = Simulation(
        problem,
        scheme_from_arguments(args),
        dt=args.dt,
        t_end=args.t_end,
        progress=not args.quiet,
        max_step_cuts=args.max_step_cuts,
    )
    add_block_probes(simulation)
    return simulation.run(
        out=args.out, columns=COLUMNS, output_every=args.output_every, callback=snapshot
    )


# -
# The rigid-body prediction, for the summary printed at the end; then the energy figure
# (with $E_\Theta$ plus the friction's work $\sum D^n$, which never rises) and the block
# at the end, coloured by von Mises (pyvista, optional):


# +
def rigid_prediction(args) -> str:
    g = 1.0
    if args.v0 == 0.0:
        if args.slope <= args.mu:
            return "a rigid block sticks"
        return f"a rigid block slides with acceleration {g * (args.slope - args.mu):.4g}"
    deceleration = g * (args.mu - args.slope)
    if deceleration <= 0:
        return f"a rigid block keeps accelerating at {-deceleration:.4g}"
    return (
        f"a rigid block decelerates at {deceleration:.4g} and stops at t = "
        f"{args.v0 / deceleration:.4g}"
    )


def main(argv=None) -> None:
    parser, args = parse_arguments(argv)
    with one_line_errors(parser):
        method_parameters(args)  # --mu among them: checked before anything is computed
        check_output_folder(args.out)
        snapshot = Snapshot(at=args.t_end)  # the last time level, for the picture
        history = run(args, snapshot)
    if MPI.COMM_WORLD.rank != 0:
        return
    velocity, t = history["mean_velocity"], history["t"]
    print(f"{rigid_prediction(args)}; computed mean velocity at t = {t[-1]:g}: {velocity[-1]:.6g}")
    friction_summary(history, args.mu)
    print(
        f"history: {os.path.join(args.out, 'history.csv')}; "
        f"fields: {os.path.join(args.out, 'solution.xdmf')}"
    )
    if not args.no_plot:
        title = figure_title(
            f"block on a plane, Coulomb friction mu = {args.mu:g}", args.nitsche_theta,
            args.gamma0, args.degree, dt=args.dt,
        )  # fmt: skip
        energy_figure([history], ["$E^h$"], ["black"], title, os.path.join(args.out, "energy.png"))
        picture = os.path.join(args.out, "deformed.png")
        render_deformed(snapshot, 2, "block on a plane", picture, ground=False)


if __name__ == "__main__":
    main(sys.argv[1:])
# -
