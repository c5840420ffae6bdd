# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: light
#       format_version: '1.5'
# ---

# # Impact of an elastic disk on a rigid plane: the 2D version of the talk's ball
#
# The talk's 3D experiment (Chouly, Hild & Renard, "A Nitsche finite element
# method for dynamic contact", M2AN 49, 2015) in the plane: an elastic disk of
# diameter 40, in plane strain, is held 5 above a rigid line and released;
# gravity pulls it down, it hits the line at $t = 10$ with speed 1, flattens,
# bounces off and flies up again, vibrating. It runs in a few seconds, which
# makes it the quick way to see what the four time schemes of the talk do
# with the energy; `demos/ball_3d.py` is the same in 3D.
#
# It shows how to
#
# - build the disk with `impact_problem(dim=2, ...)` (a curved P2 gmsh mesh
#   whose lower half circle is the contact boundary $\Gamma_C$);
# - march it with the hybrid scheme, or the theta, Newmark or Crank-Nicolson
#   schemes, with a choice of linear solvers, serially or under `mpirun`;
# - write `history.csv` and `solution.xdmf`, compare the energy of the
#   schemes and draw the deformed disk coloured by von Mises.
#
# ## Equation and problem definition
#
# The disk $\Omega$ of radius 20 centred at $(0, 20)$ touches the line
# $y = 0$ at one point. With $\rho = 1$, Lamé coefficients
# $\lambda = \mu = 20$ (plane strain) and gravity $f = (0, -0.1)$, find
# $u(t, x)$ such that
#
# $$
# \begin{align}
# \rho \ddot u - \operatorname{div} \sigma(u) &= f && \text{in } (0, T) \times \Omega, \\
# \sigma(u) n &= 0 && \text{on } \partial\Omega \setminus \Gamma_C, \\
# u_n \le g, \quad \sigma_n(u) \le 0, \quad \sigma_n(u)\,(u_n - g) &= 0
#   && \text{on } \Gamma_C, \\
# u(0) = (0, 5), \quad \dot u(0) &= 0,
# \end{align}
# $$
#
# where $\Gamma_C$ is the lower half circle, $g(x) = x_2$ the initial gap,
# $n_c = (0, -1)$ the obstacle normal and $u_n = u \cdot n_c$; the disk is
# free. It falls 5 in $t = 10$ and arrives with speed 1.
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
# The defaults and the compared schemes are those of the ball. What the demo
# prints, and what it shows, is in `docs/results.md`.
#
# ## Implementation
#
# The test case is `nitsche_dolfinx.cases.one_body.impact_problem(dim=2, ...)`: the gmsh
# disk (`nitsche_dolfinx.meshing.shapes.disk_mesh`, second-order geometry), a
# `ContactProblem` with `Material.from_lame(20, 20, rho=1)` (plane strain), a
# `PlaneObstacle` through the origin with normal $(0, 1)$ on the lower half
# circle, the body force and the initial displacement. The flags, the runs,
# the summary and the figures are those of the ball: `demos/ball_3d.py` walks
# through the code, and runs here with `dim=2`.

from ball_3d import main

if __name__ == "__main__":
    main(dim=2, body="disk")
