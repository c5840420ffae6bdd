# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
#       format_version: '1.5'
# ---

# # A bouncing elastic ring: dynamic contact by Nitsche's method in 2D
#
# An elastic ring (an annulus of outer radius 1 and inner radius 0.6, in plane
# strain) is thrown at the ground $y = 0$: it starts 0.1 above it, moving
# down with speed 1 under gravity. It hits the ground, flattens, rolls its
# deformation around the ring, and bounces off, vibrating. The contact is
# treated by the Nitsche method of Chouly, Hild & Renard, "A Nitsche finite
# element method for dynamic contact" (M2AN 49, 2015), with the hybrid time
# scheme of the paper by default.
#
# It shows how to
#
# - read a gmsh mesh with tagged boundaries (`meshes/ring_2d.msh`, made by
#   `meshes/ring_2d.py`) with `load_mesh`;
# - build a `ContactProblem` with a body force, an initial velocity and a rigid
#   plane obstacle on part of the boundary;
# - run it with a `Simulation`, writing `history.csv` (energies, contact force,
#   penetration at every step) and `solution.xdmf` (displacement, velocity and
#   von Mises stress, for ParaView);
# - plot the energy balance and draw the squeezed ring.
#
# ## Equation and problem definition
#
# On the ring $\Omega$, with Young's modulus $E$, Poisson's ratio $\nu$,
# density $\rho$ and gravity $f = (0, -\rho g)$, find $u(t, x)$ such that
#
# $$
# \begin{align}
# \rho \ddot u - \operatorname{div} \sigma(u) &= f && \text{in } (0, T) \times \Omega, \\
# \sigma(u) n &= 0 && \text{on } \partial\Omega \setminus \Gamma_C, \\
# u_n \le g, \quad \sigma_n(u) \le 0, \quad \sigma_n(u)\,(u_n - g) &= 0
#   && \text{on } \Gamma_C, \\
# u(0) = 0, \quad \dot u(0) &= (0, -1),
# \end{align}
# $$
#
# where $\Gamma_C$ is the lower half of the outer circle, $g(x) = x_2$ the
# initial gap to the ground, $n_c = (0, -1)$ the obstacle normal,
# $u_n = u \cdot n_c$ and $\sigma_n(u) = (\sigma(u) n) \cdot n_c$. There is no
# Dirichlet condition: the ring is free.
#
# Nitsche's method puts the three contact conditions into the weak form as one
# term, $\int_{\Gamma_C} \frac{1}{\gamma_h}[P_\gamma(u_h)]_+ P_{\Theta\gamma}(v_h)$
# with $P_\gamma(u) = u_n - g - \gamma_h \sigma_n(u)$ and $\gamma_h = \gamma_0 h_T$
# (docs/method.md section 2). The hybrid scheme takes the bulk terms at the
# midpoint and switches the contact term per quadrature point; with $\Theta = 1$
# it never increases the energy $E_\Theta^h$ (docs/method.md sections 3 and 4).
#
# ## Parameters
#
# $E = 1000$, $\nu = 0.3$, $\rho = 1$, $g = 1$, $\gamma_0 = 10^{-6}$,
# $\tau = 0.005$, $T = 1$ on the default mesh (378 P1 triangles). What the
# demo prints with them, and why these values, is in `docs/results.md`.
#
# ## Implementation

# +
import argparse
import os
import time

from mpi4py import MPI

from nitsche_dolfinx import ContactProblem, Material, PlaneObstacle, Simulation
from nitsche_dolfinx.cli import (
    add_method_arguments,
    add_terminal_arguments,
    method_parameters,
    one_line_errors,
    scheme_from_arguments,
    scheme_mass,
    step_taken,
)
from nitsche_dolfinx.meshing import load_mesh
from nitsche_dolfinx.post import (
    Snapshot,
    energy_figure,
    figure_title,
    render_deformed,
    run_summary,
    written_to,
)

REPOSITORY = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEFAULT_MESH = os.path.join(REPOSITORY, "meshes", "ring_2d.msh")

# Facet tag of Gamma_C, the lower half of the outer circle (RING_CONTACT in meshes/ring_2d.py)
RING_CONTACT = 1

# Material, gravity and initial velocity (see "Parameters" above)
MATERIAL = Material(E=1000.0, nu=0.3, rho=1.0)
GRAVITY = 1.0
INITIAL_VELOCITY = (0.0, -1.0)
PICTURE_TIME = 0.3  # the ring on the ground, nearly at its most squeezed (defaults)
# -

