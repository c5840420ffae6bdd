# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
#       format_version: '1.5'
# ---

# # Two elastic balls colliding head-on: contact between two deformable bodies
#
# Two balls of the talk's impact test (radius 20, $\lambda = \mu = 20$,
# $\rho = 1$, P2 on a curved mesh), mirror images of each other, move towards
# each other along the $z$ axis at speeds $\pm v_0$, without gravity. They
# touch, flatten against each other, push each other back and fly apart.
# `demos/two_disks_2d.py` runs this script in 2D (plane strain).
#
# It shows how to
#
# - build two bodies in one mesh (`nitsche_dolfinx.cases.two_bodies.two_bodies_problem`:
#   the gmsh ball of `shapes.py` and its mirror image) and pair their facing
#   halves with `ContactProblem.add_contact_pair`, along the collision axis
#   (`--pairing axis`) or with closest points (`--pairing closest`);
# - check the pair against one ball on a rigid plane: paired along the axis,
#   the unbiased pair with $\gamma_0$ is exactly one ball hitting the plane of
#   symmetry with $\gamma_0/2$ (docs/method.md section 11);
# - declare each body (`ContactProblem.add_body`) and record its momentum, centre of
#   mass and angular momentum, and the totals, which the contact terms keep;
# - hit off-centre (`--offset D --no-compare`; `--pairing closest` for an oblique
#   force): the moment of the momenta about the nodes' reference positions is kept,
#   the angular momentum about their current positions to the size of the motion
#   (docs/method.md section 4);
# - make both bodies hyperelastic (`--law neo_hookean`, finite strains, docs/method.md
#   section 15): the pair's terms are then those of finite strain, and the pair along
#   the axis is still one body on the plane with $\gamma_0/2$ (the disks: to 1e-14).
#
# With the hybrid scheme and $\Theta = 1$, $E_\Theta$ never increases.

# +
import argparse
import os
import time

import numpy as np
from mpi4py import MPI

