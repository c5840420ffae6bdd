# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
#       format_version: '1.5'
# ---

# # Impact of an elastic ball on a rigid plane: the 3D test of the talk
#
# An elastic ball of diameter 40 is held 5 above a rigid plane and released:
# gravity pulls it down, it hits the plane at $t = 10$ with speed 1, flattens,
# bounces off and flies up again, vibrating. This is the 3D experiment of
# Chouly, Hild & Renard, "A Nitsche finite element method for dynamic
# contact" (M2AN 49, 2015), whose talk shows the deformed ball coloured by
# von Mises at $t = 18$ and the energy $E^h$ of four time schemes.
#
# It shows how to
#
# - build the talk's ball with `impact_problem` (a curved P2 gmsh mesh whose
#   lower hemisphere is the contact boundary $\Gamma_C$);
# - march it with the hybrid scheme, or the theta, Newmark or Crank-Nicolson
#   schemes, with a choice of linear solvers (direct, lagged direct, or
#   conjugate gradients with algebraic multigrid and the rigid-body
#   near-nullspace), serially or under `mpirun`;
# - write `history.csv` (energies, contact force, penetration, every step)
#   and `solution.xdmf` (displacement, velocity, von Mises, for ParaView);
# - compare the energy of the schemes and draw the deformed ball.
#
# ## Equation and problem definition
#
# The ball $\Omega$ of radius 20 centred at $(0, 0, 20)$ touches the plane
# $z = 0$ at one point. With $\rho = 1$, Lamé coefficients $\lambda = \mu = 20$
# and gravity $f = (0, 0, -0.1)$, find $u(t, x)$ such that
#
# $$
# \begin{align}
# \rho \ddot u - \operatorname{div} \sigma(u) &= f && \text{in } (0, T) \times \Omega, \\
# \sigma(u) n &= 0 && \text{on } \partial\Omega \setminus \Gamma_C, \\
# u_n \le g, \quad \sigma_n(u) \le 0, \quad \sigma_n(u)\,(u_n - g) &= 0
#   && \text{on } \Gamma_C, \\
# u(0) = (0, 0, 5), \quad \dot u(0) &= 0,
# \end{align}
# $$
#
# where $\Gamma_C$ is the lower hemisphere, $g(x) = x_3$ the initial gap,
# $n_c = (0, 0, -1)$ the obstacle normal and $u_n = u \cdot n_c$. The ball
# is free (no Dirichlet condition). It falls $5$ in
# $t = \sqrt{2 \cdot 5 / 0.1} = 10$ and arrives with speed $1$; the pressure
# wave speed is $\sqrt{(\lambda + 2\mu)/\rho} \approx 7.7$.
#
# Nitsche's method puts the three contact conditions into the weak form as one
# term, $\int_{\Gamma_C} \frac{1}{\gamma_h}[P_\gamma(u_h)]_+ P_{\Theta\gamma}(v_h)$
# with $P_\gamma(u) = u_n - g - \gamma_h \sigma_n(u)$ and $\gamma_h = \gamma_0 h_T$
# (docs/method.md section 2). The hybrid scheme takes the bulk terms at the
# midpoint and switches the contact term per quadrature point; with $\Theta = 1$
# it never increases the energy $E_\Theta^h$ (docs/method.md sections 3 and 4).
#
# ## Parameters and results
#
# The defaults are the talk's: P2, $h \approx 8$, $\tau = 0.1$, $T = 40$,
# $\Theta = 1$, $\gamma_0 = 10^{-3}$; the main run is compared with
# Crank-Nicolson, backward Euler and Newmark ($\beta = 1/2$, $\gamma = 1$).
# `--linear-solver` picks a preset of `nitsche_dolfinx.linear_solvers`. What
# the demo prints, and what it shows, is in `docs/results.md`.
#
# ## Implementation
#
# The test case is `nitsche_dolfinx.cases.impact_problem(dim=3, ...)`: the gmsh
# ball (`nitsche_dolfinx.shapes.ball_mesh`, second-order geometry), a
# `ContactProblem` with `Material.from_lame(20, 20, rho=1)`, a `PlaneObstacle`
# through the origin with normal $(0, 0, 1)$ on the lower hemisphere, the body
# force and the initial displacement. `demos/disk_2d.py` runs this same script
# with `dim=2`.

# +
import argparse
import os
import time

import numpy as np
from mpi4py import MPI

