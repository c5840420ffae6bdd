"""Nitsche contact with a rigid obstacle at finite strain, in the current configuration
(docs/method.md section 15).

The point X of Gamma_C is at x = X + u. With the obstacle's signed distance d and its
normal n_c at x, and the nominal traction P N on the reference normal N::

    sigma_n(u)      = (P(u) N) . n_c(x)
    P_gamma(u)      = -d(x) - gamma_h sigma_n(u)
    P_Thgamma(u; v) = D(-d(x))[v] - Theta gamma_h D sigma_n(u)[v]
    contact term    = int_Gamma_C (1/gamma_h) [P_gamma(u)]_+ P_Thgamma(u; v)
    consistency     = -int_Gamma_C Theta gamma_h sigma_n(u) D sigma_n(u)[v]

integrals over the reference Gamma_C. With Theta = 1 the terms are the derivative of
``-1/2 ||gamma_h^1/2 sigma_n||^2 + 1/2 ||gamma_h^-1/2 [P_gamma]_+||^2``. For a plane,
-d(x) = u . n_c - g(X): the small-strain gap exactly.

The hybrid step replaces each derivative D q(u)[v] by its mean along the step,
``int_0^1 D q(u^n + s (u^{n+1} - u^n))[v] ds`` (Gauss in s), whose value at
v = u^{n+1} - u^n is q(u^{n+1}) - q(u^n); P_gamma at the midpoint is the mean of its two
ends. The energy argument of the linear hybrid scheme then holds as it is.

A half of a contact pair between hyperelastic bodies (:class:`FinitePairContact`) takes
the same terms with the pair's gap, -d = (u - T u) . n_c - g, and its n_c, those of the
pairing (docs/method.md section 15, "Contact between bodies").
"""

from __future__ import annotations

from collections.abc import Callable

import ufl
from ufl.algorithms.apply_algebra_lowering import apply_algebra_lowering
from ufl.algorithms.apply_derivatives import apply_derivatives

from ..physics.hyperelastic import gauss_points
from .nitsche import NitscheContact, hybrid_contact_force, positive_part
from .pairs import PairContact

#: The points in s of the contact terms' mean derivatives along a step: exact for St
#: Venant-Kirchhoff and a plane (D sigma_n is then quadratic in s). The neo-Hookean disk's
#: E_Theta rises by 2e-10 E at most with 1 point, 1e-13 with 2 and 4e-14 with 4, whose
#: facet Jacobian is twice as long to compile (docs/method.md section 15).
CONTACT_POINTS = gauss_points(2)

__all__ = ["FiniteContact", "FinitePairContact", "gateaux"]


def gateaux(quantity: Callable, u, v):
    """D q(u)[v], the derivative of the UFL expression ``quantity(u)`` at ``u`` (any
    expression of the displacement space's shape) in the direction of ``v`` (a test
    function or a function of that space)."""
    placeholder = ufl.Coefficient(v.ufl_function_space())
    derivative = ufl.derivative(quantity(placeholder), placeholder, v)
    derivative = apply_derivatives(apply_algebra_lowering(derivative))
    return ufl.replace(derivative, {placeholder: u})


class _FiniteTerms:
    """The contact terms at finite strain of a contact law with ``projection``,
    ``sigma_n``, ``_test_parts`` (D(-d)(u)[v] and D sigma_n(u)[v]), ``gamma_h``,
    ``nitsche_theta`` and ``ds`` (see the module docstring); :meth:`_weighted` scales the
    forms (a contact pair's half, docs/method.md section 15)."""

    def _weighted(self, form):
        return form

    # the small-strain split of the terms (a test projection linear in v, terms affine in
    # u) does not exist here: the test part depends on u (docs/method.md section 15)
    def _no_split(self, *args, **kwargs):
        raise NotImplementedError(
            "the contact terms at finite strain have no affine part nor a test projection "
            "independent of u (docs/method.md section 15): use residual or hybrid_residual"
        )

    test_projection = affine_terms = force_terms = contact_term = _no_split

    def residual(self, u, v, velocity=None, reference=None):
        """The contact terms of B(u)(v) at one time level."""
        force = positive_part(self.projection(u))
        d_pen, d_sigma = self._test_parts(u, v)
        theta_gamma = self.nitsche_theta * self.gamma_h
        test = d_pen - theta_gamma * d_sigma
        form = (force / self.gamma_h * test - theta_gamma * self.sigma_n(u) * d_sigma) * self.ds
        return self._weighted(form)

    def hybrid_residual(self, u_old, u_new, v, velocity=None, reference=None):
        """The hybrid step's contact terms: Phi from P_gamma at both ends, the derivatives
        averaged along the step, sigma_n at the mean of its ends."""
        step = u_new - u_old
        d_pen, d_sigma = 0, 0
        for s, w in CONTACT_POINTS:
            parts = self._test_parts(u_old + s * step, v)
            d_pen = d_pen + w * parts[0]
            d_sigma = d_sigma + w * parts[1]
        P_old, P_new = self.projection(u_old), self.projection(u_new)
        force = hybrid_contact_force(P_old, (P_old + P_new) / 2, P_new)
        sigma_mean = (self.sigma_n(u_old) + self.sigma_n(u_new)) / 2
        theta_gamma = self.nitsche_theta * self.gamma_h
        test = d_pen - theta_gamma * d_sigma
        form = (force / self.gamma_h * test - theta_gamma * sigma_mean * d_sigma) * self.ds
        return self._weighted(form)

    def hybrid_state(self, u_old, u_new):
        """The midpoint and Phi, P_gamma at the midpoint being the mean of its ends."""
        P_old, P_new = self.projection(u_old), self.projection(u_new)
        return (u_old + u_new) / 2, hybrid_contact_force(P_old, (P_old + P_new) / 2, P_new)