# ### Command line
#
# Every parameter of the method and of the scheme is a flag. Range checks are
# the library's: a bad value stops the demo with a one-line message naming it.


def make_parser() -> argparse.ArgumentParser:
    """The command-line parser of the demo."""
    parser = argparse.ArgumentParser(
        description="2D bouncing elastic ring: dynamic contact by Nitsche's method.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    add_method_arguments(parser, gamma0=1e-6, degree=1, dt=0.005, t_end=1.0)
    parser.add_argument(
        "--mesh", default=DEFAULT_MESH, help="gmsh .msh file of the ring (from meshes/ring_2d.py)"
    )
    parser.add_argument("--out", default=os.path.join("out", "ring_2d"), help="output folder")
    add_terminal_arguments(parser, draws="the energy figure and the picture")
    return parser


# ### The problem
#
# The mesh file holds the facet tags of the generator: 1 for $\Gamma_C$, 2 for
# the upper half of the outer circle, 3 for the inner circle. Only $\Gamma_C$
# is used: the rest of the boundary is traction-free. The ground is the plane
# through the origin whose normal $(0, 1)$ points to the admissible side. The mass
# is consistent, lumped with the explicit `--scheme verlet`, whose step is by
# default its share of the stable step it estimates (`--dt auto`).


def ring_simulation(args: argparse.Namespace) -> Simulation:
    """The ring with the parameters of ``args``.

    Raises:
        ValueError: If a parameter is out of range or the mesh cannot be read.
    """
    method_parameters(args)
    scheme = scheme_from_arguments(args)
    mesh, facet_tags = load_mesh(args.mesh)
    if mesh.geometry.dim != 2:
        raise ValueError(f"mesh {args.mesh!r} is {mesh.geometry.dim}D, the ring is 2D")
    problem = ContactProblem(
        mesh,
        facet_tags,
        MATERIAL,
        degree=args.degree,
        gamma0=args.gamma0,
        nitsche_theta=args.nitsche_theta,
        gamma0_scaling=args.gamma0_scaling,
        mass=scheme_mass(args),
    )
    problem.add_body_force((0.0, -MATERIAL.rho * GRAVITY))
    problem.add_obstacle(PlaneObstacle(point=(0.0, 0.0), normal=(0.0, 1.0)), RING_CONTACT)
    problem.set_initial_conditions(velocity=INITIAL_VELOCITY)
    return Simulation(
        problem,
        scheme,
        dt=args.dt,
        t_end=args.t_end,
        progress=not args.quiet,
        max_step_cuts=args.max_step_cuts,
    )


# ### Main
#
# A bad parameter stops the demo with a one-line message naming it, as does a
# Newton failure (the message names the step and the time). Then the numbers of
# the run (`reports.run_summary`: the energy change, the largest one-step rise of
# $E_\Theta^h$, at most round-off for the hybrid scheme with $\Theta = 1$, the
# contact force, penetration and interval, the Newton iterations) and the energy
# figure (`plotting.energy_figure`: $E^h$, its kinetic, elastic and gravity parts
# and $E_\Theta^h$; their relative changes; the contact force), and the ring at
# $t = 0.3$, squeezed on the ground, coloured by von Mises (a `Snapshot` of the run,
# drawn by `pictures.render_deformed`). matplotlib and pyvista are optional.


def main(argv: list[str] | None = None) -> None:
    """Run the demo with the command-line arguments ``argv``."""
    parser = make_parser()
    args = parser.parse_args(argv)
    start = time.perf_counter()
    with one_line_errors(parser):
        simulation = ring_simulation(args)
        args.dt = step_taken(simulation, args.quiet)  # --dt auto: the verlet scheme's step
        snapshot = Snapshot(at=PICTURE_TIME)
        history = simulation.run(out=args.out, output_every=args.output_every, callback=snapshot)
    seconds = time.perf_counter() - start

    if MPI.COMM_WORLD.rank == 0:
        run_summary(history, seconds)
        print(written_to(args.out, args.output_every))
        if not args.no_plot:
            title = figure_title(
                f"2D bouncing ring, {simulation.scheme.describe()}", args.nitsche_theta,
                args.gamma0, args.degree, dt=args.dt,
            )  # fmt: skip
            path = os.path.join(args.out, "ring_2d.png")
            energy_figure([history], ["$E^h$"], ["black"], title, path)
            picture = os.path.join(args.out, f"deformed_t{PICTURE_TIME:g}.png")
            render_deformed(snapshot, 2, "ring on the ground", picture, ground=False)


if __name__ == "__main__":
    main()