from nitsche_dolfinx import Simulation, make_scheme
from nitsche_dolfinx.arguments import (
    add_method_arguments,
    add_run_arguments,
    add_terminal_arguments,
    check_output_folder,
    finite_float,
    method_parameters,
    petsc_option,
)
from nitsche_dolfinx.cases import impact_problem
from nitsche_dolfinx.checkpoint import has_checkpoint
from nitsche_dolfinx.errors import one_line_errors
from nitsche_dolfinx.history import FRICTION_HISTORY_COLUMNS, HISTORY_COLUMNS
from nitsche_dolfinx.linear_solvers import LINEAR_SOLVERS
from nitsche_dolfinx.parameters import require
from nitsche_dolfinx.pictures import Snapshot, render_deformed
from nitsche_dolfinx.plotting import energy_figure, latex_number
from nitsche_dolfinx.shapes import check_body_mesh

# -

# ### The command line
#
# The scheme and Nitsche flags are the library's (`add_method_arguments`,
# checked by `method_parameters` before anything is computed, and reported
# under their flag); the defaults are the talk's. The schemes of the energy
# figure take the talk's parameters: Newmark with $\beta = 1/2$, $\gamma = 1$,
# the member the talk proves stable.

COMPARED_SCHEMES = {
    "hybrid": {},
    "cn": {},
    "theta": {"theta": 1.0},
    "newmark": {"beta": 0.5, "gamma": 1.0},
}
COLOURS = {"hybrid": "tab:blue", "cn": "tab:red", "theta": "tab:green", "newmark": "tab:orange"}
PICTURE_TIME = 18.0  # the time of the talk's picture


def make_parser(description: str, default_out: str) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        description=description, formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
    add_method_arguments(parser, gamma0=1e-3, degree=2, dt=0.1, t_end=40.0, beta=0.5, gamma=1.0)
    parser.add_argument("--mesh-size", type=finite_float, default=8.0, help="mesh size h")
    parser.add_argument(
        "--mu", type=finite_float, default=None, help="Coulomb coefficient (default: none)"
    )
    parser.add_argument(
        "--tangential-velocity", type=finite_float, default=0.0, help="initial velocity along x"
    )
    parser.add_argument("--out", default=default_out, help="output folder")
    parser.add_argument(
        "--linear-solver",
        choices=tuple(LINEAR_SOLVERS),
        default="auto",
        help="; ".join(f"{name}: {what}" for name, what in LINEAR_SOLVERS.items()),
    )
    parser.add_argument(
        "--petsc", type=petsc_option, action="append", default=[], metavar="KEY=VALUE",
        help="extra PETSc option of the step's solver (repeatable; wins over --linear-solver)",
    )  # fmt: skip
    add_run_arguments(parser)
    add_terminal_arguments(parser)
    parser.add_argument("--no-plot", action="store_true", help="no energy figure, no picture")
    parser.add_argument(
        "--compare", action=argparse.BooleanOptionalAction, default=True,
        help="also run the other schemes of the talk's energy figure (into OUT/<scheme>)",
    )  # fmt: skip
    return parser


def check_arguments(args: argparse.Namespace, dim: int) -> None:
    """Every flag in range and the output folder writable, before any computing."""
    method_parameters(args)
    require(args.mesh_size > 0, "mesh_size", args.mesh_size, "the mesh size must be positive")
    check_body_mesh(args.mesh_size, order=2, radius=20.0, dim=dim)  # not too many cells
    check_output_folder(args.out)


# ### One run
#
# The API in four lines: the problem of the test case, a `Simulation` with the
# scheme and a linear-solver preset, and `run`, which writes `history.csv`
# (and `solution.xdmf` every `--output-every` steps) and returns the
# `History`. With `--restart` a compared run continues from its own
# checkpoint if it has one.


def run(args, dim: int, scheme: str, out: str, compared: bool = False, callback=None):
    """One impact run; returns its History and what the summary says of it."""
    parameters = {"theta": args.theta, "beta": args.beta, "gamma": args.gamma}
    if compared:
        parameters.update(COMPARED_SCHEMES[scheme])
    problem = impact_problem(
        dim=dim, mesh_size=args.mesh_size, degree=args.degree, gamma0=args.gamma0,
        nitsche_theta=args.nitsche_theta, friction=args.mu,
        tangential_velocity=args.tangential_velocity, gamma0_scaling=args.gamma0_scaling,
    )  # fmt: skip
    simulation = Simulation(
        problem, make_scheme(scheme, **parameters), dt=args.dt, t_end=args.t_end,
        petsc_options=dict(args.petsc), linear_solver=args.linear_solver,
        progress=not (args.quiet or compared), max_step_cuts=args.max_step_cuts,
    )  # fmt: skip
    restart = args.restart and (not compared or has_checkpoint(os.path.join(out, "checkpoint")))
    MPI.COMM_WORLD.barrier()
    start = time.perf_counter()
    history = simulation.run(
        out=out,
        columns=HISTORY_COLUMNS if args.mu is None else FRICTION_HISTORY_COLUMNS,
        output_every=0 if compared else args.output_every,
        callback=callback,
        checkpoint_every=args.checkpoint_every,
        restart=restart,
    )
    seconds = MPI.COMM_WORLD.allreduce(time.perf_counter() - start, op=MPI.MAX)
    simulation.solver.destroy()  # collectively, not whenever the garbage collector runs
    label = f"Nitsche + {simulation.scheme.describe()}"
    return history, {"label": label, "out": out, "seconds": seconds, "dofs": simulation.dofs,
                     "linear_solver": simulation.solver_description}  # fmt: skip


