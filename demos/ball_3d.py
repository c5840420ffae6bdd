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
# Chouly, Hild & Renard, "A Nitsche finite element method for dynamic contact"
# (M2AN 49, 2015), whose talk shows the ball coloured by von Mises at $t = 18$
# and the energy $E^h$ of four time schemes.
#
# It shows how to build the talk's ball (`cases.impact_problem`: a curved P2 gmsh
# mesh whose lower hemisphere is the contact boundary $\Gamma_C$), run it with any
# scheme and linear solver, serially or under `mpirun`, writing `history.csv` and
# `solution.xdmf` (for ParaView), and compare the energy of the schemes.
#
# ## Equation and problem definition
#
# The ball $\Omega$ of radius 20 centred at $(0, 0, 20)$ touches the plane
# $z = 0$ at one point. With $\rho = 1$, $\lambda = \mu = 20$ and gravity
# $f = (0, 0, -0.1)$, find $u(t, x)$ such that
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
# with $\Gamma_C$ the lower hemisphere, $g(x) = x_3$, $n_c = (0, 0, -1)$, $u_n = u
# \cdot n_c$; the ball is free (no Dirichlet condition). Nitsche's method
# writes the contact conditions as one term (docs/method.md section 2); with
# $\Theta = 1$ the hybrid scheme never increases $E_\Theta^h$ (sections 3 and 4).
# The defaults are the talk's: P2, $h \approx 8$, $\tau = 0.1$, $T = 40$,
# $\Theta = 1$, $\gamma_0 = 10^{-3}$, compared with Crank-Nicolson, backward Euler
# and Newmark; what it prints is in `docs/results.md`. `demos/disk_2d.py` runs
# this script in 2D. `--law neo_hookean --gamma0 1e-4` makes the ball hyperelastic,
# at finite strains (docs/method.md section 15; `demos/ball_3d_neo_hookean.toml`):
# its elements near the contact lose half their volume, its peak force is 6% above
# the linear ball's and comes 1.2 earlier. With the talk's gamma0 = 1e-3, E_Theta
# no longer controls the energy there; `--law svk` turns elements inside out (St
# Venant-Kirchhoff gives way under strong compression) and the run stops saying so.

# +
import argparse
import os
import time

from mpi4py import MPI

from nitsche_dolfinx import Simulation, make_scheme
from nitsche_dolfinx.cases import IMPACT_SCHEMES, impact_problem
from nitsche_dolfinx.cli import (
    add_method_arguments,
    add_parameter_argument,
    add_run_arguments,
    add_terminal_arguments,
    check_output_folder,
    finite_float,
    method_parameters,
    one_line_errors,
    petsc_option,
    step_taken,
)
from nitsche_dolfinx.common import require
from nitsche_dolfinx.meshing import check_body_mesh
from nitsche_dolfinx.output import (
    FINITE_COLUMNS,
    FRICTION_HISTORY_COLUMNS,
    HISTORY_COLUMNS,
    has_checkpoint,
)
from nitsche_dolfinx.post import (
    SCHEME_COLOURS,
    Snapshot,
    energy_figure,
    figure_title,
    friction_summary,
    render_deformed,
    runs_table,
    steps_text,
    written_to,
)
from nitsche_dolfinx.solvers import LINEAR_SOLVERS

# -

# ### The command line

PICTURE_TIME = 18.0  # the time of the talk's picture


def make_parser(description: str, default_out: str) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        description=description, formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
    add_method_arguments(parser, gamma0=1e-3, degree=2, dt=0.1, t_end=40.0, beta=0.5, gamma=1.0)
    parser.add_argument("--mesh-size", type=finite_float, default=8.0, help="mesh size h")
    parser.add_argument("--mu", type=finite_float, default=None, help="Coulomb coefficient")
    add_parameter_argument(parser, "--law")
    parser.add_argument("--tangential-velocity", type=finite_float, default=0.0, help="v0 along x")
    parser.add_argument("--out", default=default_out, help="output folder")
    parser.add_argument(
        "--linear-solver", choices=tuple(LINEAR_SOLVERS), default="auto",
        help="; ".join(f"{name}: {what}" for name, what in LINEAR_SOLVERS.items()),
    )  # fmt: skip
    parser.add_argument(
        "--petsc", type=petsc_option, action="append", default=[], metavar="KEY=VALUE",
        help="extra PETSc option of the step's solver (repeatable; wins over --linear-solver)",
    )  # fmt: skip
    add_run_arguments(parser)
    add_terminal_arguments(parser, draws="the energy figure and the picture")
    parser.add_argument(
        "--compare", action=argparse.BooleanOptionalAction, default=True,
        help="also run the other schemes of the talk's energy figure (into OUT/<scheme>)",
    )  # fmt: skip
    return parser


# ### One run
#
# The problem of the test case, a `Simulation` with the scheme and a linear-solver
# preset, and `run`, which writes `history.csv` (and `solution.xdmf` every
# `--output-every` steps) and returns the `History`. The compared schemes take the
# talk's parameters, `cases.IMPACT_SCHEMES`: Newmark with $\beta = 1/2$,
# $\gamma = 1$, the member it proves stable. With `--restart` a compared run
# continues from its own checkpoint if it has one.


