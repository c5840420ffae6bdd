# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
#       format_version: '1.5'
# ---

# # Two elastic disks sliding past each other: contact pairs that follow the sliding
#
# The two disks of `two_disks_2d.py` (radius 20, plane strain, $\lambda = \mu = 20$,
# $\rho = 1$, P2), their centres 36 apart along $x$ and 41 along $y$, fly past each
# other: the upper one at $(-v_x, -v_y)$, the lower one at $(v_x, v_y)$, with
# $v_x = 2$ and $v_y = 0.3$. They graze each other from $t = 5.7$ to $13$, and
# meanwhile their surfaces slide along each other by some 28, 7 cells of $h = 4$.
#
# The two surfaces are a contact pair (docs/method.md section 11) paired by closest
# points. A pairing made once, in the reference configuration, would keep each node's
# first partner, soon many cells away: the pairing here follows the sliding. After
# each converged step the surfaces are paired again in the displaced configuration
# $x + u^n$ when a node near the other surface has slid along it by 3% of a facet
# (`add_contact_pair(..., follow=True)`). The pair is unbiased: each surface is the
# slave in turn, and both get the contact fields `gap` and `contact_pressure` in
# `solution.xdmf`.
#
# It shows how to
#
# - pair two bodies by closest points that follow the sliding
#   (`nitsche_dolfinx.cases.two_bodies.two_bodies_problem` with `along_axis=False` and
#   `follow=True`; `--no-follow` pairs them once, in the reference configuration);
# - give each body its own velocity (`cases.two_bodies.body_velocities`);
# - follow the energy: a new pairing changes the contact terms of $E_\Theta$ at the
#   same state, by the history column `pairing_energy` (their sum since $t = 0$). With
#   the hybrid scheme and $\Theta = 1$, $E_\Theta - $ `pairing_energy` never rises;
#   `pairing_energy` itself is an error of the pairing, measured, which shrinks with the
#   time step, not with the solver's tolerance (docs/method.md section 11);
# - check the momenta: the forces on a node and its partner are equal and opposite
#   whatever the pairing, so the total momentum stays zero to round-off; the
#   angular momentum about the origin is kept to the size of the deformation
#   (docs/method.md section 4), its moment about the nodes' reference positions not:
#   the pairing is made in the displaced configuration (section 11).
#
# Run it with `python demos/sliding_disks_2d.py --out out/sliding_disks_2d` (serially
# or under `mpirun -n 2`); `nitsche-dolfinx run demos/sliding_disks_2d.toml` makes the
# same run from a configuration.

# +
import argparse
import os

import numpy as np
from mpi4py import MPI
from two_balls_3d import run_simulation

from nitsche_dolfinx.cases import LOWER_BODY, UPPER_BODY, body_velocities, two_bodies_problem
from nitsche_dolfinx.cli import (
    add_method_arguments,
    add_terminal_arguments,
    check_output_folder,
    finite_float,
    method_parameters,
    one_line_errors,
    scheme_mass,
)
from nitsche_dolfinx.common import require
from nitsche_dolfinx.meshing import check_body_mesh
from nitsche_dolfinx.output import (
    HISTORY_COLUMNS,
    PAIRING_COLUMNS,
    angular_momentum_columns,
    body_columns,
    momentum_columns,
)
from nitsche_dolfinx.post import Snapshot, energy_figure, figure_title, render_deformed, written_to

RADIUS = 20.0
PICTURE_TIME = 9.0  # in the middle of the sliding, at the default velocities
#: ``history.csv``: the columns of the impact demos, the total momentum and angular
#: momenta, the pairings' change of E_Theta, then each disk's momentum, centre of mass and
#: angular momentum (docs/method.md section 6).
COLUMNS = (
    *HISTORY_COLUMNS[:11],
    *momentum_columns(2),
    *angular_momentum_columns(2),
    *angular_momentum_columns(2, reference=True),
    *PAIRING_COLUMNS,
    *body_columns(UPPER_BODY, 2),
    *body_columns(LOWER_BODY, 2),
)
# -


def make_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="sliding_disks_2d.py",
        description="Two elastic disks hitting off-centre and sliding past each other, "
        "paired again by closest points as they slide.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    add_method_arguments(parser, gamma0=1e-3, degree=2, dt=0.1, t_end=14.0)
    parser.add_argument("--mesh-size", type=finite_float, default=4.0, help="mesh size h")
    parser.add_argument(
        "--vx", type=finite_float, default=2.0,
        help="speed of each disk along x (the upper one to -x, the lower one to +x)",
    )  # fmt: skip
    parser.add_argument(
        "--vy", type=finite_float, default=0.3,
        help="speed of each disk along y, towards the other",
    )  # fmt: skip
    parser.add_argument("--gap", type=finite_float, default=1.0, help="initial gap along y")
    parser.add_argument(
        "--offset", type=finite_float, default=36.0,
        help="distance of the centres along x, across the line of approach",
    )  # fmt: skip
    parser.add_argument("--variant", choices=("unbiased", "biased"), default="unbiased")
    parser.add_argument(
        "--follow", action=argparse.BooleanOptionalAction, default=True,
        help="pair again as the surfaces slide (--no-follow: once, in the reference "
        "configuration)",
    )  # fmt: skip
    parser.add_argument("--out", default=os.path.join("out", "sliding_disks_2d"))
    add_terminal_arguments(parser, draws="the energy figure and the picture")
    return parser


def check_arguments(args) -> None:
    method_parameters(args)
    require(args.vy > 0, "vy", args.vy, "the disks must move towards each other")
    require(args.gap >= 0, "gap", args.gap, "the gap must be >= 0")
    require(abs(args.offset) < 2 * RADIUS, "offset", args.offset, "less than a diameter (40)")
    check_body_mesh(args.mesh_size, order=2, radius=RADIUS, dim=2)
    check_output_folder(args.out)


