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
# The defaults are the talk's: P2 Lagrange, $h \approx 8$ (482 tetrahedra; the
# talk's ball has about 400), $\tau = 0.1$, $T = 40$, $\Theta = 1$,
# $\gamma_0 = 10^{-3}$. For the energy figure, the main run is compared with
# the other three schemes of the talk: Crank-Nicolson, backward Euler
# ($\theta = 1$) and Newmark with $\beta = 1/2$, $\gamma = 1$, the Newmark
# scheme the talk proves stable ($\beta = 1/4$, $\gamma = 1/2$ would be
# Crank-Nicolson again); `--scheme newmark` also defaults to it.
#
# With these defaults (numbers printed by this demo; serial and
# `mpirun -n 2` histories agree to $10^{-13}$):
#
# - the ball (2625 DOFs, 400 steps) first touches the plane at $t = 10.1$,
#   the first time level with a positive contact force (at $t = 10$ its
#   lowest point just reaches the plane), stays on it until $t = 29.1$ and
#   flies up again. The contact force peaks at $1.3 \cdot 10^4$, four times
#   the weight of the ball, at $t = 19.5$;
# - with the hybrid scheme $E_\Theta^h$ never increases (its largest rise
#   over one step is $3 \cdot 10^{-14} E_\Theta^h(0)$, round-off); it loses
#   0.044 % in all, half of it in the first two time units of the impact.
#   $E^h$ itself swings by up to 0.36 % during the contact (the Nitsche terms
#   that make the difference between $E^h$ and $E_\Theta^h$) and ends 0.039 %
#   below its initial value;
# - Crank-Nicolson ends as close ($-0.015$ %), but its $E_\Theta^h$
#   increases in 88 steps, by up to $10^{-5} E_\Theta^h(0)$ in one step,
#   while the ball unloads and leaves the plane ($19 \le t \le 29$): no
#   energy estimate holds for it;
# - backward Euler loses 21 % of the energy, 1 % of it already during the
#   fall, and Newmark (1/2, 1) loses 11 %, all of it during the contact;
#   both never increase $E_\Theta^h$, as the talk proves;
# - the largest penetration, 0.20, is about $\gamma_h$ times the contact
#   pressure: it shrinks with $\gamma_0$. Newton needs 1.02 iterations per
#   step.
#
# Each run's time loop takes about 6 s with the default direct solver on a
# two-core machine with OpenBLAS (MUMPS spends most of it re-factorising the
# Jacobian, at every change of the contact set: 183 times), about 4 s with
# `--linear-solver lu-lagged`; with the comparison, the demo takes about a
# minute.
#
# ## Linear solvers
#
# Each Newton iteration solves one linear system with the Jacobian
# $M + c\,\tau^2 (K + \text{contact part})$. The library assembles the bulk
# part once and changes the matrix only when the contact set changes. The
# `--linear-solver` flag chooses how to solve with it:
#
# - `lu` (default): a direct factorisation, with MUMPS when PETSc has it
#   (serially its LDL^T here, since the Jacobian is symmetric for $\Theta = 1$;
#   PETSc's own LU is serial only), redone at every change of the matrix;
# - `lu-lagged`: the last factorisation as the preconditioner of GMRES,
#   redone only when GMRES needs more than 10 iterations
#   (`Simulation(preconditioner_lag=10)`);
# - `cg-gamg`, `gmres-gamg`: conjugate gradients (the Jacobian is symmetric
#   positive definite for $\Theta = 1$) or GMRES, preconditioned by PETSc's
#   algebraic multigrid with the six rigid motions of the ball as the
#   near-nullspace of the matrix, as in dolfinx's elasticity demo;
#   `--petsc pc_gamg_threshold=0.02` and the like tune it.
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
from _impact import main

# -

# ### Main
#
# The main run writes `OUT/history.csv` and `OUT/solution.xdmf`, and its
# callback keeps the fields at $t = 18$ for the picture. Unless `--no-compare`,
# the other schemes of the energy figure run with the same parameters into
# `OUT/<scheme>/history.csv`. A bad parameter, a Newton failure or a PETSc
# error stops the demo with a one-line message. A Newton failure, SIGINT or
# SIGTERM stops it after the last complete step, with the history and the
# fields readable and that state saved in `OUT/checkpoint` (also every K steps
# with `--checkpoint-every K`); `--restart` continues from it.

if __name__ == "__main__":
    main(3, "ball", "Impact of an elastic ball on a rigid plane (3D), Nitsche's method.")
