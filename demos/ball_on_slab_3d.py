# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
#       format_version: '1.5'
# ---

# # A ball dropped on a deformable slab resting on the ground
#
# The ball of the talk's impact test (radius 20, $\lambda = \mu = 20$,
# $\rho = 1$, P2) is thrown down at speed $v_0$ from 1 above a slab of the same
# material, $80 \times 80 \times 10$, which rests on the rigid ground; gravity
# $0.1$ acts on both. Two contacts in one run: between two deformable bodies
# (the ball's lower half and the slab's top, an unbiased pair paired along the
# vertical) and between a body and a rigid obstacle (the slab's bottom and the
# ground). `--dim 2` runs a disk on a plate in plane strain, in seconds.
#
# It shows how to combine `ContactProblem.add_contact_pair` and `add_obstacle`
# (`nitsche_dolfinx.cases.two_bodies.ball_on_slab_problem`), and that the hybrid scheme
# with $\Theta = 1$ keeps its energy control with both: $E_\Theta$ never
# increases (docs/method.md sections 4 and 11).

# +
import argparse
import os
import time

from mpi4py import MPI

from nitsche_dolfinx import Simulation
from nitsche_dolfinx.cases import ball_on_slab_problem
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
from nitsche_dolfinx.common import require
from nitsche_dolfinx.meshing import check_body_mesh
from nitsche_dolfinx.output import HISTORY_COLUMNS
from nitsche_dolfinx.post import Snapshot, energy_figure, figure_title, render_deformed, written_to

PICTURE_TIME = 8.0  # the ball pressed into the slab
# -


def make_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        description="A ball dropped on a deformable slab on the ground: contact between "
        "two bodies and with a rigid obstacle in one run.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    add_method_arguments(parser, gamma0=1e-3, degree=2, dt=0.1, t_end=15.0)
    parser.add_argument("--dim", type=int, choices=(2, 3), default=3, help="3: ball, 2: disk")
    parser.add_argument("--mesh-size", type=finite_float, default=8.0, help="mesh size h")
    parser.add_argument("--v0", type=finite_float, default=1.0, help="the ball's initial speed")
    parser.add_argument("--out", default=os.path.join("out", "ball_on_slab_3d"))
    add_terminal_arguments(parser, draws="the energy figure and the picture")
    return parser


def main(argv: list[str] | None = None) -> None:
    parser = make_parser()
    args = parser.parse_args(argv)
    with one_line_errors(parser):
        method_parameters(args)
        require(args.degree == 2, "degree", args.degree, "the curved ball needs P2")
        check_body_mesh(args.mesh_size, order=2, radius=20.0, dim=args.dim)
        check_output_folder(args.out)
        problem, _ = ball_on_slab_problem(
            dim=args.dim, mesh_size=args.mesh_size, v0=args.v0, gamma0=args.gamma0,
            nitsche_theta=args.nitsche_theta, gamma0_scaling=args.gamma0_scaling,
            mass=scheme_mass(args),
        )  # fmt: skip
        simulation = Simulation(
            problem, scheme_from_arguments(args), dt=args.dt, t_end=args.t_end,
            progress=not args.quiet, max_step_cuts=args.max_step_cuts,
        )  # fmt: skip
        args.dt = step_taken(simulation, args.quiet)  # --dt auto: the verlet scheme's step
        momentum = [f"momentum_{c}" for c in "xyz"[: args.dim]]
        snapshot = Snapshot(at=PICTURE_TIME)  # the fields gathered on rank 0 for the picture
        start = time.perf_counter()
        history = simulation.run(
            out=args.out, columns=(*HISTORY_COLUMNS[:11], *momentum),
            output_every=args.output_every, callback=snapshot,
        )  # fmt: skip
        seconds = MPI.COMM_WORLD.allreduce(time.perf_counter() - start, op=MPI.MAX)
    if MPI.COMM_WORLD.rank != 0:
        return
    print(f"{simulation.dofs} DOFs")
    print(
        f"{len(history) - 1} steps of tau = {args.dt:g} in {seconds:.1f} s; "
        f"E(T)/E(0) - 1 = {history.energy_drift():+.3e}, largest rise of E_Theta "
        f"{history.largest_rise():.2e}, Newton {history.mean_newton_iterations():.2f} per step, "
        f"largest contact force {history['contact_force'].max():.4g} (pair and ground)"
    )
    print(written_to(args.out, args.output_every))
    if not args.no_plot:
        title = figure_title(
            f"{'ball' if args.dim == 3 else 'disk'} on a slab", gamma0=args.gamma0,
            h=f"{args.mesh_size:g}", dt=args.dt,
        )  # fmt: skip
        energy_figure([history], ["ball on slab"], ["tab:blue"], title,
                      os.path.join(args.out, "energy.png"))  # fmt: skip
        picture = os.path.join(args.out, f"deformed_t{PICTURE_TIME:g}.png")
        body = "ball on a slab" if args.dim == 3 else "disk on a plate"
        render_deformed(snapshot, args.dim, body, picture, ground=False)


if __name__ == "__main__":
    main()