def run(args, dim: int, scheme: str, out: str, compared: bool = False, callback=None):
    """One impact run; returns its History and what the summary says of it. The explicit
    verlet scheme takes the lumped mass; the main run's step (``--dt auto``: the verlet
    scheme's) becomes ``--dt``, the compared runs'."""
    parameters = {"theta": args.theta, "beta": args.beta, "gamma": args.gamma,
                  "safety": args.safety, "force_dt": args.force_dt}  # fmt: skip
    if compared:
        parameters.update(IMPACT_SCHEMES[scheme])
    time_scheme = make_scheme(scheme, **parameters)
    problem = impact_problem(
        dim=dim, mesh_size=args.mesh_size, degree=args.degree, gamma0=args.gamma0,
        nitsche_theta=args.nitsche_theta, friction=args.mu,
        tangential_velocity=args.tangential_velocity, gamma0_scaling=args.gamma0_scaling,
        mass="lumped" if time_scheme.explicit else "consistent", law=args.law,
    )  # fmt: skip
    simulation = Simulation(
        problem, time_scheme, dt=args.dt, t_end=args.t_end,
        petsc_options=dict(args.petsc), linear_solver=args.linear_solver,
        progress=not (args.quiet or compared), max_step_cuts=args.max_step_cuts,
    )  # fmt: skip
    if not compared:
        args.dt = step_taken(simulation, args.quiet)
    restart = args.restart and (not compared or has_checkpoint(os.path.join(out, "checkpoint")))
    MPI.COMM_WORLD.barrier()
    start = time.perf_counter()
    history = simulation.run(
        out=out, columns=_columns(problem, args.mu),
        output_every=0 if compared else args.output_every, callback=callback,
        checkpoint_every=args.checkpoint_every, restart=restart,
    )  # fmt: skip
    seconds = MPI.COMM_WORLD.allreduce(time.perf_counter() - start, op=MPI.MAX)
    if simulation.solver is not None:  # collectively, not whenever the garbage collector runs
        simulation.solver.destroy()
    label = f"Nitsche + {simulation.scheme.describe()}"
    return history, label, seconds, (simulation.dofs, simulation.solver_description)


# ### Main
#
# The main run keeps the fields at $t = 18$ for the picture (a `Snapshot`
# callback); unless `--no-compare` (or with friction), the other schemes run into
# `OUT/<scheme>`. A bad flag, a Newton failure or a signal stops the demo with one
# line (the last complete step saved in `OUT/checkpoint`, `--restart` goes on).
# Then one line per run (`reports.runs_table`), the talk's energy figure and the
# deformed ball (pyvista, optional).


def _columns(problem, mu) -> tuple[str, ...]:
    """The history's columns: with friction its balance, at finite strains det_F_min."""
    columns = HISTORY_COLUMNS if mu is None else FRICTION_HISTORY_COLUMNS
    return (*columns, *(FINITE_COLUMNS if problem.finite else ()))


def main(dim: int = 3, body: str = "ball", argv: list[str] | None = None) -> None:
    description = f"Impact of an elastic {body} on a rigid plane ({dim}D), Nitsche's method."
    parser = make_parser(description, default_out=os.path.join("out", f"{body}_{dim}d"))
    args = parser.parse_args(argv)
    compare = args.compare and args.mu is None  # the talk's figure is frictionless
    schemes = [args.scheme] + [s for s in IMPACT_SCHEMES if compare and s != args.scheme]
    outs = [args.out] + [os.path.join(args.out, name) for name in schemes[1:]]
    snapshot = Snapshot(at=PICTURE_TIME)
    with one_line_errors(parser):
        method_parameters(args)  # the scheme and Nitsche flags in range, before computing
        require(args.mesh_size > 0, "mesh_size", args.mesh_size, "the mesh size must be positive")
        check_body_mesh(args.mesh_size, order=2, radius=20.0, dim=dim)  # not too many cells
        check_output_folder(args.out)
        runs = [run(args, dim, args.scheme, args.out, callback=snapshot)]
        runs += [run(args, dim, s, out, compared=True) for s, out in zip(schemes[1:], outs[1:])]
    if MPI.COMM_WORLD.rank != 0:
        return
    history, _, _, (dofs, linear_solver) = runs[0]
    print(
        f"{dofs} DOFs (P{args.degree}, h = {args.mesh_size:g}), {steps_text(history)} of "
        f"tau = {args.dt:g} to T = {args.t_end:g}, Theta = {args.nitsche_theta:g}, "
        f"gamma0 = {args.gamma0:g}, linear solver {linear_solver}"
    )
    runs_table([run[:3] for run in runs])
    if args.mu is not None:
        friction_summary(history, args.mu)
    print(written_to(args.out, args.output_every, outs))
    if not args.no_plot:
        title = figure_title(
            body, args.nitsche_theta, args.gamma0, args.degree, f"{args.mesh_size:g}", args.dt
        )
        labels = [label for _, label, _, _ in runs]
        colours = [SCHEME_COLOURS[name] for name in schemes]
        energy_figure([run[0] for run in runs], labels, colours, title, f"{args.out}/energy.png")
        picture = os.path.join(args.out, "deformed_t18.png")
        render_deformed(snapshot, dim, f"{body}, {labels[0]}", picture)


if __name__ == "__main__":
    main()
