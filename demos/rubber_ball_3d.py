# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
#       format_version: '1.5'
# ---

# # A soft ball that flattens on the ground: finite deformations
#
# A neo-Hookean ball of radius $R = 1$ ($E = 1$, $\nu = 0.3$, $\rho = 1$: shear
# waves travel at $0.62$) falls at $v_0 = 0.3$ onto rigid ground $0.02$ below it,
# without gravity. It flattens until a disk of 0.72 of its radius presses on the
# ground ($t \approx 2.4$; its elements near the contact lose up to half their
# volume), springs back and leaves the ground at $t \approx 5.3$. Small strains
# would be wrong here: `--law linear` runs the same ball with linear elasticity.
#
# The material is hyperelastic (`Material(law="neo_hookean")`, docs/method.md
# section 15): the stress is the first Piola-Kirchhoff stress $P = \partial
# W/\partial F$ of the strain energy $W$, and Nitsche's contact term takes the gap
# and the obstacle's normal at the current position $x = X + u$ and the nominal
# traction $P N$. The hybrid scheme averages the stress along each step, so that
# the step keeps the energy (exactly for St Venant-Kirchhoff, to a Gauss rule's
# round-off for neo-Hookean); with $\Theta = 1$, $E_\Theta$ never rises through the
# impact.
#
# It shows how to
#
# - give a body a hyperelastic material (`--law svk` takes St Venant-Kirchhoff,
#   `--law linear` linear elasticity, for comparison);
# - follow the contact radius in the current configuration
#   (`FiniteContact.current_area`) and the smallest $\det F$ (`det_F_min`: no
#   element turns inside out).
#
# Run it with `python demos/rubber_ball_3d.py --out out/rubber_ball_3d` (serially
# or under `mpirun -n 2`); `nitsche-dolfinx run demos/rubber_ball_3d.toml` is the
# same run.

# +
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np
from dolfinx import fem
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
from nitsche_dolfinx.meshing import BALL_CONTACT, ball_mesh
from nitsche_dolfinx.output import FINITE_COLUMNS, HISTORY_COLUMNS, assemble_global
from nitsche_dolfinx.post import (
    Snapshot,
    energy_figure,
    figure_title,
    render_deformed,
    run_summary,
    written_to,
)

RADIUS = 1.0
#: The ground this far below the ball.
DROP = 0.02
#: The time of the picture: about the largest flattening.
PICTURE_TIME = 2.4
# -


def parse_arguments(argv=None) -> tuple[argparse.ArgumentParser, argparse.Namespace]:
    parser = argparse.ArgumentParser(
        prog="rubber_ball_3d.py", description="A soft neo-Hookean ball flattening on the ground."
    )
    add_method_arguments(parser, gamma0=1e-3, degree=2, dt=0.02, t_end=6.0)
    add_parameter_argument(parser, "--law", "neo_hookean")
    add_parameter_argument(parser, "--E", 1.0)
    parser.add_argument("--mesh-size", type=finite_float, default=0.3, help="mesh size h")
    parser.add_argument("--v0", type=finite_float, default=0.3, help="falling speed")
    parser.add_argument("--out", default="out/rubber_ball_3d", help="output folder")
    add_terminal_arguments(parser, draws="the energy figure and the picture")
    return parser, parser.parse_args(argv)


# The ball, the ground under its lower half, and the run, which records the contact
# radius in the current configuration, $\sqrt{A/\pi}$ with $A$ the area in contact:


# +
def rubber_ball_problem(args) -> ContactProblem:
    mesh, facet_tags = ball_mesh(mesh_size=args.mesh_size, order=2, radius=RADIUS,
                                 center=(0.0, 0.0, RADIUS))  # fmt: skip
    material = Material(E=args.E, nu=0.3, rho=1.0, law=args.law)
    problem = ContactProblem(
        mesh, facet_tags, material, degree=args.degree, gamma0=args.gamma0,
        nitsche_theta=args.nitsche_theta, gamma0_scaling=args.gamma0_scaling,
    )  # fmt: skip
    problem.add_obstacle(PlaneObstacle(point=(0.0, 0.0, -DROP), normal=(0.0, 0.0, 1.0)),
                         BALL_CONTACT)  # fmt: skip
    problem.set_initial_conditions(velocity=(0.0, 0.0, -args.v0))
    return problem


class ContactRadius:
    """After every step: the radius sqrt(A / pi) of the area A in contact, in the current
    configuration (the small-strain area of the reference surface with a linear law)."""

    def __init__(self, problem: ContactProblem, u):
        contact = problem.contacts[0]
        self.form = fem.form(contact.current_area(u) if problem.finite else contact.area(u))
        self.comm = problem.mesh.comm
        self.radii = [0.0]

    def __call__(self, simulation) -> None:
        self.radii.append(np.sqrt(assemble_global(self.form, self.comm) / np.pi))


def run(args):
    problem = rubber_ball_problem(args)
    simulation = Simulation(
        problem, scheme_from_arguments(args), dt=args.dt, t_end=args.t_end,
        progress=not args.quiet, max_step_cuts=args.max_step_cuts,
    )  # fmt: skip
    args.dt = step_taken(simulation, args.quiet)
    radius, snapshot = ContactRadius(problem, simulation.u), Snapshot(at=PICTURE_TIME)

    def after_step(sim) -> None:
        radius(sim)
        snapshot(sim)

    columns = (*HISTORY_COLUMNS, *(FINITE_COLUMNS if problem.finite else ()))
    history = simulation.run(
        out=args.out, columns=columns, output_every=args.output_every, callback=after_step
    )
    return history, radius.radii, snapshot


# -
# The flattening, the elements' volumes, Newton and the energy:


# +
def main(argv=None) -> None:
    parser, args = parse_arguments(argv)
    start = time.perf_counter()
    with one_line_errors(parser):
        method_parameters(args)  # checked before anything is computed
        check_output_folder(args.out)
        history, radii, snapshot = run(args)
    seconds = time.perf_counter() - start
    if MPI.COMM_WORLD.rank != 0:
        return
    run_summary(history, seconds)
    largest = int(np.argmax(radii))
    print(f"largest contact radius {radii[largest] / RADIUS:.3f} R at t = "
          f"{history['t'][largest]:.3g}")  # fmt: skip
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
            f"{args.law} ball", args.nitsche_theta, args.gamma0, args.degree,
            h=f"{args.mesh_size:g}", dt=args.dt,
        )  # fmt: skip
        energy_figure([history], ["$E^h$"], ["black"], title, os.path.join(args.out, "energy.png"))
        picture = os.path.join(args.out, "deformed.png")
        render_deformed(snapshot, 3, f"{args.law} ball", picture)


if __name__ == "__main__":
    main(sys.argv[1:])
# -