from nitsche_dolfinx import ContactProblem, Material, PlaneObstacle, Simulation
from nitsche_dolfinx.cases import LOWER_BODY, UPPER_BODY, two_bodies_problem
from nitsche_dolfinx.cli import (
    add_method_arguments,
    add_parameter_argument,
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
from nitsche_dolfinx.meshing import ball_mesh, check_body_mesh, disk_mesh
from nitsche_dolfinx.output import HISTORY_COLUMNS, angular_momentum_columns, body_columns
from nitsche_dolfinx.post import Snapshot, energy_figure, figure_title, render_deformed, written_to

PICTURE_TIME = 8.0  # about the largest compression, at the default v0 and gap
# -


def make_parser(dim: int, body: str) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        description=f"Two elastic {body}s colliding head-on ({dim}D), Nitsche contact "
        "between two bodies.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    add_method_arguments(parser, gamma0=1e-3, degree=2, dt=0.1, t_end=20.0)
    parser.add_argument("--mesh-size", type=finite_float, default=8.0, help="mesh size h")
    parser.add_argument("--v0", type=finite_float, default=1.0, help="speed of each body")
    parser.add_argument("--gap", type=finite_float, default=1.0, help="initial gap")
    parser.add_argument(
        "--offset", type=finite_float, default=0.0,
        help="distance of the centres across the collision axis (an off-centre hit)",
    )  # fmt: skip
    parser.add_argument("--variant", choices=("unbiased", "biased"), default="unbiased")
    add_parameter_argument(parser, "--law")
    parser.add_argument(
        "--pairing", choices=("axis", "closest"), default="axis",
        help="pair the surfaces along the collision axis, or with closest points",
    )  # fmt: skip
    parser.add_argument("--out", default=os.path.join("out", f"two_{body}s_{dim}d"))
    parser.add_argument(
        "--compare", action=argparse.BooleanOptionalAction, default=True,
        help="also run one body on the rigid plane of symmetry with gamma0/2 (OUT/plane)",
    )  # fmt: skip
    add_terminal_arguments(parser, draws="the energy figure and the picture")
    return parser


def check_arguments(args, dim: int) -> None:
    method_parameters(args)
    require(args.v0 > 0, "v0", args.v0, "the bodies must move towards each other")
    require(args.gap >= 0, "gap", args.gap, "the gap must be >= 0")
    require(abs(args.offset) < 40.0, "offset", args.offset, "less than a diameter (40)")
    require(
        args.offset == 0 or not args.compare, "offset", args.offset,
        "the check against one body on a plane is for a head-on hit: add --no-compare",
    )  # fmt: skip
    check_body_mesh(args.mesh_size, order=2, radius=20.0, dim=dim)
    check_output_folder(args.out)


# ## The pair and the body on a plane
#
# Each body is declared by its cell tag: the history gets its momentum
# `momentum_1_x`, ..., its centre of mass and its angular momentum about the origin,
# after the columns of the output contract and the totals. The body on the plane runs
# at the pair's step: with `--scheme verlet`, `--dt` is by default `auto`, the
# scheme's share of the stable step it estimates for the pair.


def run_pair(args, dim: int, snapshot: Snapshot):
    problem, cells = two_bodies_problem(
        dim=dim, mesh_size=args.mesh_size, v0=args.v0, gap=args.gap, degree=args.degree,
        gamma0=args.gamma0, nitsche_theta=args.nitsche_theta, variant=args.variant,
        along_axis=args.pairing == "axis", gamma0_scaling=args.gamma0_scaling,
        mass=scheme_mass(args), offset=args.offset, law=args.law,
    )  # fmt: skip
    for tag in (UPPER_BODY, LOWER_BODY):
        problem.add_body(tag, cells)
    momentum = [f"momentum_{c}" for c in "xyz"[:dim]]
    bodies = [*body_columns(UPPER_BODY, dim), *body_columns(LOWER_BODY, dim)]
    angular = [*angular_momentum_columns(dim), *angular_momentum_columns(dim, reference=True)]
    columns = (*HISTORY_COLUMNS[:11], *momentum, *angular, *bodies)
    return run_simulation(args, problem, args.out, columns, args.quiet, snapshot)


def run_on_plane(args, dim: int):
    """The upper body alone, hitting the plane of symmetry with gamma0 / 2."""
    center = [0.0] * dim
    center[-1] = 20.0 + args.gap / 2
    mesh, tags = (ball_mesh if dim == 3 else disk_mesh)(args.mesh_size, 2, 20.0, center)
    problem = ContactProblem(
        mesh, tags, Material.from_lame(20.0, 20.0, rho=1.0, law=args.law), args.degree,
        args.gamma0 / 2, args.nitsche_theta, gamma0_scaling=args.gamma0_scaling,
        mass=scheme_mass(args),
    )  # fmt: skip
    up = [0.0] * dim
    up[-1] = 1.0
    problem.add_obstacle(PlaneObstacle([0.0] * dim, up), 1)
    problem.set_initial_conditions(velocity=[-args.v0 * c for c in up])
    return run_simulation(
        args, problem, os.path.join(args.out, "plane"), HISTORY_COLUMNS[:11], True
    )


def run_simulation(args, problem, out, columns, quiet, callback=None):
    """Run ``problem`` with the scheme, steps and output of the flags into ``out``: its
    history, the global number of DOFs and the wall time of the run (the slowest rank's).
    Also the run of `sliding_disks_2d.py`."""
    simulation = Simulation(
        problem, scheme_from_arguments(args), dt=args.dt, t_end=args.t_end,
        progress=not quiet, max_step_cuts=args.max_step_cuts,
    )  # fmt: skip
    args.dt = step_taken(simulation, quiet)  # the pair's (--dt auto) is the plane's
    start = time.perf_counter()
    history = simulation.run(
        out=out, columns=columns, output_every=args.output_every, callback=callback
    )
    seconds = MPI.COMM_WORLD.allreduce(time.perf_counter() - start, op=MPI.MAX)
    return history, simulation.dofs, seconds


def main(dim: int = 3, body: str = "ball", argv: list[str] | None = None) -> None:
    parser = make_parser(dim, body)
    args = parser.parse_args(argv)
    snapshot = Snapshot(at=PICTURE_TIME)  # the fields gathered on rank 0 for the picture
    with one_line_errors(parser):
        check_arguments(args, dim)
        pair, dofs, seconds = run_pair(args, dim, snapshot)
        plane = run_on_plane(args, dim) if args.compare else None
    if MPI.COMM_WORLD.rank != 0:
        return
    print(f"{dofs} DOFs")
    contact = pair.contact_interval()
    touching = "never" if contact is None else f"from t = {contact[0]:.3f} to {contact[1]:.3f}"
    momentum = max(np.abs(pair[f"momentum_{c}"]).max() for c in "xyz"[:dim])
    mass = np.pi * 20.0**2 if dim == 2 else 4 / 3 * np.pi * 20.0**3
    angular = [
        max(np.ptp(pair[name]) / mass / args.v0 / 20.0 for name in names)
        for names in (angular_momentum_columns(dim), angular_momentum_columns(dim, True))
    ]
    print(f"{len(pair) - 1} steps of tau = {args.dt:g} in {seconds:.1f} s; contact {touching}")
    print(
        f"E(T)/E(0) - 1 = {pair.energy_drift():+.3e}, largest rise of E_Theta "
        f"{pair.largest_rise():.2e}, largest |momentum| / (m v0) "
        f"{momentum / mass / args.v0:.1e}, Newton {pair.mean_newton_iterations():.2f} per step"
    )
    print(
        f"angular momentum: largest change / (m v0 R) {angular[0]:.1e}, about the reference "
        f"positions {angular[1]:.1e}"
    )
    if plane is not None:
        one = plane[0]
        force = np.abs(pair["contact_force"] - one["contact_force"]).max()
        force /= max(one["contact_force"].max(), 1e-300)
        energy = np.abs(pair["energy_theta"] - 2 * one["energy_theta"]).max()
        energy /= 2 * one["energy_theta"][0]
        print(
            f"against one {body} on the plane with gamma0/2: contact force differs by "
            f"{force:.2e} relative, E_Theta by {energy:.2e}"
        )
    print(written_to(args.out, args.output_every))
    if not args.no_plot:
        title = figure_title(
            f"two {body}s, {args.variant}, pairing {args.pairing}", gamma0=args.gamma0,
            h=f"{args.mesh_size:g}", dt=args.dt,
        )  # fmt: skip
        energy_figure([pair], [f"two {body}s"], ["tab:blue"], title,
                      os.path.join(args.out, "energy.png"))  # fmt: skip
        picture = os.path.join(args.out, f"deformed_t{PICTURE_TIME:g}.png")
        render_deformed(snapshot, dim, f"two {body}s, {args.variant}", picture, ground=False)


if __name__ == "__main__":
    main()
