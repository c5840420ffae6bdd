# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
#       format_version: '1.5'
# ---

# # A rigid indenter pushed into a slab resting on the ground
#
# A steel slab, $0.2 \times 0.05$ m ($E = 2\cdot10^{11}$ Pa, $\nu = 0.3$,
# $\rho = 7850$ kg/m$^3$, plane strain), rests on the rigid ground $y = 0$. A
# rigid cylinder of radius 0.05 m, 0.1 mm above the slab's top, is pushed down at
# the constant speed $V = 10$ m/s: it touches at $t = 10\,\mu$s and is 0.9 mm
# into the slab at $t = 100\,\mu$s. Both contacts are frictionless Nitsche
# contact: the slab's top with the moving indenter, its bottom with the ground
# that stands still. SI units throughout, with $\gamma_0$ scaled by $E$
# (docs/method.md section 10).
#
# The indenter is a `MovingObstacle`: a `SphereObstacle` (a circle in 2D)
# carried by the translation $c(t) = (0, -Vt)$ (docs/method.md section 13). The
# schemes see it where it is at each time of their step, and the history reports
# the work it does on the slab, `obstacle_work`, and what the contact terms
# dissipate, `contact_dissipation`: with the hybrid scheme and $\Theta = 1$,
# $E_\Theta - E_\Theta(0) + D - W$ stays at zero to the solver's tolerance, the
# balance this demo prints and draws.
#
# Run it with `python demos/indenter_2d.py` (serially or under `mpirun -n 2`;
# `--checkpoint-every K` and `--restart` continue a stopped run);
# `demos/indenter_2d.toml` is the same run for `nitsche-dolfinx run`.

# +
from __future__ import annotations

import argparse
import os

import numpy as np
from mpi4py import MPI

from nitsche_dolfinx import ContactProblem, Material, MovingObstacle, PlaneObstacle, Simulation
from nitsche_dolfinx.cli import (
    add_method_arguments,
    add_run_arguments,
    add_terminal_arguments,
    check_output_folder,
    finite_float,
    method_parameters,
    one_line_errors,
    scheme_from_arguments,
    scheme_mass,
    step_taken,
)
from nitsche_dolfinx.meshing import block_mesh, tag_facets
from nitsche_dolfinx.output import HISTORY_COLUMNS, OBSTACLE_COLUMNS, WORK_COLUMNS, contact_columns
from nitsche_dolfinx.physics import SphereObstacle
from nitsche_dolfinx.post import Snapshot, figure_title, render_deformed, work_figure, written_to

WIDTH, HEIGHT = 0.2, 0.05  # the slab, m
RADIUS, GAP = 0.05, 1e-4  # the indenter and its height above the slab at t = 0, m
CENTRE = [0.0, 0.1001]  # the indenter's centre at t = 0: (0, H + R + g0)
STEEL = Material(E=2e11, nu=0.3, rho=7850.0)
GROUND, TOP = 1, 2  # facet tags
#: the columns of the 2D demos, each contact's force and area (the indenter's first),
#: the indenter's work and the contact dissipation, the work and the energy balance
COLUMNS = (*HISTORY_COLUMNS[:11], *contact_columns(2), *OBSTACLE_COLUMNS, *WORK_COLUMNS)
# -


def make_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="indenter_2d.py",
        description="A rigid cylinder pushed at constant speed into a steel slab resting on "
        "the ground (SI units).",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    add_method_arguments(parser, gamma0=1e-3, degree=2, dt=1e-6, t_end=1e-4)
    parser.set_defaults(gamma0_scaling="E")
    parser.add_argument("--nx", type=int, default=80, help="cells along the slab (ny = nx / 4)")
    parser.add_argument("--speed", type=finite_float, default=10.0, help="the indenter's speed")
    parser.add_argument("--out", default=os.path.join("out", "indenter_2d"), help="output folder")
    add_run_arguments(parser)
    add_terminal_arguments(parser, draws="the energy figure and the picture")
    return parser


# The slab and its two contacts. The indenter's centre starts at $(0, H + R + g_0)$
# and moves by $c(t) = (0, -Vt)$; the ground is a plane that stands still.


# +
def indenter_problem(args) -> ContactProblem:
    mesh, _ = block_mesh(WIDTH, HEIGHT, args.nx, max(1, args.nx // 4))
    tags = tag_facets(
        mesh,
        {GROUND: lambda x: np.isclose(x[1], 0.0), TOP: lambda x: np.isclose(x[1], HEIGHT)},
    )
    problem = ContactProblem(
        mesh, tags, STEEL, degree=args.degree, gamma0=args.gamma0,
        nitsche_theta=args.nitsche_theta, gamma0_scaling=args.gamma0_scaling,
        mass=scheme_mass(args),
    )  # fmt: skip
    cylinder = SphereObstacle(CENTRE, RADIUS)
    speed = args.speed
    problem.add_obstacle(MovingObstacle(cylinder, translation=lambda t: [0.0, -speed * t]), TOP)
    problem.add_obstacle(PlaneObstacle([0.0, 0.0], [0.0, 1.0]), GROUND)
    return problem


# -


def main(argv: list[str] | None = None) -> None:
    parser = make_parser()
    args = parser.parse_args(argv)
    with one_line_errors(parser):
        method_parameters(args)
        check_output_folder(args.out)
        simulation = Simulation(
            indenter_problem(args), scheme_from_arguments(args), dt=args.dt,
            t_end=args.t_end, progress=not args.quiet, max_step_cuts=args.max_step_cuts,
        )  # fmt: skip
        args.dt = step_taken(simulation, args.quiet)  # --dt auto: the verlet scheme's step
        snapshot = Snapshot(at=simulation.t_end)
        history = simulation.run(
            out=args.out, columns=COLUMNS, output_every=args.output_every, callback=snapshot,
            checkpoint_every=args.checkpoint_every, restart=args.restart,
        )  # fmt: skip
    if MPI.COMM_WORLD.rank != 0:
        return
    print(f"{simulation.dofs} DOFs")
    depth = args.speed * history["t"][-1] - GAP
    balance = history["energy_balance"]
    indenter, ground = history["contact_force_1"][-1], history["contact_force_2"][-1]
    print(
        f"{len(history) - 1} steps of tau = {args.dt:g} s; at t = {history['t'][-1]:g} s the "
        f"indenter is {depth * 1e3:.3g} mm deep and pushes with {indenter:.4g} N/m, the ground "
        f"with {ground:.4g} N/m; work of the indenter "
        f"{history['obstacle_work'][-1]:.4g} J/m, contact dissipation "
        f"{history['contact_dissipation'][-1]:.3g} J/m, largest |E_Theta - E_Theta(0) + D - W| "
        f"{np.abs(balance).max():.2e} J/m"
    )
    print(written_to(args.out, args.output_every))
    if not args.no_plot:
        title = figure_title(
            f"indenter at {args.speed:g} m/s", gamma0=args.gamma0, degree=args.degree,
            dt=args.dt,
        )  # fmt: skip
        forces = {"contact_force_1": "indenter", "contact_force_2": "ground"}
        work_figure(history, title, os.path.join(args.out, "energy.png"), forces)
        picture = os.path.join(args.out, "deformed.png")
        render_deformed(snapshot, 2, "slab under the indenter", picture, ground=False)


if __name__ == "__main__":
    main()
