"""The stable step of the explicit Verlet scheme (docs/method.md section 12): 2 over the
square root of the largest eigenvalue of M^-1 K, K the stiffness with every point of every
Gamma_C in contact (and, for Theta != 1, also with none), estimated by power iterations."""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from petsc4py import PETSc

from ..assembly.pair_coupling import add_partner_terms
from ..common import compat
from ..common.parameters import ParameterError, TimeStepping
from ..contact.coercivity import constant_value
from ..model.problem import ContactProblem
from ..output.mass_moments import assembled_matrix
from ..physics.damping import damped_stable_step

__all__ = [
    "damped_step",
    "largest_eigenvalue",
    "resolve_step",
    "round_down",
    "stable_step",
]


def stable_step(problem: ContactProblem, affine: PETSc.Mat, mass) -> float:
    """The estimated stable step 2 / sqrt(lambda_max(M^-1 K)): K the ``affine`` matrix (the
    bulk and A_Thgamma's boundary part) with all of Gamma_C in contact
    (:func:`largest_eigenvalue`), and for Theta != 1, where the contact term is not a
    nonnegative addition, also with none of it (the larger eigenvalue of the two)."""
    largest = largest_eigenvalue(problem, affine, mass)
    if any(constant_value(c.nitsche_theta) != 1.0 for c in problem.contacts):
        largest = max(largest, largest_eigenvalue(problem, affine, mass, with_contact=False))
    return float(2.0 / np.sqrt(largest))


def damped_step(problem: ContactProblem, affine: PETSc.Mat, mass, stiffness: PETSc.Mat) -> float:
    """The estimated stable step (:func:`stable_step`); with stiffness damping beta > 0,
    shrunk by :func:`~nitsche_dolfinx.physics.damping.damped_stable_step` with the bulk's
    own largest eigenvalue (``stiffness``, docs/method.md section 14)."""
    stable = stable_step(problem, affine, mass)
    beta = 0.0 if problem.damping is None else problem.damping.values[1]
    if beta == 0.0:
        return stable
    bulk = largest_eigenvalue(problem, stiffness, mass, with_contact=False)
    return damped_stable_step(4.0 / stable**2, bulk, beta)


def resolve_step(scheme, stable: float, time_stepping: TimeStepping) -> float:
    """The time step of ``scheme`` (a :class:`~nitsche_dolfinx.steppers.schemes.
    VerletScheme`): ``"auto"`` is its safety share of the ``stable`` step; a given one
    above the stable step is refused unless the scheme allows it."""
    dt = time_stepping.dt
    if time_stepping.automatic:
        return round_down(scheme.safety * stable)
    if dt > stable and not scheme.force_dt:
        raise ParameterError(
            "dt", dt,
            f"above the verlet scheme's stable step {stable:.6g} (estimated for this "
            f"mesh, mass, gamma0 and Theta); take dt='auto' ({scheme.safety:g} of it) or "
            "insist on it (force_dt=True)",
        )  # fmt: skip
    return float(dt)


def round_down(value: float, digits: int = 3) -> float:
    """``value`` rounded down to ``digits`` significant digits: the automatic step is the same
    on every partition (whose estimates differ by round-off) and reads well."""
    exponent = int(np.floor(np.log10(value))) - digits + 1
    return float(f"{int(np.floor(value / 10.0**exponent))}e{exponent}")  # the nearest double


def contact_stiffness_form(problem: ContactProblem):
    """The contact's part of the operator's derivative with every point of every Gamma_C in
    contact: (1/gamma_h) times the linear part of P_gamma(du) times P_Thgamma(v) (None
    without contact). With the affine terms (the bulk and A_Thgamma's boundary part) it
    makes the stiffness of that state. For Theta = 1 this bounds the stiffness of every
    contact state from above (the contact adds a rank-one nonnegative term per quadrature
    point), so its largest eigenvalue bounds the stable step from below."""
    du, v = ufl.TrialFunction(problem.V), ufl.TestFunction(problem.V)
    form = None
    for contact in problem.contacts:
        if contact in problem.pairs:  # their partner: :class:`PairStiffness`
            continue
        term = contact.contact_term(_linear_projection(contact, du), v)
        form = term if form is None else form + term
    return form


