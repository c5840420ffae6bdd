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
# Nitsche's method, with $\gamma_h = \gamma_0 h_T$ and
# $P_\gamma(u) = u_n - g - \gamma_h \sigma_n(u)$, puts the contact
# conditions in the weak form without multiplier:
#
# $$
# (\rho \ddot u_h, v_h) + A_{\Theta\gamma}(u_h, v_h)
# + \int_{\Gamma_C} \frac{1}{\gamma_h} [P_\gamma(u_h)]_+ P_{\Theta\gamma}(v_h)
# = L(v_h) \quad \forall v_h.
# $$
#
# The hybrid scheme takes the bulk terms at the midpoint and the contact
# term, per quadrature point, at the midpoint where the point was in contact
# at $t^n$ and with Crank-Nicolson elsewhere; for $\Theta = 1$ the paper
# proves that it never increases
# $E_\Theta^h = E^h - \frac\Theta2 \big(\|\gamma_h^{1/2}\sigma_n(u_h)\|^2
# - \|\gamma_h^{-1/2}[P_\gamma(u_h)]_+\|^2\big)$, with
# $E^h = \frac12\|\sqrt\rho\,\dot u_h\|^2 + \frac12 a(u_h, u_h) - L(u_h)$
# (kinetic, elastic and gravity energy).
#
# ## Parameters and results
#
# The defaults are the talk's: P2 Lagrange, $h \approx 8$ (the ball has
# about 400 tetrahedra), $\tau = 0.1$, $T = 40$, $\Theta = 1$,
# $\gamma_0 = 10^{-3}$. For the energy figure, the main run is compared with
# the other three schemes of the talk: Crank-Nicolson, backward Euler
# ($\theta = 1$) and Newmark with $\beta = 1/2$, $\gamma = 1$, the Newmark
# scheme the talk proves stable ($\beta = 1/4$, $\gamma = 1/2$ would be
# Crank-Nicolson again); `--scheme newmark` also defaults to it.
#
# RESULTS
#
# ## Implementation
#
# The test case is `nitsche_dolfinx.cases.impact_problem(dim=3, ...)`: the
# gmsh ball (`nitsche_dolfinx.shapes.ball_mesh`, second-order geometry), a
# `ContactProblem` with `Material.from_lame(20, 20, rho=1)`, a
# `PlaneObstacle` through the origin with normal $(0, 0, 1)$ on the lower
# hemisphere, the body force and the initial displacement. What the ball
# and the disk demos share (flags, linear solvers, summary, figures) is in
# `demos/_impact.py`.

# +
import os

from mpi4py import MPI

from _impact import (
    Snapshot,
    compared_runs,
    linear_solver,
    make_parser,
    one_line_errors,
    plot_energies,
    print_summary,
    render_deformed,
    run,
)

DIM = 3
# -

# ### Main
#
# The main run writes `OUT/history.csv` and `OUT/solution.xdmf`, and its
# callback keeps the fields at $t = 18$ for the picture. Unless `--no-compare`,
# the other schemes of the energy figure run with the same parameters into
# `OUT/<scheme>/history.csv`. A bad parameter, a Newton failure or a PETSc
# error stops the demo with a one-line message.


def main(argv: list[str] | None = None) -> None:
    """Run the demo with the command-line arguments ``argv``."""
    parser = make_parser(
        "Impact of an elastic ball on a rigid plane (3D), Nitsche's method.",
        default_out=os.path.join("out", "ball_3d"),
    )
    args = parser.parse_args(argv)
    snapshot = Snapshot(at=18.0)
    with one_line_errors(parser):
        results = [
            run(args, DIM, args.scheme, args.out, output_every=args.output_every, callback=snapshot)
        ]
        schemes = [args.scheme] + compared_runs(args)
        for name in schemes[1:]:
            results.append(run(args, DIM, name, os.path.join(args.out, name), compared=True))
        solver = linear_solver(args.linear_solver)[2]

    if MPI.COMM_WORLD.rank == 0:
        print_summary(results, args, solver)
        if args.output_every > 0:
            print(f"fields: {os.path.join(args.out, 'solution.xdmf')}")
        if not args.no_plot:
            plot_energies(results, schemes, args, "ball", os.path.join(args.out, "energy.png"))
            title = f"ball, {results[0]['label']}, von Mises stress"
            render_deformed(snapshot, DIM, title, os.path.join(args.out, "deformed_t18.png"))


if __name__ == "__main__":
    main()
