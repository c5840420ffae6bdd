"""The Nitsche contact terms of SPEC section 2, as pure functions of UFL objects.

Notation of the talk, with ``gamma_h = gamma0 h_T``::

    P_gamma(u)      = u_n - g - gamma_h sigma_n(u)
    P_Thgamma(v)    = v_n - Theta gamma_h sigma_n(v)
    A_Thgamma(u, v) = a(u, v) - int_Gamma_C Theta gamma_h sigma_n(u) sigma_n(v)
    contact term    = int_Gamma_C (1/gamma_h) [P_gamma(u)]_+ P_Thgamma(v)
    lambda_h        = -(1/gamma_h) [P_gamma(u)]_+        (contact pressure, <= 0)

Nothing here assembles or solves: every function returns a UFL expression or form.
"""

from __future__ import annotations

import ufl

from .material import sigma_n

__all__ = [
    "NitscheContact",
    "PenaltyContact",
    "heaviside",
    "hybrid_contact_force",
    "nitsche_projection",
    "nitsche_test_projection",
    "positive_part",
]


def positive_part(x):
    """[x]_+ = max(x, 0), as a ``ufl.conditional`` (its derivative is H(x))."""
    return ufl.conditional(ufl.gt(x, 0), x, 0)


def heaviside(x):
    """H(x) = 1 if x > 0, else 0."""
    return ufl.conditional(ufl.gt(x, 0), 1, 0)


def nitsche_projection(u_n, gap, sigma_n_u, gamma_h):
    """P_gamma(u) = u_n - g - gamma_h sigma_n(u): contact where it is positive."""
    return u_n - gap - gamma_h * sigma_n_u


def nitsche_test_projection(v_n, sigma_n_v, gamma_h, nitsche_theta):
    """P_Thgamma(v) = v_n - Theta gamma_h sigma_n(v)."""
    return v_n - nitsche_theta * gamma_h * sigma_n_v


def hybrid_contact_force(P_old, P_mid, P_new):
    """Phi(u^n, u^{n+1}) of the hybrid scheme, evaluated per quadrature point.

    Midpoint ``[P(u^{n+1/2})]_+`` where the point is in contact at t^n
    (P(u^n) > 0), Crank-Nicolson ``([P(u^n)]_+ + [P(u^{n+1})]_+) / 2`` elsewhere.
    P is affine in u, so ``P_mid = (P_old + P_new) / 2``.
    """
    midpoint = positive_part(P_mid)
    crank_nicolson = (positive_part(P_old) + positive_part(P_new)) / 2
    return ufl.conditional(ufl.gt(P_old, 0), midpoint, crank_nicolson)


