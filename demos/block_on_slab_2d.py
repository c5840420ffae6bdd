# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
#       format_version: '1.5'
# ---

# # A block sliding on a deformable slab: Coulomb friction between two bodies
#
# The block of `friction_block_2d.py` (2 x 1, plane strain, $E = 10^4$, $\nu = 0$,
# $\rho = 1$, P1) is thrown at $v_0 = 1.5$ along a slab of the same material,
# $9 \times 0.5$, held at its bottom; gravity $g = 1$ acts on both. Coulomb
# friction of coefficient $\mu_f = 0.2$ between the block's bottom and the slab's
# top slows it down: a rigid block stops after $v_0^2/(2\mu_f g) = 5.6$, some 22
# cells of the slab, at $t = v_0/(\mu_f g) = 7.5$.
#
# The two surfaces are a contact pair (docs/method.md section 11): each node of
# the block's bottom is paired with its closest point on the slab's top, paired
# again as the block slides by a tenth of a facet, and the friction law of
# section 2 acts on the relative slip velocity $(\dot u - T\dot u)_t$, $T$ the
# pairing:
#
# $$
# \sigma_t = -\frac{1}{\gamma_h}\big[(\dot u - T\dot u)_t
#   - \gamma_h\sigma_t(u)\big]_{\mu_f[P_\gamma(u)]_+} .
# $$
#
# It shows how to
#
# - give a contact pair Coulomb friction: `ContactProblem(..., friction=mu_f)`
#   and `add_contact_pair` (here through
#   `nitsche_dolfinx.cases.two_bodies.block_on_slab_problem`);
# - follow the energy: `friction_dissipation` (the friction's work $D^n$ on the
#   relative slip), `energy_balance_residual` ($E_\Theta^{n+1} - E_\Theta^n + D^n$)
#   and `pairing_energy` (the change of $E_\Theta$ at the pairings) in
#   `history.csv`: for the hybrid scheme with $\Theta = 1$,
#   $E_\Theta$ less `pairing_energy` plus $\sum D^n$ never rises.
#
# Run it with `python demos/block_on_slab_2d.py --out out/block_on_slab` (serially
# or under `mpirun -n 2`).

# +
from __future__ import annotations

import argparse
import os
import sys

import numpy as np
import ufl
from mpi4py import MPI

from nitsche_dolfinx import Simulation
from nitsche_dolfinx.cases import BLOCK, block_on_slab_problem
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
from nitsche_dolfinx.output import FRICTION_HISTORY_COLUMNS, PAIRING_COLUMNS, BoundaryAverage
from nitsche_dolfinx.post import (
    Snapshot,
    energy_figure,
    figure_title,
    friction_summary,
    render_deformed,
)

#: ``history.csv`` columns: those of the friction block, the pairings' change of E_Theta,
#: and the block's mean velocity and displacement along the slab.
COLUMNS = (*FRICTION_HISTORY_COLUMNS, *PAIRING_COLUMNS, "mean_velocity", "mean_displacement")
SLAB = {"slab_start": -1.5, "slab_length": 9.0, "slab_nx": 36}  # 36 cells of 0.25
# -


def parse_arguments(argv=None) -> tuple[argparse.ArgumentParser, argparse.Namespace]:
    parser = argparse.ArgumentParser(
        prog="block_on_slab_2d.py",
        description="A stiff block sliding on a deformable slab with Coulomb friction.",
    )
    add_method_arguments(parser, gamma0=1e-7, degree=1, dt=0.05, t_end=8.5)
    parser.add_argument("--mu", type=finite_float, default=0.2, help="friction coefficient")
    parser.add_argument("--v0", type=finite_float, default=1.5, help="initial velocity along x")
    parser.add_argument("--out", default="out/block_on_slab_2d", help="output folder")
    add_terminal_arguments(parser, draws="the energy figure and the picture")
    return parser, parser.parse_args(argv)


# The problem, the block's mean velocity and displacement as history columns, and the
# run, which keeps the fields of its last time level for the picture (a `Snapshot`):


# +
def run(args, snapshot):
    problem, cells = block_on_slab_problem(
        friction=args.mu, v0=args.v0, degree=args.degree, gamma0=args.gamma0,
        nitsche_theta=args.nitsche_theta, gamma0_scaling=args.gamma0_scaling,
        mass=scheme_mass(args), **SLAB,
    )  # fmt: skip
    simulation = Simulation(
        problem, scheme_from_arguments(args), dt=args.dt, t_end=args.t_end,
        progress=not args.quiet, max_step_cuts=args.max_step_cuts,
    )  # fmt: skip
    block = ufl.Measure(
        "dx", domain=problem.mesh, subdomain_data=cells, metadata=problem.dx.metadata()
    )(BLOCK)
    for name, function in (("mean_velocity", simulation.v), ("mean_displacement", simulation.u)):
        simulation.add_probe(name, BoundaryAverage(problem.mesh, function[0], block))
    return simulation.run(
        out=args.out, columns=COLUMNS, output_every=args.output_every, callback=snapshot
    )


# -
# Where the block stopped, against a rigid block, and where the energy went; then the
# energy figure (with $E_\Theta$ less `pairing_energy` plus $\sum D^n$, which never rises)
# and the block on the slab at the end, coloured by von Mises (pyvista, optional):


# +
def main(argv=None) -> None:
    parser, args = parse_arguments(argv)
    with one_line_errors(parser):
        method_parameters(args)  # --mu among them: checked before anything is computed
        check_output_folder(args.out)
        snapshot = Snapshot(at=args.t_end)  # the last time level, for the picture
        history = run(args, snapshot)
    if MPI.COMM_WORLD.rank != 0:
        return
    rigid = args.v0**2 / (2 * args.mu) if args.mu > 0 else float("inf")
    lost = history["kinetic"][0] - history["kinetic"][-1]
    work = history["friction_dissipation"]
    controlled = history["energy_theta"] - history["pairing_energy"] + np.cumsum(work)
    print(
        f"a rigid block stops after {rigid:.4g}; the block slid "
        f"{history['mean_displacement'][-1]:.6g} (mean velocity at t = {history['t'][-1]:g}: "
        f"{history['mean_velocity'][-1]:.3g})"
    )
    print(
        f"kinetic energy lost {lost:.6g}, friction's work {work.sum():.6g}; largest rise of "
        f"E_Theta - pairing_energy + sum D {np.diff(controlled).max():.2e}"
    )
    friction_summary(history, args.mu)
    print(
        f"history: {os.path.join(args.out, 'history.csv')}; "
        f"fields: {os.path.join(args.out, 'solution.xdmf')}"
    )
    if not args.no_plot:
        title = figure_title(
            f"block on a slab, Coulomb friction mu = {args.mu:g}", args.nitsche_theta,
            args.gamma0, args.degree, dt=args.dt,
        )  # fmt: skip
        energy_figure([history], ["$E^h$"], ["black"], title, os.path.join(args.out, "energy.png"))
        picture = os.path.join(args.out, "deformed.png")
        render_deformed(snapshot, 2, "block on a slab", picture, ground=False)


if __name__ == "__main__":
    main(sys.argv[1:])
# -
