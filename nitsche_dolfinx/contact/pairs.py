"""Contact between two deformable bodies by Nitsche's method (docs/method.md section 11):
the contact terms of a pair and its halves.

A pair is a slave surface Gamma_1 and a master surface Gamma_2, each node of Gamma_1
paired with a point pi(x) of Gamma_2 by a matrix T, (T u)(x_i) = u(pi(x_i))
(:class:`~nitsche_dolfinx.contact.pairing.Pairing`). The contact law is that of a rigid
obstacle (:class:`~nitsche_dolfinx.contact.nitsche.NitscheContact`, the hybrid switch
included) with

    u_n = (u - T u) . n_c,   g = (X(pi(x)) - X(x)) . n_c,   n_c = -(outer normal of Gamma_2),

X the reference positions, the normal taken at pi(x). The test projection is
P_Thgamma(v) = (v - T v) . n_c - Theta gamma_h sigma_n(v). The part of the residual
tested by T v is assembled as a vector G on the slave side and added as T^T G; within a
step T and n_c are fixed, and the Jacobian is exact for them: with w~ = T w the partner
of the scheme's unknown,

    J = dF/dw + (dF/dw~) T + T^T (dG/dw) + T^T (dG/dw~) T.

The unbiased variant is two biased pairs, each surface slave in turn, each with weight 1/2.
Coulomb friction acts on the relative slip velocity (u' - T u')_t, its partner part in G
(docs/method.md section 11, "Friction between bodies").
"""

from __future__ import annotations

import ufl
from dolfinx import fem
from ufl.algorithms import extract_coefficients

from .nitsche import NitscheContact
from .pairing import Pairing

__all__ = ["CONTACT_PAIR_VARIANTS", "PairContact", "pair_halves"]

#: ``"unbiased"``: each surface slave in turn with weight 1/2; ``"biased"``: the first
#: surface is the slave, and only its stress enters.
CONTACT_PAIR_VARIANTS = ("unbiased", "biased")


class _PartnerSurface:
    """The master surface as seen from the slave nodes, behind the interface of a rigid
    obstacle (:mod:`nitsche_dolfinx.physics.obstacles`): n_c and g interpolated from the nodes."""

    def __init__(self, pairing: Pairing):
        self.pairing = pairing

    def normal(self, x):
        return self.pairing.normal

    def gap(self, x):
        return ufl.dot(self.pairing.gap_vector, self.pairing.normal)