class FiniteContact(_FiniteTerms, NitscheContact):
    """Nitsche contact of one Gamma_C with a rigid obstacle that stands still, at finite
    strain (see the module docstring).

    Args:
        obstacle: The rigid obstacle (:mod:`nitsche_dolfinx.physics.obstacles`).
        ds: The measure of Gamma_C on the reference mesh.
        piola: Function from a displacement to its first Piola-Kirchhoff stress P.
        gamma_h: gamma0 h_T (reference cells).
        nitsche_theta: The variant Theta.
    """

    def __init__(self, obstacle, ds, piola, gamma_h, nitsche_theta):
        super().__init__(obstacle, ds, piola, gamma_h, nitsche_theta)
        self.X = ufl.SpatialCoordinate(ds.ufl_domain())

    # -- pointwise quantities at the current position x = X + u -----------------------

    def normal_at(self, u):
        """n_c at x = X + u."""
        return self.obstacle.normal(self.X + u)

    def penetration(self, u):
        """-d(X + u) (> 0 means penetration)."""
        return -self.obstacle.distance(self.X + u)

    def sigma_n(self, u):
        """(P(u) N) . n_c(X + u)."""
        return ufl.dot(ufl.dot(self.stress(u), self.n), self.normal_at(u))

    def projection(self, u):
        """P_gamma(u) = -d(X + u) - gamma_h sigma_n(u)."""
        return self.penetration(u) - self.gamma_h * self.sigma_n(u)

    def _test_parts(self, u, v):
        """D(-d)(u)[v] and D sigma_n(u)[v]."""
        return gateaux(self.penetration, u, v), gateaux(self.sigma_n, u, v)

    def _test_projection_at(self, u, v):
        """P_Thgamma(u; v) = D(-d)(u)[v] - Theta gamma_h D sigma_n(u)[v]."""
        d_pen, d_sigma = self._test_parts(u, v)
        return d_pen - self.nitsche_theta * self.gamma_h * d_sigma

    # -- forms -----------------------------------------------------------------------

    def current_area(self, u):
        """The contact area in the current configuration as a form: H(P_gamma(u)) times
        the change of area J norm(F^-T N) (Nanson's formula), over the reference Gamma_C."""
        F = ufl.Identity(len(u)) + ufl.grad(u)
        stretch = ufl.det(F) * ufl.sqrt(ufl.dot(ufl.inv(F).T * self.n, ufl.inv(F).T * self.n))
        return ufl.conditional(ufl.gt(self.projection(u), 0), stretch, 0) * self.ds


class FinitePairContact(_FiniteTerms, PairContact):
    """One half of a contact pair between hyperelastic bodies (docs/method.md section 15).

    The gap is the pair's, -d = (u - T u) . n_c - g with the pairing's T, n_c and g
    (:class:`~nitsche_dolfinx.contact.pairs.PairContact`): affine in u within a step, with
    D(-d)[v] = v . n_c on the slave side and -(T v) . n_c on the partner's
    (:meth:`~nitsche_dolfinx.contact.pairs.PairContact.partner_term`, unchanged). The normal stress
    is the slave's nominal one, sigma_n(u) = (P(u) N) . n_c, and its test part
    D sigma_n(u)[v] is the Gateaux derivative, as for a rigid obstacle
    (:class:`FiniteContact`); every term is multiplied by the half's ``weight``.
    The arguments are those of :class:`~nitsche_dolfinx.contact.pairs.PairContact`, with the
    first Piola-Kirchhoff stress for ``stress``.
    """

    def _weighted(self, form):
        return self.weight * form

    def _test_parts(self, u, v):
        """The slave's parts: D(-d)(u)[v] = v . n_c and D sigma_n(u)[v]."""
        return ufl.dot(v, self.n_c), gateaux(self.sigma_n, u, v)
