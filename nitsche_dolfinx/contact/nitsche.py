"""The Nitsche contact terms of docs/method.md section 2, as pure functions of UFL objects.

Notation of the talk, with ``gamma_h = gamma0 h_T``::

    P_gamma(u)      = u_n - g - gamma_h sigma_n(u)
    P_Thgamma(v)    = v_n - Theta gamma_h sigma_n(v)
    A_Thgamma(u, v) = a(u, v) - int_Gamma_C Theta gamma_h sigma_n(u) sigma_n(v)
    contact term    = int_Gamma_C (1/gamma_h) [P_gamma(u)]_+ P_Thgamma(v)
    lambda_h        = -(1/gamma_h) [P_gamma(u)]_+        (contact pressure, <= 0)

Coulomb friction (coefficient mu_f, docs/method.md section 2), with ``[x]_r`` the projection
onto the ball of radius r and ``u'_t`` the tangential velocity of the time scheme::

    P_t(u)          = u'_t - gamma_h sigma_t(u)
    r               = mu_f [P_gamma(u)]_+
    friction term   = int_Gamma_C (1/gamma_h) [P_t(u)]_r . (v_t - Theta gamma_h sigma_t(v))
                      - int_Gamma_C Theta gamma_h sigma_t(u) . sigma_t(v)   (tangential part of A)
    lambda_t        = -(1/gamma_h) [P_t(u)]_r        (friction traction)

Nothing here assembles or solves: every function returns a UFL expression or form.
"""

from __future__ import annotations

import copy

import ufl

from ..physics.material import sigma_n, sigma_t
from ..physics.motion import LEVELS