class PairContact(NitscheContact):
    """One biased half of a contact pair: Gamma_1 (``ds``) against its partner surface.

    The law is :class:`~nitsche_dolfinx.contact.nitsche.NitscheContact`'s with the relative
    normal displacement (u - T u) . n_c and, with friction, the relative slip velocity
    (u' - T u')_t, every term multiplied by ``weight`` (1/2 for each half of the
    unbiased variant). The part tested by the partner's displacement,
    :meth:`partner_force_terms`, is assembled apart and added through T^T
    (:class:`~nitsche_dolfinx.assembly.pair_coupling.PairCoupling`).

    Args:
        pairing: The :class:`~nitsche_dolfinx.contact.pairing.Pairing` of Gamma_1 with Gamma_2.
        weight: 1 (biased) or 1/2 (a half of the unbiased variant).
        follow: Pair the surfaces again in the configuration of the last converged step
            when they have slid (:meth:`~nitsche_dolfinx.contact.pairing.Pairing.slid`);
            False: in the reference configuration only.
        friction: The Coulomb coefficient mu_f (a ``fem.Constant``), or None.

    The other arguments are those of :class:`~nitsche_dolfinx.contact.nitsche.NitscheContact`.
    """

    def __init__(
        self, pairing, ds, stress, gamma_h, nitsche_theta, weight: float, follow: bool = True,
        friction=None,
    ):  # fmt: skip
        super().__init__(_PartnerSurface(pairing), ds, stress, gamma_h, nitsche_theta, friction)
        self.pairing = pairing
        self.weight = float(weight)
        self.follow = bool(follow)
        self.partners: dict = {}  # Function -> its partner T f

    def track(self, functions) -> None:
        """Give each Function of the state (u, v, a and the unknown) a partner T f."""
        for function in functions:
            if function not in self.partners:
                self.partners[function] = fem.Function(function.function_space)

    def update(self, functions=None) -> None:
        """Recompute the partners of ``functions`` (default: of every tracked Function)."""
        for function in self.partners if functions is None else functions:
            self.pairing.apply(function, self.partners[function])

    def partner(self, expression):
        """The expression with every tracked Function f replaced by its partner T f."""
        replaced = ufl.replace(expression, self.partners)
        tracked = set(self.partners.values())
        for coefficient in extract_coefficients(replaced):
            space = getattr(coefficient, "function_space", None)
            if space is not None and space == self.pairing.normal.function_space:
                if coefficient not in tracked and coefficient not in self._surface():
                    raise ValueError(
                        f"contact pair: {coefficient} has no partner (not in the state)"
                    )
        return replaced

    def _surface(self):
        return (self.pairing.normal, self.pairing.gap_vector)

    # -- the law of NitscheContact with the partner -----------------------------------

    def normal_displacement(self, u):
        """(u - T u) . n_c (for the test function: v . n_c, see :meth:`test_projection`)."""
        return ufl.dot(u - self.partner(u), self.n_c)

    def test_projection(self, v):
        """v . n_c - Theta gamma_h sigma_n(v): the slave's part; the partner's is
        :meth:`partner_term`."""
        return ufl.dot(v, self.n_c) - self.nitsche_theta * self.gamma_h * self.sigma_n(v)

    def consistency_term(self, u, v):
        return self.weight * super().consistency_term(u, v)

    def contact_term(self, force, v):
        return self.weight * super().contact_term(force, v)

    def partner_term(self, force, v):
        """-weight int (1/gamma_h) force (T v) . n_c, with ``v`` standing for T v."""
        return -self.weight * force / self.gamma_h * ufl.dot(v, self.n_c) * self.ds

    def partner_force_terms(self, u, velocity, force, v, reference=None):
        """The terms of :meth:`force_terms` tested by the partner (``v`` standing for T v):
        :meth:`partner_term` and, with friction, :meth:`friction_partner_term`."""
        form = self.partner_term(force, v)
        if self.frictional:
            velocity = self._velocity(velocity)
            form = form + self.friction_partner_term(u, velocity, force, v, reference)
        return form

    # -- Coulomb friction on the relative slip (docs/method.md section 11) -----------

    def slip_velocity(self, velocity):
        """The relative tangential velocity (u' - T u')_t."""
        return self.tangential(velocity - self.partner(velocity))

    def tangential_consistency_term(self, u, v):
        return self.weight * super().tangential_consistency_term(u, v)

    def friction_term(self, u, velocity, normal_force, v, reference=None):
        """The slave's part, weighted: the test's tangential part is v_t (the partner's,
        -(T v)_t, is :meth:`friction_partner_term`)."""
        return self.weight * super().friction_term(u, velocity, normal_force, v, reference)

    def friction_partner_term(self, u, velocity, normal_force, v, reference=None):
        """weight int lambda_t . (T v)_t, with ``v`` standing for T v: the friction term's
        part tested by the partner, -(T v)_t in the relative test v_t - (T v)_t."""
        traction = self.friction_traction(u, velocity, normal_force, reference)
        return self.weight * ufl.dot(traction, self.tangential(v)) * self.ds

    def friction_work(self, u, velocity, normal_force, v):
        """The friction term tested with the increment ``v`` of both bodies: the slave's
        part and the partner's, on T v (``v`` a tracked Function)."""
        slave = self.friction_term(u, velocity, normal_force, v)
        return slave + self.friction_partner_term(u, velocity, normal_force, self.partner(v))

    def energy_correction(self, u):
        return self.weight * super().energy_correction(u)

    def force(self, u):
        return self.weight * super().force(u)

    def area(self, u):
        return self.weight * super().area(u)


def pair_halves(
    problem, tag_a: int, tag_b: int, variant: str, direction, follow: bool = True,
    kind: type = PairContact,
) -> list[PairContact]:  # fmt: skip
    """The biased halves of a contact pair of ``problem`` (a
    :class:`~nitsche_dolfinx.model.problem.ContactProblem`) between the facets ``tag_a`` and
    ``tag_b``: one, slave ``tag_a``, with weight 1 (``"biased"``), or one per surface
    with weight 1/2 (``"unbiased"``); paired along the unit vector ``direction`` (from
    ``tag_a`` towards ``tag_b``; reversed for the other half) or, None, with closest
    points; ``follow``: paired again as the surfaces slide
    (:meth:`~nitsche_dolfinx.contact.pairing.Pairing.slid`).
    ``tag_a == tag_b``: self-contact, one half with weight 1/2 (each node of the surface
    is a slave, so that each touching pair of points is counted twice, as in the unbiased
    variant), paired again at every step. ``kind``: the class of the halves
    (:class:`PairContact`, or the finite-strain one of
    :class:`~nitsche_dolfinx.contact.finite.FinitePairContact`)."""
    facets = {tag: problem.facets(tag) for tag in (tag_a, tag_b)}
    sides = [(tag_a, tag_b, direction)]
    if variant == "unbiased" and tag_a != tag_b:
        sides.append((tag_b, tag_a, None if direction is None else -direction))
    weight = 1.0 if variant == "biased" and tag_a != tag_b else 0.5
    halves = []
    for slave, master, along in sides:
        pairing = Pairing(problem.V, facets[slave], facets[master], along)
        halves.append(
            kind(
                pairing,
                problem.ds(slave),
                problem.stress,
                problem.gamma_h,
                problem.nitsche_theta,
                weight,
                follow,
                problem.friction,
            )  # fmt: skip
        )
    return halves
