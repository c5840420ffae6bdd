# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
#       format_version: '1.5'
# ---

# # A C-shaped body that lands and closes on itself: self-contact
#
# A C-shaped body (the rectangle $4 \times 2.2$ less a slot $3 \times 0.2$ cut from
# its right side: two arms $1$ thick, joined at the left) falls flat at
# $v_0 = 0.5$ onto rigid ground $0.0525$ below it (plane strain, $E = 100$,
# $\nu = 0.3$, $\rho = 1$, no gravity, P1). The lower arm stops on the ground; the
# upper arm swings on, bends down and its free end hits the lower arm's: the slot
# closes at its open end, opens again, and the body bounces.
#
# The slot's three faces are one surface, paired with itself
# (`add_contact_pair(1, 1)`, docs/method.md section 11, "Self-contact"): each of its
# nodes is paired, at every step, with the nearest point of the surface that faces
# it (normals more than opposite), in front of it and not on one of its own facets;
# a node that nothing faces, or whose nearest point is an end of the facing part
# seen at a glancing angle, has no partner. Each touching pair of points is counted
# from both sides, with weight 1/2, as in the unbiased two-body contact.
#
# It shows how to
#
# - pair a surface with itself, next to a rigid obstacle on another part of the
#   boundary;
# - follow the energy: for the hybrid scheme with $\Theta = 1$, $E_\Theta$ less
#   `pairing_energy` (the change of $E_\Theta$ at the pairings) never rises.
#
# Run it with `python demos/c_shape_2d.py --out out/c_shape_2d` (serially or under
# `mpirun -n 2`); `nitsche-dolfinx run demos/c_shape_2d.toml` is the same run.

# +
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np
from mpi4py import MPI

from nitsche_dolfinx import ContactProblem, Material, PlaneObstacle, Simulation
from nitsche_dolfinx.cli import (
    add_method_arguments,
    add_terminal_arguments,
    check_output_folder,
    finite_float,
    method_parameters,
    one_line_errors,
    scheme_from_arguments,
    scheme_mass,
    step_taken,
)
from nitsche_dolfinx.meshing import C_BOTTOM, C_SLOT, c_shape_mesh
from nitsche_dolfinx.output import HISTORY_COLUMNS, PAIRING_COLUMNS
from nitsche_dolfinx.post import (
    Snapshot,
    energy_figure,
    figure_title,
    render_deformed,
    run_summary,
    written_to,
)

MATERIAL = Material(E=100.0, nu=0.3, rho=1.0)
#: The ground this far below the body: not a multiple of v0 dt, so that the flat
#: bottom does not land exactly at the end of a step.
DROP = 0.0525
#: The time of the picture: the slot closed, its force the largest (at the defaults).
PICTURE_TIME = 0.46
#: ``history.csv`` columns: those of every run, each contact's force (1: the slot, 2:
#: the ground) and the pairings' change of E_Theta.
COLUMNS = (*HISTORY_COLUMNS, "contact_force_1", "contact_force_2", *PAIRING_COLUMNS)
# -


def parse_arguments(argv=None) -> tuple[argparse.ArgumentParser, argparse.Namespace]:
    parser = argparse.ArgumentParser(
        prog="c_shape_2d.py",
        description="A C-shaped body landing on the ground and closing on itself.",
    )
    add_method_arguments(parser, gamma0=1e-5, degree=1, dt=0.01, t_end=3.0)
    parser.add_argument("--mesh-size", type=finite_float, default=0.1, help="mesh size h")
    parser.add_argument("--v0", type=finite_float, default=0.5, help="falling speed")
    parser.add_argument("--out", default="out/c_shape_2d", help="output folder")
    add_terminal_arguments(parser, draws="the energy figure and the picture")
    return parser, parser.parse_args(argv)


# The body, its slot paired with itself, the ground under its bottom, and the run, which
# keeps the fields at $t = 0.46$, the slot closed, for the picture (a `Snapshot`):


# +
def c_shape_problem(args) -> ContactProblem:
    mesh, _, facet_tags = c_shape_mesh(mesh_size=args.mesh_size)
    problem = ContactProblem(
        mesh, facet_tags, MATERIAL, degree=args.degree, gamma0=args.gamma0,
        nitsche_theta=args.nitsche_theta, gamma0_scaling=args.gamma0_scaling,
        mass=scheme_mass(args),
    )  # fmt: skip
    problem.add_contact_pair(C_SLOT, C_SLOT)
    problem.add_obstacle(PlaneObstacle(point=(0.0, -DROP), normal=(0.0, 1.0)), C_BOTTOM)
    problem.set_initial_conditions(velocity=(0.0, -args.v0))
    return problem


def run(args, snapshot):
    simulation = Simulation(
        c_shape_problem(args), scheme_from_arguments(args), dt=args.dt, t_end=args.t_end,
        progress=not args.quiet, max_step_cuts=args.max_step_cuts,
    )  # fmt: skip
    args.dt = step_taken(simulation, args.quiet)  # --dt auto: the verlet scheme's step
    return simulation.run(
        out=args.out, columns=COLUMNS, output_every=args.output_every, callback=snapshot
    )


# -
# The run's numbers, the slot's contact and where the energy went; then the energy
# figure and the body with its slot closed, coloured by von Mises (pyvista, optional):


# +
def main(argv=None) -> None:
    parser, args = parse_arguments(argv)
    start = time.perf_counter()
    with one_line_errors(parser):
        method_parameters(args)  # checked before anything is computed
        check_output_folder(args.out)
        snapshot = Snapshot(at=PICTURE_TIME)
        history = run(args, snapshot)
    seconds = time.perf_counter() - start
    if MPI.COMM_WORLD.rank != 0:
        return
    run_summary(history, seconds)
    slot = np.asarray(history["contact_force_1"])
    t = np.asarray(history["t"])
    controlled = np.asarray(history["energy_theta"]) - np.asarray(history["pairing_energy"])
    first = controlled[0]
    if (slot > 0).any():
        closed = t[slot > 0]
        print(f"the slot is closed from t = {closed.min():.3g} to {closed.max():.3g}, "
              f"largest force {slot.max():.4g}")  # fmt: skip
    else:
        print("the slot does not close")
    print(
        f"pairing_energy at the end {history['pairing_energy'][-1] / first:.2e} of E_0; "
        f"largest rise of E_Theta - pairing_energy {np.diff(controlled).max() / first:.2e} "
        "of E_0"
    )
    print(written_to(args.out, args.output_every))
    if not args.no_plot:
        title = figure_title(
            "C-shaped body, self-contact", args.nitsche_theta, args.gamma0, args.degree,
            h=f"{args.mesh_size:g}", dt=args.dt,
        )  # fmt: skip
        energy_figure([history], ["$E^h$"], ["black"], title, os.path.join(args.out, "energy.png"))
        picture = os.path.join(args.out, f"deformed_t{PICTURE_TIME:g}.png")
        render_deformed(snapshot, 2, "C-shaped body, slot closed", picture, ground=False)


if __name__ == "__main__":
    main(sys.argv[1:])
# -