__all__ = [
    "NitscheContact",
    "ball_projection",
    "guard_activity",
    "guarded_projection",
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


def ball_projection(x, radius):
    """[x]_r: the projection of the vector ``x`` onto the closed ball of radius r >= 0.

    Written as ``k x`` with a scalar factor k, 1 inside the ball and r/norm(x) outside,
    so that ``ufl.derivative`` gives the semismooth Jacobian: the identity inside
    (stick, zero slip included), the tangent projection scaled by r/norm(x) outside (slip).
    Where r = 0 (no contact, or mu_f = 0) the factor and its derivative are exactly
    zero: no 0/0 is ever selected, and [x]_0 = 0 reproduces frictionless contact.
    """
    norm = ufl.sqrt(ufl.dot(x, x))
    inside = ufl.conditional(ufl.le(norm, radius), 1, radius / norm)
    return ufl.conditional(ufl.gt(radius, 0), inside, 0) * x


def guarded_projection(x, radius, reference, reference_radius):
    """[x]_r guarded by a reference state (x_ref, r_ref) of the same point, for Newton.

    - Where the reference sticks (norm(x_ref) <= r_ref): the stick branch, x (0 where r = 0).
    - Where it slips along d = x_ref and x points ahead (x . d >= 0): [x]_r.
    - Where x points behind d (x . d < 0): the component of x along d takes the stick
      branch and the rest is projected onto the ball, ``[x - x_d]_r + x_d`` with
      ``x_d = (x . d / |d|^2) d``; this equals [x]_r on the plane x . d = 0.

    In 1D tangent (2D problems) a slipping reference gives ``min(x, r)`` for d > 0:
    monotone with two affine pieces, so semismooth Newton cannot cycle from one slip
    direction to the other across the thin stick band. The guarded law agrees with
    Coulomb's [x]_r wherever :func:`guard_activity` is 0; with the reference at the point
    itself (x_ref = x, r_ref = r) it is [x]_r everywhere.
    :class:`~nitsche_dolfinx.steppers.friction.GuardedNewton` moves the reference to the guarded
    solution until the two agree.
    """
    switch = ufl.conditional(ufl.gt(radius, 0), 1, 0)
    along = ufl.dot(x, reference)
    d2 = ufl.dot(reference, reference)
    x_d = along / ufl.conditional(ufl.gt(d2, 0), d2, 1) * reference
    behind = ball_projection(x - x_d, radius) + switch * x_d
    slipping = ufl.conditional(ufl.lt(along, 0), behind, ball_projection(x, radius))
    return ufl.conditional(_sticks(reference, reference_radius), switch * x, slipping)


def guard_activity(x, radius, reference, reference_radius):
    """1 where :func:`guarded_projection` differs from [x]_r, else 0: outside the ball
    (norm(x) > r > 0) where the reference sticks or x points behind its slip direction."""
    outside = ufl.And(ufl.gt(radius, 0), ufl.Not(_sticks(x, radius)))
    guarded = ufl.Or(_sticks(reference, reference_radius), ufl.lt(ufl.dot(x, reference), 0))
    return ufl.conditional(ufl.And(outside, guarded), 1, 0)


def _sticks(x, radius):
    """norm(x) <= r, the stick band of [x]_r (as a UFL condition)."""
    return ufl.le(ufl.dot(x, x), radius**2)


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
    """Nitsche contact of one boundary part Gamma_C with one rigid obstacle,
    frictionless or with Coulomb friction.

    Args:
        obstacle: The rigid obstacle (:mod:`nitsche_dolfinx.physics.obstacles`).
        ds: The measure of Gamma_C, e.g. ``ufl.Measure("ds", mesh, subdomain_data=tags)(tag)``.
        stress: Function from a displacement to its stress tensor.
        gamma_h: gamma0 h_T, an expression constant on each cell.
        nitsche_theta: The variant Theta (1 symmetric, 0 non-symmetric, -1 skew-symmetric).
        friction: The Coulomb coefficient mu_f (a ``fem.Constant``), or None for frictionless
            contact: then no tangential term is written at all. With a coefficient, the
            tangential terms are switched on where mu_f > 0, so that mu_f = 0 is exactly
            the frictionless problem (Coulomb's law with mu_f = 0 is sigma_t = 0, which
            the frictionless formulation already satisfies weakly).
    """

    def __init__(self, obstacle, ds, stress, gamma_h, nitsche_theta, friction=None):
        mesh = ds.ufl_domain()
        x = ufl.SpatialCoordinate(mesh)
        self.obstacle = obstacle
        self.ds = ds
        self.stress = stress
        self.gamma_h = gamma_h
        self.nitsche_theta = nitsche_theta
        self.n = ufl.FacetNormal(mesh)
        self.friction = friction
        #: Whether the obstacle moves: the terms then see it at the times of a step
        #: (:meth:`at_level`).
        self.moving = getattr(obstacle, "moving", False)
        if self.moving:
            self._levels = {level: (obstacle.normal(x, level), obstacle.gap(x, level))
                            for level in LEVELS}  # fmt: skip
            self.n_c, self.gap = self._levels["new"]
        else:
            self.n_c = obstacle.normal(x)
            self.gap = obstacle.gap(x)

    def at_level(self, level: str) -> NitscheContact:
        """The contact with its obstacle at a time of the step: ``"old"`` (t^n), ``"mid"``
        (t^{n+1/2}) or ``"new"`` (t^{n+1}, the contact itself); an obstacle that stands
        still is at every level (docs/method.md section 13)."""
        if not self.moving or level == "new":
            return self
        view = copy.copy(self)
        view.n_c, view.gap = self._levels[level]
        return view

    @property
    def frictional(self) -> bool:
        """Whether the contact has a Coulomb coefficient (possibly zero)."""
        return self.friction is not None

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

    def tangential(self, w):
        """w_t = w - (w . n_c) n_c."""
        return w - ufl.dot(w, self.n_c) * self.n_c

    def sigma_t(self, u):
        """sigma_t(u) = sigma(u) n - sigma_n(u) n_c."""
        return sigma_t(self.stress(u), self.n, self.n_c)

    def slip_velocity(self, velocity):
        """u'_t, the tangential velocity (relative to the obstacle, which stands still)."""
        return self.tangential(velocity)

    def tangential_projection(self, u, velocity):
        """P_t(u) = u'_t - gamma_h sigma_t(u)."""
        return self.slip_velocity(velocity) - self.gamma_h * self.sigma_t(u)

    def tangential_test_projection(self, v):
        """v_t - Theta gamma_h sigma_t(v)."""
        return self.tangential(v) - self.nitsche_theta * self.gamma_h * self.sigma_t(v)

    def friction_switch(self):
        """1 where the tangential terms are on (mu_f > 0), else 0."""
        return ufl.conditional(ufl.gt(self.friction, 0), 1, 0)

    def friction_traction(self, u, velocity, normal_force, reference=None):
        """lambda_t = -(1/gamma_h) [P_t(u)]_{mu_f normal_force}, where normal_force is
        [P_gamma(u)]_+ (or the hybrid scheme's Phi). With ``reference``, a map from an
        expression of the unknown to its value at a reference state, the projection is
        guarded by that state's P_t and radius (:func:`guarded_projection`)."""
        x, radius = self._slip_state(u, velocity, normal_force)
        if reference is None:
            return -ball_projection(x, radius) / self.gamma_h
        return -guarded_projection(x, radius, reference(x), reference(radius)) / self.gamma_h

    def guard_activity(self, u, velocity, normal_force, reference):
        """int over Gamma_C of the indicator of :func:`guard_activity`: zero when the
        guarded friction law (see :meth:`friction_traction`) is Coulomb's law at u."""
        x, radius = self._slip_state(u, velocity, normal_force)
        return guard_activity(x, radius, reference(x), reference(radius)) * self.ds

    def _slip_state(self, u, velocity, normal_force):
        """The argument P_t(u) of the friction law and its radius mu_f normal_force."""
        return self.tangential_projection(u, velocity), self.friction * normal_force

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

    def tangential_consistency_term(self, u, v):
        """The tangential part of A_Thgamma: -int Theta gamma_h sigma_t(u) . sigma_t(v),
        where mu_f > 0."""
        return (
            -self.friction_switch()
            * self.nitsche_theta
            * self.gamma_h
            * ufl.dot(self.sigma_t(u), self.sigma_t(v))
            * self.ds
        )

    def friction_term(self, u, velocity, normal_force, v, reference=None):
        """int (1/gamma_h) [P_t(u)]_{mu_f normal_force} . (v_t - Theta gamma_h sigma_t(v))
        (``reference``: the guarded law of :meth:`friction_traction`)."""
        traction = self.friction_traction(u, velocity, normal_force, reference)
        return -ufl.dot(traction, self.tangential_test_projection(v)) * self.ds

    def friction_work(self, u, velocity, normal_force, v):
        """The friction term tested with a displacement ``v`` (a Function: the step's
        increment), the work D^n of docs/method.md section 4."""
        return self.friction_term(u, velocity, normal_force, v)

    def affine_terms(self, u, v):
        """The terms of :meth:`residual` that are affine in u whatever the contact: the
        boundary part of A_Thgamma (its tangential part too with friction)."""
        form = self.consistency_term(u, v)
        if self.frictional:
            form = form + self.tangential_consistency_term(u, v)
        return form

    def force_terms(self, u, velocity, force, v, reference=None):
        """The other terms of :meth:`residual`, those of the normal ``force``: with it, they
        and their derivatives are exactly zero wherever the force is."""
        form = self.contact_term(force, v)
        if self.frictional:
            form = form + self.friction_term(u, self._velocity(velocity), force, v, reference)
        return form

    def residual(self, u, v, velocity=None, reference=None):
        """Boundary terms of the Nitsche operator B(u)(v) at one time level; with friction,
        ``velocity`` is u' at that level (``reference``: see :meth:`friction_traction`)."""
        force = positive_part(self.projection(u))
        return self.affine_terms(u, v) + self.force_terms(u, velocity, force, v, reference)

    def hybrid_residual(self, u_old, u_new, v, velocity=None, reference=None):
        """Boundary terms of the hybrid scheme: A_Thgamma at the midpoint and Phi; with
        friction, the step's mean velocity (u_new - u_old) / tau and the threshold mu_f Phi.
        A moving obstacle is at the middle of the step in these terms."""
        u_mid, force = self.hybrid_state(u_old, u_new)
        mid = self.at_level("mid")
        return mid.affine_terms(u_mid, v) + mid.force_terms(u_mid, velocity, force, v, reference)

    def hybrid_state(self, u_old, u_new):
        """What the hybrid scheme's contact terms see: the midpoint u^{n+1/2} and the
        normal force Phi(u^n, u^{n+1}) per quadrature point. With a moving obstacle,
        P(u^n) with the obstacle at t^n, P(u^{n+1}) at t^{n+1} and their mean for the
        midpoint (docs/method.md section 13)."""
        u_mid = (u_old + u_new) / 2
        if not self.moving:
            P_mid = self.projection(u_mid)
            force = hybrid_contact_force(self.projection(u_old), P_mid, self.projection(u_new))
            return u_mid, force
        P_old, P_new = self.at_level("old").projection(u_old), self.projection(u_new)
        return u_mid, hybrid_contact_force(P_old, (P_old + P_new) / 2, P_new)

    @staticmethod
    def _velocity(velocity):
        if velocity is None:
            raise ValueError("contact with friction needs the velocity u' of the time level")
        return velocity

    def energy_correction(self, u):
        """E_Theta - E = -Theta/2 (||gamma_h^1/2 sigma_n(u)||^2 - ||gamma_h^-1/2 [P(u)]_+||^2),
        and -Theta/2 ||gamma_h^1/2 sigma_t(u)||^2 with friction (mu_f > 0)."""
        P_plus = positive_part(self.projection(u))
        correction = self.gamma_h * self.sigma_n(u) ** 2 - P_plus**2 / self.gamma_h
        if self.frictional:
            correction = correction + self.friction_switch() * self.gamma_h * ufl.dot(
                self.sigma_t(u), self.sigma_t(u)
            )
        return -self.nitsche_theta / 2 * correction * self.ds

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

    def tangential_projection(self, u, velocity):
        """u'_t: penalised friction, ``[u'_t]_{mu_f [u_n - g]_+} / eps``."""
        return self.slip_velocity(velocity)

    def tangential_test_projection(self, v):
        """v_t."""
        return self.tangential(v)

    def tangential_consistency_term(self, u, v):
        """No stress term: zero."""
        return 0 * ufl.inner(u, v) * self.ds

    def energy_correction(self, u):
        """The penalty energy ``1/(2 eps) ||[u_n - g]_+||^2``."""
        return positive_part(self.projection(u)) ** 2 / (2 * self.gamma_h) * self.ds