# ### The summary
#
# One line per run from `History.summary()`: the first contact, the drifts of
# $E^h$ and $E_\Theta^h$ over $[0, T]$, the largest one-step rise of
# $E_\Theta^h$, the largest penetration and the Newton iterations per step.


def print_summary(runs: list, args: argparse.Namespace) -> None:
    history, main = runs[0]
    cut = history.cut_steps()
    steps = f"{len(history) - 1} steps" + (f" ({cut} of them cut)" if cut else "")
    print(
        f"{main['dofs']} DOFs (P{args.degree}, h = {args.mesh_size:g}), {steps} "
        f"of tau = {args.dt:g} to T = {args.t_end:g}, Theta = {args.nitsche_theta:g}, "
        f"gamma0 = {args.gamma0:g}, linear solver {main['linear_solver']}"
    )
    print(
        f"{'run':40s} {'1st contact':>11s} {'E(T)/E(0)-1':>12s} {'E_Th drift':>11s} "
        f"{'max dE_Th/E_Th(0)':>17s} {'max penetr.':>11s} {'Newton':>6s} {'loop (s)':>8s}"
    )
    for history, info in runs:
        s = history.summary()
        first = "never" if np.isnan(s["first_contact"]) else f"{s['first_contact']:.3f}"
        print(
            f"{info['label']:40s} {first:>11s} {s['energy_drift']:+12.3e} "
            f"{s['energy_theta_drift']:+11.3e} {s['largest_rise']:17.2e} "
            f"{history['penetration_max'].max():11.3e} {s['mean_newton_iterations']:6.2f} "
            f"{info['seconds']:8.2f}"
        )
    if args.mu is not None:
        work, balance = history["friction_dissipation"], history["energy_balance_residual"]
        print(
            f"friction (mu_f = {args.mu:g}): frictional work {work.sum():.6g}, smallest D^n "
            f"{work.min():+.3e}, largest |E_Th^(n+1) - E_Th^n + D^n| {abs(balance).max():.3e}"
        )
    for _, info in runs:
        print(f"history: {os.path.join(info['out'], 'history.csv')}")


# ### Main
#
# The main run keeps the fields at $t = 18$ for the picture (a `Snapshot`
# callback, gathered on rank 0); unless `--no-compare` (or with friction),
# the other schemes of the energy figure run into `OUT/<scheme>`. A bad flag,
# a Newton failure or a signal stops the demo with one line; the state of the
# last complete step is then in `OUT/checkpoint`, and `--restart` continues.


def main(dim: int = 3, body: str = "ball", argv: list[str] | None = None) -> None:
    description = f"Impact of an elastic {body} on a rigid plane ({dim}D), Nitsche's method."
    parser = make_parser(description, default_out=os.path.join("out", f"{body}_{dim}d"))
    args = parser.parse_args(argv)
    compare = args.compare and args.mu is None  # the talk's figure is frictionless
    schemes = [args.scheme] + [s for s in COMPARED_SCHEMES if compare and s != args.scheme]
    snapshot = Snapshot(at=PICTURE_TIME)
    with one_line_errors(parser):
        check_arguments(args, dim)
        runs = [run(args, dim, args.scheme, args.out, callback=snapshot)]
        for name in schemes[1:]:
            runs.append(run(args, dim, name, os.path.join(args.out, name), compared=True))
    if MPI.COMM_WORLD.rank != 0:
        return
    print_summary(runs, args)
    if args.output_every > 0:
        print(f"fields: {os.path.join(args.out, 'solution.xdmf')}")
    if not args.no_plot:
        title = (
            rf"{body}, Nitsche $\Theta = {args.nitsche_theta:g}$, "
            rf"$\gamma_0 = {latex_number(args.gamma0)}$, P{args.degree}, "
            rf"$h = {args.mesh_size:g}$, $\tau = {latex_number(args.dt)}$"
        )
        labels = [info["label"] for _, info in runs]
        colours = [COLOURS[name] for name in schemes]
        energy_figure([h for h, _ in runs], labels, colours, title, f"{args.out}/energy.png")
        picture = os.path.join(args.out, "deformed_t18.png")
        render_deformed(snapshot, dim, f"{body}, {labels[0]}", picture)


if __name__ == "__main__":
    main()