class NitscheContact:
    """Frictionless Nitsche contact of one boundary part Gamma_C with one rigid obstacle.

    Args:
        obstacle: The rigid obstacle (:mod:`nitsche_dolfinx.obstacles`).
        ds: The measure of Gamma_C, e.g. ``ufl.Measure("ds", mesh, subdomain_data=tags)(tag)``.
        stress: Function from a displacement to its stress tensor.
        gamma_h: gamma0 h_T, an expression constant on each cell.
        nitsche_theta: The variant Theta (1 symmetric, 0 non-symmetric, -1 skew-symmetric).
    """

    def __init__(self, obstacle, ds, stress, gamma_h, nitsche_theta):
        mesh = ds.ufl_domain()
        x = ufl.SpatialCoordinate(mesh)
        self.obstacle = obstacle
        self.ds = ds
        self.stress = stress
        self.gamma_h = gamma_h
        self.nitsche_theta = nitsche_theta
        self.n = ufl.FacetNormal(mesh)
        self.n_c = obstacle.normal(x)
        self.gap = obstacle.gap(x)

    # -- pointwise quantities --------------------------------------------------------

    def normal_displacement(self, u):
        """u_n = u . n_c."""
        return ufl.dot(u, self.n_c)

    def sigma_n(self, u):
        """sigma_n(u) = (sigma(u) n) . n_c."""
        return sigma_n(self.stress(u), self.n, self.n_c)

    def projection(self, u):
        """P_gamma(u)."""
        return nitsche_projection(
            self.normal_displacement(u), self.gap, self.sigma_n(u), self.gamma_h
        )

    def test_projection(self, v):
        """P_Thgamma(v)."""
        return nitsche_test_projection(
            self.normal_displacement(v), self.sigma_n(v), self.gamma_h, self.nitsche_theta
        )

    def pressure(self, u):
        """Discrete contact pressure lambda_h = -(1/gamma_h) [P_gamma(u)]_+ (<= 0)."""
        return -positive_part(self.projection(u)) / self.gamma_h

    def penetration(self, u):
        """u_n - g (> 0 means penetration)."""
        return self.normal_displacement(u) - self.gap

    # -- forms -----------------------------------------------------------------------

    def consistency_term(self, u, v):
        """The boundary part of A_Thgamma: -int Theta gamma_h sigma_n(u) sigma_n(v)."""
        return -self.nitsche_theta * self.gamma_h * self.sigma_n(u) * self.sigma_n(v) * self.ds

    def contact_term(self, force, v):
        """int (1/gamma_h) force P_Thgamma(v), where force is [P_gamma(u)]_+ or Phi."""
        return force / self.gamma_h * self.test_projection(v) * self.ds

    def residual(self, u, v):
        """Boundary terms of the Nitsche operator B(u)(v) at one time level."""
        return self.consistency_term(u, v) + self.contact_term(positive_part(self.projection(u)), v)

    def hybrid_residual(self, u_old, u_new, v):
        """Boundary terms of the hybrid scheme: A_Thgamma at the midpoint and Phi."""
        u_mid = (u_old + u_new) / 2
        force = hybrid_contact_force(
            self.projection(u_old), self.projection(u_mid), self.projection(u_new)
        )
        return self.consistency_term(u_mid, v) + self.contact_term(force, v)

    def energy_correction(self, u):
        """E_Theta - E = -Theta/2 (||gamma_h^1/2 sigma_n(u)||^2 - ||gamma_h^-1/2 [P(u)]_+||^2)."""
        P_plus = positive_part(self.projection(u))
        return (
            -self.nitsche_theta
            / 2
            * (self.gamma_h * self.sigma_n(u) ** 2 - P_plus**2 / self.gamma_h)
            * self.ds
        )

    def force(self, u):
        """Contact force int (1/gamma_h) [P_gamma(u)]_+ (>= 0) as a form."""
        return positive_part(self.projection(u)) / self.gamma_h * self.ds

    def area(self, u):
        """Contact area int H(P_gamma(u)) as a form."""
        return heaviside(self.projection(u)) * self.ds


class PenaltyContact(NitscheContact):
    """Penalised contact, for comparison: the term ``int (1/eps) [u_n - g]_+ v_n`` with
    ``eps = gamma0 h_T``.

    It is the Nitsche term without the stress: ``P = u_n - g`` and ``P_Thgamma(v) = v_n``,
    so every scheme (the hybrid switch included) and every diagnostic carry over.
    Unlike Nitsche's method it is not consistent: the penetration is O(eps).
    ``energy_theta`` then holds E plus the penalty energy ``||eps^-1/2 [u_n - g]_+||^2 / 2``,
    which the semi-discrete problem conserves.
    """

    def projection(self, u):
        """u_n - g."""
        return self.normal_displacement(u) - self.gap

    def test_projection(self, v):
        """v_n."""
        return self.normal_displacement(v)

    def consistency_term(self, u, v):
        """No stress term: zero."""
        return 0 * ufl.inner(u, v) * self.ds

    def energy_correction(self, u):
        """The penalty energy ``1/(2 eps) ||[u_n - g]_+||^2``."""
        return positive_part(self.projection(u)) ** 2 / (2 * self.gamma_h) * self.ds
