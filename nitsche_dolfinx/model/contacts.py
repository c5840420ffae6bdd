"""The contacts of a :class:`~nitsche_dolfinx.model.problem.ContactProblem`: rigid
obstacles and contact pairs (docs/method.md sections 2, 11, 13), the pairs' pairing as the
surfaces slide, the moving obstacles, and what may help a contact step that fails.
"""

from __future__ import annotations

import numpy as np
from dolfinx import fem

from ..common.parameters import require, require_choice
from ..contact.finite import FiniteContact, FinitePairContact
from ..contact.nitsche import NitscheContact, PenaltyContact
from ..contact.pairs import CONTACT_PAIR_VARIANTS, PairContact, pair_halves
from ..physics.problem_values import as_array

__all__ = ["ProblemContacts"]


class ProblemContacts:
    """The obstacles and contact pairs of
    :class:`~nitsche_dolfinx.model.problem.ContactProblem` (one of its parts: it reads the
    problem's ``mesh``, ``gdim``, ``method``, ``friction``, ``ds``, ``stress``, ``gamma_h``,
    ``nitsche_theta`` and ``facets``).
    """

    def add_obstacle(self, obstacle, tag: int) -> NitscheContact:
        """Add unilateral contact of the facets ``tag`` (Gamma_C) with a rigid obstacle."""
        self.facets(tag)
        shape = getattr(obstacle, "shape", obstacle)  # a moving obstacle's at t = 0
        point = getattr(shape, "point", None)  # a plane: of the mesh's dimension
        if point is not None and len(point) != self.gdim:
            raise ValueError(
                f"obstacle point {list(point)} has {len(point)} coordinates, the mesh has "
                f"{self.gdim}"
            )
        if getattr(obstacle, "moving", False):
            require(
                self.method != "mixed", "method", self.method,
                "a moving obstacle takes Nitsche's or the penalty method",
            )  # fmt: skip
            require(
                self.friction is None, "friction", float(self.friction.value)
                if self.friction is not None else None,
                "a moving obstacle is frictionless so far (the slip would be relative to it)",
            )  # fmt: skip
            obstacle.bind(self.mesh)
        if self.finite:  # in the current configuration (docs/method.md section 15)
            require(
                not getattr(obstacle, "moving", False), "obstacle", obstacle,
                "a hyperelastic body meets obstacles that stand still so far",
            )  # fmt: skip
            contact = FiniteContact(
                obstacle, self.ds(tag), self.stress, self.gamma_h, self.nitsche_theta
            )
        else:
            law = PenaltyContact if self.method == "penalty" else NitscheContact
            contact = law(
                obstacle, self.ds(tag), self.stress, self.gamma_h, self.nitsche_theta,
                self.friction,
            )  # fmt: skip
        self.contacts.append(contact)
        self.contact_tags.append(tag)
        return contact

    def add_contact_pair(
        self, tag_a: int, tag_b: int, variant: str = "unbiased", direction=None,
        follow: bool | None = None,
    ) -> list:  # fmt: skip
        """Add contact between the facets ``tag_a`` and ``tag_b`` of two bodies (or of two
        parts of one body) of the mesh, by Nitsche's method (docs/method.md section 11).

        Each node of a slave surface is paired with its closest point on the other
        surface, in the reference configuration and, with ``follow``, again in the
        configuration of the last converged step whenever the surfaces have slid along
        each other by 3% of a facet (:data:`~nitsche_dolfinx.contact.pairing.REPAIR_SLIP`). By
        default closest points are followed and a pairing along a ``direction`` is not:
        paired again along a line, the gap is not a distance, and each pairing changes
        E_Theta by the force times the slope of the surface times the slip
        (docs/method.md section 11).
        ``variant="unbiased"`` (the default): each surface is slave in turn with weight
        1/2, and the stresses of both bodies enter; ``"biased"``: ``tag_a`` is the slave,
        and only its stress enters.
        ``tag_a == tag_b``: self-contact, the surface paired with the nearest of its
        points that faces it away from its own neighbourhood, at every step (docs/method.md
        section 11). ``direction``: pair along this direction (from ``tag_a`` towards ``tag_b``)
        instead of with the closest point, with the contact normal n_c = direction: for
        a head-on collision, where it makes a pair of mirror-image bodies exactly one
        body on a rigid plane (docs/method.md section 11). Nitsche only; with the
        problem's ``friction``, Coulomb friction on the relative slip. With a hyperelastic
        material, the halves' terms are those of finite strain
        (:class:`~nitsche_dolfinx.contact.finite.FinitePairContact`, docs/method.md
        section 15).
        Returns the :class:`~nitsche_dolfinx.contact.pairs.PairContact` halves.
        """
        require_choice(variant, CONTACT_PAIR_VARIANTS, "variant", "contact pair variant")
        require(
            self.method == "nitsche", "method", self.method,
            "contact between bodies is Nitsche contact (not penalty nor the mixed method)",
        )  # fmt: skip
        require(
            tag_a != tag_b or (direction is None and follow is not False), "direction",
            direction if follow is not False else follow,
            "self-contact (a surface paired with itself) pairs closest points, again at every "
            "step",
        )  # fmt: skip
        require(
            tag_a != tag_b or self.gdim > 1, "tag_b", tag_b,
            f"a surface paired with itself (tag {tag_a} twice) is self-contact, which needs a "
            "2D or 3D mesh (in 1D a surface is a point)",
        )  # fmt: skip
        unit = None
        if direction is not None:
            unit = as_array(direction, (self.gdim,), "contact pair direction")
            length = float(np.linalg.norm(unit))
            require(length > 0, "direction", unit.tolist(), "the direction must not be zero")
            unit = unit / length
        follow = unit is None if follow is None else bool(follow)
        kind = FinitePairContact if self.finite else PairContact  # docs/method.md section 15
        halves = pair_halves(self, tag_a, tag_b, variant, unit, follow, kind)
        for half in halves:
            self.contacts.append(half)
            self.contact_tags.append(half.ds.subdomain_id())
        return halves

    @property
    def pairs(self) -> list:
        """The halves of the contact pairs (:meth:`add_contact_pair`)."""
        return [contact for contact in self.contacts if isinstance(contact, PairContact)]

    def track_partners(self, *functions) -> None:
        """Give the Functions of a state their partners on every contact pair (the
        stepper's displacement, velocity, acceleration and unknown)."""
        for pair in self.pairs:
            pair.track(functions)

    def follow_pairs(self, u: fem.Function) -> bool:
        """Pair the surfaces of the contact pairs again in the configuration displaced by
        ``u`` (the last converged step's) if any has slid (docs/method.md section 11), all
        of them at once; True if they were (collective)."""
        pairings = [pair.pairing for pair in self.pairs if pair.follow]
        if not any([pairing.slid(u) for pairing in pairings]):
            return False
        for pairing in pairings:
            pairing.pair(u)
        self.update_partners()
        return True

    def pairing_state(self) -> dict:
        """The displacements the pairs were last paired in, by name (``pairing_1``, ...):
        what a restart needs to pair them as the run did (:meth:`restore_pairs`)."""
        halves = (pair for pair in self.pairs if pair.follow)
        return {f"pairing_{k}": pair.pairing.displacement for k, pair in enumerate(halves, 1)}

    def restore_pairs(self) -> None:
        """Pair the surfaces in the displacements of :meth:`pairing_state`, just loaded
        from a checkpoint (collective)."""
        for pair in self.pairs:
            if pair.follow:
                pair.pairing.pair(pair.pairing.displacement)
        self.update_partners()

    def update_partners(self) -> None:
        """Recompute the partners of the tracked Functions (before evaluating a form)."""
        for pair in self.pairs:
            pair.update()

    def solver_hint(self) -> str:
        """What may make a failing contact step converge, in words ('' without contact)."""
        if not self.contacts or self.method == "mixed":
            return ""
        return (
            f"{self._gamma0_in_words()}: a smaller gamma0 ({self._suggested_gamma0()} suits P1 "
            "and P2, see docs/method.md section 10) or a smaller dt may let Newton converge"
        )

    def stability_hint(self) -> str:
        """What may bring a run whose E_Theta lost control of the energy back (docs/method.md
        section 8)."""
        if not self.contacts:
            return "no contact term: check the loads and the initial values"
        return (
            f"{self._gamma0_in_words()} is beyond the stability limit of this mesh and degree: "
            f"use a smaller gamma0 ({self._suggested_gamma0()}, see docs/method.md section 10); "
            "a smaller dt does not help"
        )

    def _gamma0_in_words(self) -> str:
        gamma0 = float(np.asarray(self.gamma0.value))
        if self.gamma0_scaling == "absolute":
            return f"gamma0 * E = {gamma0 * self.largest('E'):.3g}"
        return f"gamma0 = {gamma0:.3g} (scaled by E)"

    def _suggested_gamma0(self) -> str:
        return "about 1e-3 / E" if self.gamma0_scaling == "absolute" else "about 1e-3"

    def _contact_facets(self) -> np.ndarray | None:
        """The local facets of every Gamma_C (None without contact)."""
        if not self.contact_tags:
            return None
        return np.concatenate([self.facets(tag) for tag in self.contact_tags])

    @property
    def frictional(self) -> bool:
        """Whether the contact terms carry Coulomb friction (a coefficient was given)."""
        return self.friction is not None

    @property
    def frictional_contacts(self) -> list[NitscheContact]:
        """The contacts with a Coulomb coefficient (all of them, or none)."""
        return [contact for contact in self.contacts if contact.frictional]

    @property
    def moving_contacts(self) -> list[NitscheContact]:
        """The contacts whose obstacle moves
        (:class:`~nitsche_dolfinx.physics.motion.MovingObstacle`)."""
        return [contact for contact in self.contacts if contact.moving]

    def move_obstacles(self, t_old: float, t_new: float | None = None) -> None:
        """Put the moving obstacles at the times of a step from ``t_old`` to ``t_new``
        (``"old"``, ``"mid"`` and ``"new"``: docs/method.md section 13); without ``t_new``,
        at t_old, the current level."""
        for contact in self.moving_contacts:
            contact.obstacle.move(t_old, t_new)