# ## The pair that follows the sliding
#
# `two_bodies_problem` builds the two disks, the lower one the mirror image of the upper
# one in the plane $y = 0$, then moves them by `offset / 2` along $x$ in opposite
# directions, and pairs the upper disk's lower half with the lower disk's upper
# half by closest points (`along_axis=False`), followed as they slide. Each disk then
# gets its velocity, and is declared a body for its columns in the history.
#
# With `--no-follow` the nodes keep the partners of the reference configuration, and
# the gap is linearised about it while the disks move by 28: at the defaults they touch
# at $t = 4.6$, still 2 apart, and the contact stops their sliding: at $t = 14$ the
# upper disk moves at $(-0.01, 1.25)$, where the pairing that follows the sliding lets
# it go on at $(-1.96, -0.01)$.


def sliding_disks(args):
    problem, cells = two_bodies_problem(
        dim=2, mesh_size=args.mesh_size, v0=args.vy, gap=args.gap, degree=args.degree,
        gamma0=args.gamma0, nitsche_theta=args.nitsche_theta, variant=args.variant,
        along_axis=False, gamma0_scaling=args.gamma0_scaling, mass=scheme_mass(args),
        offset=args.offset, follow=args.follow,
    )  # fmt: skip
    velocity = np.array([args.vx, args.vy])
    velocities = {UPPER_BODY: -velocity, LOWER_BODY: velocity}
    problem.set_initial_conditions(velocity=body_velocities(problem, cells, velocities))
    for tag in (UPPER_BODY, LOWER_BODY):
        problem.add_body(tag, cells)
    return problem


# ## What the run kept
#
# The momenta are compared with one disk's, $m|v|$, and the angular momenta with
# $m|v|R$; $E_\Theta - $ `pairing_energy` with $E_\Theta(0)$. How far the surfaces slid:
# the centres' relative motion along $x$ between the first and the last time level in
# contact, in cells of the mesh. At the defaults (measured, serially and on 2 ranks): the
# total momentum within $5\cdot10^{-13}$ of $m|v|$, the angular momentum within
# $6\cdot10^{-4}$ of $m|v|R$; $E_\Theta - $ `pairing_energy` rising by at most
# $10^{-13}$ of $E_\Theta(0)$, the pairings' change $-0.14\%$ of it; 104 pairings,
# the surfaces sliding 7.1 cells.


def summary(history, args, pairings: int, dofs: int, seconds: float) -> None:
    print(f"{dofs} DOFs")
    contact = history.contact_interval()
    touching = "never" if contact is None else f"from t = {contact[0]:.3f} to {contact[1]:.3f}"
    print(f"{len(history) - 1} steps of tau = {args.dt:g} in {seconds:.1f} s; contact {touching}")
    mass = np.pi * RADIUS**2  # rho = 1
    speed = np.hypot(args.vx, args.vy)
    momentum = max(np.abs(history[name]).max() for name in momentum_columns(2))
    angular = [
        np.ptp(history[name]) / (mass * speed * RADIUS)
        for name in (*angular_momentum_columns(2), *angular_momentum_columns(2, reference=True))
    ]
    print(
        f"momentum: largest |total| / (m |v|) {momentum / mass / speed:.1e}; angular momentum: "
        f"largest change / (m |v| R) {angular[0]:.1e}, about the reference positions "
        f"{angular[1]:.1e}"
    )
    energy, pairing = history["energy_theta"], history["pairing_energy"]
    rise = np.diff(energy - pairing).max() / energy[0]
    print(
        f"E_Theta: largest rise of E_Theta - pairing_energy {rise:.1e} of E_Theta(0); the "
        f"pairings changed it by {pairing[-1] / energy[0]:+.2e}, E_Theta(T)/E_Theta(0) - 1 = "
        f"{history.energy_drift('energy_theta'):+.2e}; Newton "
        f"{history.mean_newton_iterations():.2f} per step"
    )
    if contact is None:
        slid = 0.0
    else:
        t = history["t"]
        relative = history["centre_of_mass_1_x"] - history["centre_of_mass_2_x"]
        slid = abs(relative[t == contact[1]][0] - relative[t == contact[0]][0])
    print(
        f"{pairings} pairings (the first in the reference configuration); the surfaces slid "
        f"{slid:.1f} in contact, {slid / args.mesh_size:.1f} cells of h = {args.mesh_size:g}"
    )


def main(argv: list[str] | None = None) -> None:
    parser = make_parser()
    args = parser.parse_args(argv)
    snapshot = Snapshot(at=PICTURE_TIME)  # the fields gathered on rank 0 for the picture
    with one_line_errors(parser):
        check_arguments(args)
        problem = sliding_disks(args)
        history, dofs, seconds = run_simulation(
            args, problem, args.out, COLUMNS, args.quiet, snapshot
        )
    pairings = problem.pairs[0].pairing.generation
    if MPI.COMM_WORLD.rank != 0:
        return
    summary(history, args, pairings, dofs, seconds)
    print(written_to(args.out, args.output_every))
    if not args.no_plot:
        followed = "followed" if args.follow else "paired once"
        title = figure_title(
            f"two disks sliding, {args.variant}, closest points {followed}",
            gamma0=args.gamma0, h=f"{args.mesh_size:g}", dt=args.dt,
        )  # fmt: skip
        energy_figure([history], ["two disks"], ["tab:blue"], title,
                      os.path.join(args.out, "energy.png"))  # fmt: skip
        picture = os.path.join(args.out, f"deformed_t{PICTURE_TIME:g}.png")
        render_deformed(snapshot, 2, f"two disks sliding, {args.variant}", picture, ground=False)


if __name__ == "__main__":
    main()
