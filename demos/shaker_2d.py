# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
#       format_version: '1.5'
# ---

# # A two-layer block on a shaker, rattling against a rigid stop
#
# A block of two bonded layers, aluminium below and steel above ($0.2 \times 0.1$
# m, plane strain, SI units), stands on a shaker table that moves its base up
# and down, $u_y = A \sin(2\pi f t)$ with $A = 1\,\mu$m and $f = 10$ kHz. A rigid
# stop hangs $1\,\mu$m above the block's top: the block hits it, again and again.
# Rayleigh damping $C = \alpha M + \beta K$ takes energy out of its vibrations.
#
# It shows the problem data of docs/method.md sections 13 and 14 in one run:
#
# - a material per region: the cells of the upper half get steel, the others
#   aluminium (`ContactProblem(material={TOP_LAYER: steel, None: aluminium},
#   cell_tags=...)`; `material_id` in `solution.xdmf`);
# - a Dirichlet value that varies in time, written in the expression language
#   (`"1e-6 * sin(2 * pi * 1e4 * t)"`), and the reaction the table exerts on
#   the block (`reaction_1_x`, `reaction_1_y`);
# - Rayleigh damping (`problem.set_damping`) and what it dissipates;
# - the energy balance: the work the shaker does (`work`) goes into the block's
#   energy, the damping and the impacts; with the hybrid scheme and $\Theta = 1$,
#   `energy_balance` stays at zero to the solver's tolerance.
#
# Run it with `python demos/shaker_2d.py` (serially or under `mpirun -n 2`;
# `--checkpoint-every K` and `--restart` continue a stopped run);
# `demos/shaker_2d.toml` is the same run for `nitsche-dolfinx run`.

# +
from __future__ import annotations

import argparse
import os

import numpy as np
from mpi4py import MPI

from nitsche_dolfinx import ContactProblem, Material, PlaneObstacle, Simulation
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
from nitsche_dolfinx.meshing import BLOCK_CONTACT, InBox, block_mesh, tag_cells, tag_facets
from nitsche_dolfinx.output import DAMPING_COLUMNS, HISTORY_COLUMNS, WORK_COLUMNS
from nitsche_dolfinx.post import Snapshot, figure_title, render_deformed, work_figure, written_to

WIDTH, HEIGHT = 0.2, 0.1  # the block (-0.1, 0.1) x (0, 0.1), m
ALUMINIUM = Material(E=7e10, nu=0.33, rho=2700.0)
STEEL = Material(E=2e11, nu=0.3, rho=7850.0)
TOP_LAYER = 2  # the cell tag of the steel layer, y > 0.05
BASE, TOP = BLOCK_CONTACT, 2  # facet tags: the base on the table, the top under the stop
STOP = [0.0, 0.100001]  # a point of the stop: 1 micrometre above the top
#: the table's motion: 1 micrometre at 10 kHz, in the expression language
TABLE = ["0", "1e-6 * sin(2 * pi * 1e4 * t)"]
#: the columns of the 2D demos, the table's reaction, the dissipation of damping and of
#: the impacts, the work and the energy balance
COLUMNS = (*HISTORY_COLUMNS[:11], "reaction_1_x", "reaction_1_y", *DAMPING_COLUMNS,
           "contact_dissipation", *WORK_COLUMNS)  # fmt: skip
# -


def make_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="shaker_2d.py",
        description="A two-layer block (aluminium, steel) on a shaker table, hitting a rigid "
        "stop, with Rayleigh damping (SI units).",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    add_method_arguments(parser, gamma0=1e-3, degree=2, dt=2e-6, t_end=5e-4)
    parser.set_defaults(gamma0_scaling="E")
    parser.add_argument("--nx", type=int, default=40, help="cells along the block (ny = nx / 2)")
    parser.add_argument("--damping-alpha", type=finite_float, default=500.0,
                        help="Rayleigh damping alpha, 1/s")  # fmt: skip
    parser.add_argument("--damping-beta", type=finite_float, default=2e-7,
                        help="Rayleigh damping beta, s")  # fmt: skip
    parser.add_argument("--out", default=os.path.join("out", "shaker_2d"), help="output folder")
    add_run_arguments(parser)
    add_terminal_arguments(parser, draws="the energy figure and the picture")
    return parser


# The block, its two layers (cell tags from a box), the table, the stop and the damping:


# +
def shaker_problem(args) -> ContactProblem:
    mesh, tags = block_mesh(WIDTH, HEIGHT, args.nx, max(1, args.nx // 2))
    tags = tag_facets(mesh, {TOP: lambda x: np.isclose(x[1], HEIGHT)}, tags)
    layers = tag_cells(mesh, {TOP_LAYER: InBox([-WIDTH / 2, HEIGHT / 2], [WIDTH / 2, HEIGHT])})
    problem = ContactProblem(
        mesh, tags, {TOP_LAYER: STEEL, None: ALUMINIUM}, cell_tags=layers,
        degree=args.degree, gamma0=args.gamma0, nitsche_theta=args.nitsche_theta,
        gamma0_scaling=args.gamma0_scaling, mass=scheme_mass(args),
    )  # fmt: skip
    problem.add_dirichlet(BASE, TABLE)
    problem.add_obstacle(PlaneObstacle(STOP, [0.0, -1.0]), TOP)
    problem.set_damping(alpha=args.damping_alpha, beta=args.damping_beta)
    return problem


# -


def main(argv: list[str] | None = None) -> None:
    parser = make_parser()
    args = parser.parse_args(argv)
    with one_line_errors(parser):
        method_parameters(args)
        check_output_folder(args.out)
        simulation = Simulation(
            shaker_problem(args), scheme_from_arguments(args), dt=args.dt,
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
    impacts = history["contact_force"] > 0
    print(
        f"{len(history) - 1} steps of tau = {args.dt:g} s; in contact with the stop at "
        f"{np.count_nonzero(impacts)} levels; the table did {history['work'][-1]:.4g} J/m of "
        f"work, damping dissipated {history['damping_dissipation'][-1]:.4g} J/m and the "
        f"impacts {history['contact_dissipation'][-1]:.3g} J/m; largest |energy_balance| "
        f"{np.abs(history['energy_balance']).max():.2e} J/m; largest reaction of the table "
        f"{np.abs(history['reaction_1_y']).max():.4g} N/m"
    )
    print(written_to(args.out, args.output_every))
    if not args.no_plot:
        title = figure_title("two-layer block on a shaker", gamma0=args.gamma0,
                             degree=args.degree, dt=args.dt)  # fmt: skip
        forces = {"contact_force": "the stop", "reaction_1_y": "the table (its reaction)"}
        work_figure(history, title, os.path.join(args.out, "energy.png"), forces)
        picture = os.path.join(args.out, "deformed.png")
        render_deformed(snapshot, 2, "two-layer block on a shaker", picture, ground=False)


if __name__ == "__main__":
    main()