def _linear_projection(contact, du):
    """The linear part of P_gamma(du): du_n - gamma_h sigma_n(du)."""
    return contact.normal_displacement(du) - contact.gamma_h * contact.sigma_n(du)


class PairStiffness:
    """The product with the contact pairs' stiffness with every point of every slave
    surface in contact, the pairs' part of :func:`contact_stiffness_form`, by assembly
    (the partner of x is T x, a function: not a trial function)."""

    def __init__(self, problem: ContactProblem):
        V = problem.V
        self.pairs = problem.pairs
        self.x = fem.Function(V)
        problem.track_partners(self.x)
        v = ufl.TestFunction(V)
        slave = sum(pair.contact_term(_linear_projection(pair, self.x), v) for pair in self.pairs)
        self._slave = fem.form(slave)
        self._partner = [fem.form(pair.partner_term(_linear_projection(pair, self.x), v))
                         for pair in self.pairs]  # fmt: skip
        self._vector = compat.create_vector(V)
        self._work = (self._vector.duplicate(), self._vector.duplicate())

    def mult_add(self, x: PETSc.Vec, y: PETSc.Vec) -> None:
        """y += K_pairs x."""
        self.x.x.array[: x.getLocalSize()] = x.array_r
        self.x.x.scatter_forward()
        for pair in self.pairs:
            pair.update([self.x])
        vector = self._vector
        with vector.localForm() as local:
            local.set(0.0)
        fem_petsc.assemble_vector(vector, self._slave)
        vector.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        add_partner_terms(self.pairs, self._partner, vector, self._work, np.zeros(0, np.int32))
        y.axpy(1.0, vector)

    def destroy(self) -> None:
        for obj in (self._vector, *self._work):
            obj.destroy()


def largest_eigenvalue(problem: ContactProblem, affine: PETSc.Mat, mass,
                       with_contact: bool = True, iterations=200, rtol=1e-6) -> float:  # fmt: skip
    """The largest eigenvalue of M^-1 K, K = ``affine`` (the matrix of the affine terms)
    plus, ``with_contact``, :func:`contact_stiffness_form`, M the ``mass`` (an
    :mod:`~nitsche_dolfinx.steppers.explicit_mass` mass: zero rows at the dofs without an
    acceleration of their own, which the estimate leaves out), by power iterations
    x <- M^-1 K x, as the Rayleigh quotient x.K x / x.M x (a lower bound that converges
    from below). With massless nodes it is the largest eigenvalue of the massive dofs' K
    alone, above that of K with the massless nodes in equilibrium: the estimated step is
    then on the safe side."""
    form = contact_stiffness_form(problem) if with_contact else None
    contact = None if form is None else assembled_matrix(form)
    pairs = PairStiffness(problem) if problem.pairs and with_contact else None
    x, y, z = (affine.createVecRight() for _ in range(3))
    n = x.getLocalSize()
    start = fem.Function(problem.V)  # the same start on every partition: a function of x
    gdim = problem.gdim
    start.interpolate(
        lambda p: np.array([1.0 + 0.5 * np.sin(3.0 * k + 7.1 * p[0] + 5.3 * p[1] + 2.9 * p[2])
                            for k in range(gdim)])
    )  # fmt: skip
    x.array[:] = start.x.array[:n] * mass.start_scaling(n)
    estimate = 0.0
    for _ in range(iterations):
        affine.mult(x, y)
        if contact is not None:
            contact.multAdd(x, y, y)
        if pairs is not None:
            pairs.mult_add(x, y)
        mass.mult(x, z)
        previous, estimate = estimate, x.dot(y) / x.dot(z)
        mass.solve(y, x)
        x.scale(1.0 / x.norm())
        if abs(estimate - previous) <= rtol * abs(estimate):
            break
    for obj in (x, y, z, contact, pairs):
        if obj is not None:
            obj.destroy()
    return float(estimate)
