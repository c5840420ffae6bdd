"""The terms of the weak form of a :class:`~nitsche_dolfinx.model.problem.ContactProblem`
in UFL, which the time schemes assemble (the
:class:`~nitsche_dolfinx.steppers.schemes.Model` interface): the stress, the bulk
stiffness, the inertia and the diagonal mass, Rayleigh damping, the operators B(u)(v) of a
time level and of the hybrid step with their contact terms, the energies.
"""

from __future__ import annotations

import numpy as np
import ufl

from ..common.parameters import require
from ..physics.damping import RayleighDamping
from ..physics.hyperelastic import (
    averaged_stress,
    cauchy_stress,
    first_piola,
    strain_energy,
    von_mises_of,
)
from ..physics.material import sigma, von_mises

__all__ = ["ProblemTerms"]


class ProblemTerms:
    """The weak form's terms of :class:`~nitsche_dolfinx.model.problem.ContactProblem`
    (one of its parts: it reads the problem's ``law``, ``material_constants``, ``mass``,
    ``mass_matrix``, ``dx``, ``contacts`` and its constants).
    """

    def set_damping(self, alpha: float = 0.0, beta: float = 0.0) -> RayleighDamping:
        """Rayleigh damping C = alpha M + beta K (docs/method.md section 14): M the
        problem's mass (consistent, lumped or redistributed), K the bulk stiffness a(u, v)
        (not the Nitsche terms). alpha >= 0 [1/time], beta >= 0 [time]; the modal damping
        ratio at the circular frequency omega is alpha / (2 omega) + beta omega / 2. The
        coefficients are the ``fem.Constant`` attributes ``damping.alpha`` and
        ``damping.beta`` (runtime values). Set before the simulation is built."""
        require(
            self.method != "mixed", "method", self.method,
            "damping is for Nitsche's and the penalty method (not the mixed one)",
        )  # fmt: skip
        require(
            not self.finite, "law", self.materials[0].law,
            "Rayleigh damping takes a linear stiffness: not with a hyperelastic material",
        )  # fmt: skip
        damping = RayleighDamping(self.mesh, alpha, beta)
        if self.damping is None:
            self.damping = damping
        else:  # the same constants: compiled forms stay valid
            self.damping.alpha.value, self.damping.beta.value = damping.values
        return self.damping

    def damping_force(self, velocity, v):
        """(C velocity, v) in UFL without a diagonal mass's part (which the solver adds), or
        None without damping (the forms then have no damping term at all)."""
        return None if self.damping is None else self.damping.force(self, velocity, v)

    def stress(self, u):
        """sigma(u); at finite strains the first Piola-Kirchhoff stress P(u)."""
        if self.finite:
            return first_piola(self.law, self.material_constants, u)
        return sigma(u, self.material_constants)

    def bulk_stiffness(self, u, v):
        """a(u, v) = int sigma(u) : eps(v); at finite strains int P(u) : grad v."""
        if self.finite:
            return ufl.inner(self.stress(u), ufl.grad(v)) * self.dx
        return ufl.inner(self.stress(u), ufl.sym(ufl.grad(v))) * self.dx

    def stored_energy(self, u):
        """The elastic energy as a form: int W(C(u)) at finite strains, 1/2 a(u, u) else."""
        if self.finite:
            return strain_energy(self.law, self.material_constants, u) * self.dx
        return 0.5 * self.bulk_stiffness(u, u)

    def von_mises(self, u):
        """The von Mises stress (of the Cauchy stress at finite strains), in UFL."""
        if self.finite:
            return von_mises_of(cauchy_stress(self.law, self.material_constants, u))
        return von_mises(u, self.material_constants)

    def inertia(self, acceleration, v):
        """<rho u'', v> with the consistent mass; zero for a diagonal mass
        (:meth:`mass_diagonal`), which the solver adds as a matrix."""
        rho = self.material_constants.rho if self.mass == "consistent" else 0.0
        return rho * ufl.inner(acceleration, v) * self.dx

    def mass_diagonal(self, V=None):
        """The lumped or redistributed mass matrix as a PETSc vector (its diagonal), or None
        for the consistent mass; on ``V`` (another numbering of the displacement space)
        when given (:class:`~nitsche_dolfinx.physics.mass.MassMatrix`)."""
        return self.mass_matrix.diagonal(V)

    def massless_dofs(self, nodes: bool = False) -> np.ndarray:
        """Local indices (with ghosts) of the dofs whose mass is zero (redistributed mass);
        with ``nodes``, of their nodes (the blocks of the dof array)."""
        return self.mass_matrix.massless_dofs(nodes)

    @property
    def symmetric_jacobian(self) -> bool:
        """Whether the Jacobian of every time scheme is symmetric: without friction or a
        moving obstacle whose normal turns, with the symmetric variant Theta = 1 or with
        penalty (whose test term is v_n).
        The stepper reads it once, when it is built."""
        if self.frictional:  # contact pairs keep it: measured symmetric to 5e-17
            return False
        if self.finite:  # the averaged stress's derivative is not symmetric
            return False
        if any(contact.obstacle.turns for contact in self.moving_contacts):
            # the hybrid scheme tests with n_c at t^{n+1/2} what its force takes with n_c
            # at t^{n+1} (docs/method.md section 13): a normal that turns breaks the symmetry
            return False
        return self.method == "penalty" or float(np.asarray(self.nitsche_theta.value)) == 1.0

    def operator(self, u, v, velocity=None, reference=None):
        """B(u)(v) = A_Thgamma(u, v) + the Nitsche contact terms at one time level
        (with friction, ``velocity`` is u' at that level; ``reference``: the guarded
        friction law, see :class:`~nitsche_dolfinx.contact.terms.GuardedFriction`)."""
        form = self.bulk_stiffness(u, v)
        for contact in self.contacts:
            form = form + contact.residual(u, v, velocity, reference)
        return form

    def hybrid_operator(self, u_old, u_new, v, velocity=None, reference=None):
        """The hybrid scheme's operator: A_Thgamma at the midpoint and the switching term
        Phi; with friction, the step's mean velocity ``velocity`` = (u_new - u_old) / tau."""
        if self.finite:  # the energy-consistent stress (docs/method.md section 15)
            stress = averaged_stress(self.law, self.material_constants, u_old, u_new)
            form = ufl.inner(stress, ufl.grad(v)) * self.dx
        else:
            form = self.bulk_stiffness((u_old + u_new) / 2, v)
        for contact in self.contacts:
            form = form + contact.hybrid_residual(u_old, u_new, v, velocity, reference)
        return form
