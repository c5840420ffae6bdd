"""Contact quantities behind the model interface of the time schemes
(:class:`~nitsche_dolfinx.steppers.schemes.Model`), so that a scheme evaluates each with its own
normal force, slip velocity and threshold (docs/method.md sections 3 and 8).

- :class:`ContactTerms`: one quantity of the contacts of a problem: the friction work,
  the friction traction, the slip velocity, the contact activity, a pair's
  partner-tested terms, the affine and force parts of the contact terms;
- :class:`GuardedFriction`: the problem with its friction law guarded by a reference
  state (docs/method.md section 8);
- :data:`FRICTION_QUANTITIES`: the friction quantities by name.
"""

from __future__ import annotations

import ufl

from .nitsche import positive_part

__all__ = [
    "FRICTION_QUANTITIES",
    "ContactTerms",
    "GuardedFriction",
    "contact_activity",
    "contact_parts",
    "friction_terms",
]


class ContactTerms:
    """A contact quantity of a problem behind the model interface of the time schemes
    (no inertia, bulk or load), so that ``scheme.residual(terms, w, u, v, a, dt, test)``
    evaluates it with the step's own normal force, slip velocity and threshold (hybrid:
    Phi, v^{n+1/2} and mu_f Phi; theta and Newmark: [P_gamma(u^{n+1})]_+, v^{n+1} and
    mu_f [P_gamma(u^{n+1})]_+).

    ``term(contact, u, velocity, normal_force, test)`` is the form of one contact.
    """

    def __init__(self, contacts, term):
        self.contacts = list(contacts)
        self.term = term

    def inertia(self, acceleration, v):
        """No inertia: 0."""
        return 0

    def load(self, v):
        """No load: 0."""
        return 0

    def damping_force(self, velocity, v):
        """No damping: None."""
        return None

    def operator(self, u, v, velocity=None):
        """The sum of ``term`` over the contacts at one time level, with the normal force
        [P_gamma(u)]_+ (``velocity``: u' at that level)."""
        forms = (
            self.term(c, u, velocity, positive_part(c.projection(u)), v) for c in self.contacts
        )
        return sum(forms, 0)

    def hybrid_operator(self, u_old, u_new, v, velocity=None):
        """The sum of ``term`` over the contacts at the midpoint u^{n+1/2}, with the
        obstacle at t^{n+1/2} and the switch Phi as the normal force (``velocity``: the
        step's mean velocity)."""
        form = 0
        for contact in self.contacts:
            u_mid, force = contact.hybrid_state(u_old, u_new)
            form = form + self.term(contact.at_level("mid"), u_mid, velocity, force, v)
        return form


class GuardedFriction:
    """A :class:`ContactProblem` whose friction law is guarded by a reference state
    (:func:`~nitsche_dolfinx.contact.nitsche.guarded_projection`), behind the model interface of
    the time schemes. ``reference`` maps an expression of the unknown to its value at
    the reference state."""

    def __init__(self, problem, reference):
        self.problem = problem
        self.reference = reference

    def inertia(self, acceleration, v):
        """The problem's inertia term (the guard changes only the contact terms)."""
        return self.problem.inertia(acceleration, v)

    def load(self, v):
        """The problem's loads."""
        return self.problem.load(v)

    def damping_force(self, velocity, v):
        """The problem's damping force, or None without damping."""
        return self.problem.damping_force(velocity, v)

    def operator(self, u, v, velocity=None):
        """The problem's operator at one time level, its friction law guarded by the
        reference state."""
        return self.problem.operator(u, v, velocity, self.reference)

    def hybrid_operator(self, u_old, u_new, v, velocity=None):
        """The problem's hybrid operator, its friction law guarded by the reference
        state."""
        return self.problem.hybrid_operator(u_old, u_new, v, velocity, self.reference)


#: Friction quantities of :func:`friction_terms`.
FRICTION_QUANTITIES = {
    # the friction term of the equation: tested with the step's increment, its work (a
    # pair's: on the increment of both bodies, docs/method.md section 11)
    "work": lambda c, u, velocity, force, v: c.friction_work(u, velocity, force, v),
    # int lambda_t . v and int u'_t . v, for output on Gamma_C
    "traction": lambda c, u, velocity, force, v: (
        ufl.inner(c.friction_traction(u, velocity, force), v) * c.ds
    ),
    "slip_velocity": lambda c, u, velocity, force, v: (
        ufl.inner(c.slip_velocity(velocity), v) * c.ds
    ),
}


def friction_terms(problem, quantity: str = "work") -> ContactTerms:
    """A friction quantity of the frictional contacts of ``problem``, as a model with the
    interface of the time schemes, so that the scheme supplies its slip velocity and
    threshold:

    - ``"work"``: the friction term of the equation; with a Function ``du`` as the
      test, ``scheme.residual(friction_terms(problem), w, u, v, a, dt, du)`` is the
      work of the step's friction force on the increment ``du``;
    - ``"traction"``: ``int lambda_t . mu`` (lambda_t the friction traction);
    - ``"slip_velocity"``: ``int u'_t . mu``.
    """
    if quantity not in FRICTION_QUANTITIES:
        raise ValueError(
            f"unknown friction quantity {quantity!r}; "
            f"choose one of {', '.join(FRICTION_QUANTITIES)}"
        )
    return ContactTerms(problem.frictional_contacts, FRICTION_QUANTITIES[quantity])


def contact_activity(problem) -> ContactTerms:
    """The normal force tested by a cell-wise function, ``int_Gamma_C force q``, as a
    model with the interface of the time schemes (the scheme supplies its force:
    [P_gamma(u^{n+1})]_+ or Phi). It is zero on the cells where every contact term of
    ``problem`` is inactive: there the terms are affine and their Jacobian does not
    change."""
    return ContactTerms(problem.contacts, lambda c, u, velocity, force, q: force * q * c.ds)


def contact_parts(problem, reference=None) -> tuple[ContactTerms, ContactTerms]:
    """The contact terms of ``problem``'s operator as two models with the interface of the
    time schemes: the terms affine in u whatever the contact, and those of the normal
    force, which vanish with their derivatives wherever the force does (``reference``:
    the guarded friction law of :class:`GuardedFriction`)."""

    def affine(contact, u, velocity, force, v):
        return contact.affine_terms(u, v)

    def forces(contact, u, velocity, force, v):
        return contact.force_terms(u, velocity, force, v, reference)

    return ContactTerms(problem.contacts, affine), ContactTerms(problem.contacts, forces)
