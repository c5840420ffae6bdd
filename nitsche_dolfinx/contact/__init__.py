"""The contact terms in UFL (docs/method.md sections 2, 9, 15): Nitsche and penalty contact
with a rigid obstacle (`nitsche`), the contact quantities behind the schemes (`terms`),
contact between bodies (`pairs`; their pairing: `pairing`, on the master surface of
`master_surface`, its closest points by `projection`), finite-strain contact (`finite`), the
coercivity bound of Theta > 0 (`coercivity`), the explicit steps' contact force at
quadrature points (`quadrature`).
"""

from .coercivity import coercivity_ratio, constant_value
from .finite import FiniteContact, FinitePairContact, gateaux
from .nitsche import NitscheContact, PenaltyContact, heaviside, hybrid_contact_force, positive_part
from .pairs import CONTACT_PAIR_VARIANTS, PairContact, pair_halves
from .quadrature import QuadratureContact
from .terms import ContactTerms, GuardedFriction, contact_activity, contact_parts, friction_terms

__all__ = [
    "CONTACT_PAIR_VARIANTS",
    "ContactTerms",
    "FiniteContact",
    "FinitePairContact",
    "GuardedFriction",
    "NitscheContact",
    "PairContact",
    "PenaltyContact",
    "QuadratureContact",
    "coercivity_ratio",
    "constant_value",
    "contact_activity",
    "contact_parts",
    "friction_terms",
    "gateaux",
    "heaviside",
    "hybrid_contact_force",
    "pair_halves",
    "positive_part",
]
