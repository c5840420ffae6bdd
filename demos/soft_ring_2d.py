# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
#       format_version: '1.5'
# ---

# # A soft ring thrown at a wall: finite deformations in 2D
#
# The ring of `demos/ring_2d.py` (outer radius 1, inner radius 0.6, plane strain),
# made of a soft neo-Hookean material ($E = 10$, $\nu = 0.3$, $\rho = 1$: shear
# waves travel at 1.24), is thrown sideways at $v_0 = 1$ against a rigid wall
# $0.05$ to its left, without gravity. Its left side flattens on the wall until
# its centre is 0.38 from it (a linear ring would have the same force law only at
# small strains), the elements there lose up to 60% of their area, and the ring
# leaves the wall at $t \approx 2.6$ with 38% of its momentum, the rest left in its
# vibrations.
#
# The material is hyperelastic (`Material(law="neo_hookean")`, docs/method.md
# section 15); the contact part of the boundary, the left half of the outer circle,
# is tagged from the mesh's own tags with two facet selectors.
#
# It shows how to
#
# - tag a new part of a gmsh mesh's boundary (`tag_facets` with `InBox` and
#   `NormalWithin`: every selector of the list must choose a facet);
# - compare the laws: `--law linear` runs the same ring with linear elasticity,
#   `--law svk` with St Venant-Kirchhoff.
#
# Run it with `python demos/soft_ring_2d.py --out out/soft_ring_2d` (serially or
# under `mpirun -n 2`); `nitsche-dolfinx run demos/soft_ring_2d.toml` is the same
# run.

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
    add_parameter_argument,
    add_terminal_arguments,
    check_output_folder,
    finite_float,
    method_parameters,
    one_line_errors,
    scheme_from_arguments,
    step_taken,
)
from nitsche_dolfinx.meshing import InBox, NormalWithin, load_mesh, tag_facets
from nitsche_dolfinx.output import FINITE_COLUMNS, HISTORY_COLUMNS
from nitsche_dolfinx.post import (
    Snapshot,
    energy_figure,
    figure_title,
    render_deformed,
    run_summary,
    written_to,
)

REPOSITORY = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MESH = os.path.join(REPOSITORY, "meshes", "ring_2d.msh")
#: The facet tag of the left half of the outer circle (the mesh has 1 to 3).
LEFT = 4
#: The wall x = WALL; the ring's leftmost point is at x = -1.
WALL = -1.05
#: The time of the picture: the ring flattened on the wall, nearly at its closest (defaults).
PICTURE_TIME = 1.4
# -


def parse_arguments(argv=None) -> tuple[argparse.ArgumentParser, argparse.Namespace]:
    parser = argparse.ArgumentParser(
        prog="soft_ring_2d.py", description="A soft neo-Hookean ring thrown at a wall."
    )
    add_method_arguments(parser, gamma0=1e-4, degree=1, dt=0.005, t_end=3.0)
    add_parameter_argument(parser, "--law", "neo_hookean")
    add_parameter_argument(parser, "--E", 10.0)
    parser.add_argument("--v0", type=finite_float, default=1.0, help="throwing speed")
    parser.add_argument("--out", default="out/soft_ring_2d", help="output folder")
    add_terminal_arguments(parser, draws="the energy figure and the picture")
    return parser, parser.parse_args(argv)


# The ring, its left side tagged, the wall, and the run, which keeps the fields of one
# time level for the picture (a `Snapshot`):


# +
def soft_ring_problem(args) -> ContactProblem:
    mesh, facet_tags = load_mesh(MESH)
    left = [InBox(lower=(-2.0, -1.0), upper=(0.0, 3.0)), NormalWithin((-1.0, 0.0), 90.0)]
    facet_tags = tag_facets(mesh, {LEFT: left}, facet_tags)
    material = Material(E=args.E, nu=0.3, rho=1.0, law=args.law)
    problem = ContactProblem(
        mesh, facet_tags, material, degree=args.degree, gamma0=args.gamma0,
        nitsche_theta=args.nitsche_theta, gamma0_scaling=args.gamma0_scaling,
    )  # fmt: skip
    problem.add_obstacle(PlaneObstacle(point=(WALL, 0.0), normal=(1.0, 0.0)), LEFT)
    problem.set_initial_conditions(velocity=(-args.v0, 0.0))
    return problem


def run(args, snapshot):
    problem = soft_ring_problem(args)
    simulation = Simulation(
        problem, scheme_from_arguments(args), dt=args.dt, t_end=args.t_end,
        progress=not args.quiet, max_step_cuts=args.max_step_cuts,
    )  # fmt: skip
    args.dt = step_taken(simulation, args.quiet)
    columns = (*HISTORY_COLUMNS, *(FINITE_COLUMNS if problem.finite else ()))
    return simulation.run(
        out=args.out, columns=columns, output_every=args.output_every, callback=snapshot
    )


# -
# How hard it hit, how far the elements were squeezed, Newton and the energy; then the
# energy figure and the ring flattened on the wall, coloured by von Mises (pyvista,
# optional):


# +
def main(argv=None) -> None:
    parser, args = parse_arguments(argv)
    start = time.perf_counter()
    with one_line_errors(parser):
        method_parameters(args)  # checked before anything is computed
        check_output_folder(args.out)
        snapshot = Snapshot(at=PICTURE_TIME)  # the fields at that time, for the picture
        history = run(args, snapshot)
    seconds = time.perf_counter() - start
    if MPI.COMM_WORLD.rank != 0:
        return
    run_summary(history, seconds)
    if "det_F_min" in history.columns:
        print(f"smallest det F {np.min(history['det_F_min']):.3f}")
    iterations = np.asarray(history["newton_iterations"])[1:]
    controlled = np.asarray(history["energy_theta"])
    print(f"Newton: {iterations.mean():.2f} iterations a step on average, at most "
          f"{iterations.max()}; largest rise of E_Theta in a step "
          f"{np.diff(controlled).max() / controlled[0]:.1e} of E_Theta(0)")  # fmt: skip
    print(written_to(args.out, args.output_every))
    if not args.no_plot:
        title = figure_title(
            f"{args.law} ring", args.nitsche_theta, args.gamma0, args.degree, dt=args.dt
        )
        energy_figure([history], ["$E^h$"], ["black"], title, os.path.join(args.out, "energy.png"))
        picture = os.path.join(args.out, f"deformed_t{PICTURE_TIME:g}.png")
        render_deformed(snapshot, 2, f"{args.law} ring on the wall", picture, ground=False)


if __name__ == "__main__":
    main(sys.argv[1:])
# -
