"""The algebraic system F(x) = 0 a Newton solver works on: its residual and its Jacobian,
assembled into PETSc objects (docs/method.md section 8).

- :class:`FormSystem`: any problem given as UFL forms, assembled in full at each call
  (with the coupling of contact pairs, if any: a step at finite strain);
- :class:`~nitsche_dolfinx.assembly.affine_system.AffineSystem`: a step of linear
  elastodynamics with contact, whose cell terms are affine in the unknown, its constant
  Jacobian assembled once.

Both derive from :class:`SystemBase`: they take an iterate ``x`` into the unknown Function
``u`` before assembling, impose the Dirichlet conditions on every iterate (lifting and
``set_bc``), and offer the same methods to :class:`~nitsche_dolfinx.solvers.solver.SNESSolver`.
"""

from __future__ import annotations

import numpy as np
import ufl
from petsc4py import PETSc

from ..common import compat
from ..physics.damping import DiagonalDamping
from .forms import Forms, add_diagonal_product
from .jacobian_sum import widen

__all__ = ["FormSystem", "SystemBase"]


class SystemBase:
    """What both systems share: the unknown, the conditions, the forms and a diagonal."""

    def __init__(self, F: ufl.Form, u, bcs, J: ufl.Form | None, mass_diagonal):
        self.u, self.bcs = u, list(bcs)
        self._bc_values = None  # (owned Dirichlet dofs, the Function of their values)
        self.J = ufl.derivative(F, u, ufl.TrialFunction(u.function_space)) if J is None else J
        self.F_forms, self.J_forms = Forms(F), Forms(self.J)
        self.comm = u.function_space.mesh.comm
        self._D, self._D_bc = None, None
        # with damping, (1 + alpha c) D and the vector alpha D v_0 (docs/method.md section 14)
        self._damped = mass_diagonal if isinstance(mass_diagonal, DiagonalDamping) else None
        if mass_diagonal is not None:  # a diagonal matrix D added: F(u) + D u and J + D
            self._D = mass_diagonal if self._damped is None else self._damped.vector
            self._D_bc = self._D.copy()  # zero on Dirichlet rows: they stay identity
            compat.set_bc(self._D_bc, self.bcs, None, 0.0)
        #: Whether the last Jacobian widened the sparsity of the matrices (a contact pair).
        self.grew = False

    def _refresh_diagonal(self) -> None:
        """A damped diagonal (:class:`~nitsche_dolfinx.physics.damping.DiagonalDamping`) for the
        current alpha and step."""
        if self._damped is None:
            return
        self._damped.refresh()
        self._D.copy(self._D_bc)
        compat.set_bc(self._D_bc, self.bcs, None, 0.0)

    def _take(self, x: PETSc.Vec) -> None:
        """The iterate ``x`` into ``u`` (with its ghosts)."""
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        x.copy(compat.petsc_vector(self.u))
        self.u.x.scatter_forward()

    def prescribe(self, dofs: np.ndarray, values) -> None:
        """Say that the Dirichlet conditions give the (local, unblocked) ``dofs`` the values
        of the Function ``values``: an iterate that has them already needs no lifting."""
        owned = self.u.function_space.dofmap.index_map.size_local
        owned *= self.u.function_space.dofmap.index_map_bs
        dofs = np.asarray(dofs, dtype=np.int64)
        self._bc_values = (dofs[dofs < owned], values)

    def _lift(self, x: PETSc.Vec, b: PETSc.Vec, conditions: bool = True) -> None:
        """The Dirichlet lifting of b, b += J (g - x) near the Dirichlet dofs, then its ghosts
        added to their owners. Without conditions (lifting would still pack the
        coefficients of J), or where x is g already (J (g - x) adds zeros: the iterates
        of Newton but the first), or for F's own rows (``conditions`` False), nothing is
        lifted."""
        if conditions and self.bcs and not self._prescribed(x):
            self.J_forms.apply_lifting(b, self.bcs, x, -1.0)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)

    def _prescribed(self, x: PETSc.Vec) -> bool:
        """Whether the owned entries of ``x`` at the Dirichlet dofs are their values (known
        through :meth:`prescribe`; else False)."""
        if self._bc_values is None:
            return False
        dofs, values = self._bc_values
        return bool(np.array_equal(x.array_r[dofs], values.x.array[dofs]))

    def _matrix_options(self, matrix: PETSc.Mat) -> PETSc.Mat:
        if self._D is not None:  # J may have no diagonal of its own (initial acceleration)
            matrix.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
        return matrix

    @property
    def facet_terms_active(self) -> bool:
        """Whether facet terms of a split Jacobian were active at the last Jacobian."""
        return False

    def constants_changed(self) -> bool:
        """Whether a constant of the constant terms changed since they were assembled."""
        return False

    def new_coefficients(self) -> None:
        """Before a solve: what depends on the coefficients other than ``u``."""

    def update_constant_terms(self) -> None:
        """A constant of the Jacobian changed (the time step)."""

    def forget_jacobian(self) -> None:
        """Make the next Jacobian count as changed."""

    @property
    def facet_jacobian_assemblies(self) -> int | None:
        """How many times the facet Jacobian was assembled (None: at each evaluation)."""
        return None

    def petsc_objects(self) -> list:
        """The PETSc objects the system made, for the solver to destroy (none here)."""
        return []


class FormSystem(SystemBase):
    """F(u) = 0 for the forms F and J (``ufl.derivative(F, u)`` by default), assembled in
    full at every call, with a diagonal matrix D added (a lumped mass: F(u) + D u, J + D).

    With the ``coupling`` of contact pairs, the residual gets their partner-tested terms
    T^T G and the Jacobian their coupling terms (on every facet of the slave surfaces),
    whose growth widens the Jacobian's sparsity: a step at finite strain between bodies
    (docs/method.md section 15).

    Args:
        F: The residual, linear in the test function.
        u: The unknown Function.
        bcs: Dirichlet conditions on ``u``.
        J: The Jacobian form.
        mass_diagonal: D as a PETSc vector (FFCx 0.5 cannot compile vertex quadrature).
        coupling: The :class:`~nitsche_dolfinx.assembly.pair_coupling.PairCoupling` of the contact
            pairs, or None.
    """

    def __init__(self, F: ufl.Form, u, bcs=(), J=None, mass_diagonal=None, coupling=None):
        super().__init__(F, u, bcs, J, mass_diagonal)
        self.coupling = coupling

    def new_coefficients(self) -> None:
        """Before a solve: the partners of the state across contact pairs."""
        if self.coupling is not None:
            self.coupling.update()

    def create_matrix(self, matrix_type: str | None) -> PETSc.Mat:
        """A matrix with the sparsity of J, of PETSc type ``matrix_type``."""
        return self._matrix_options(self.J_forms.create_matrix(matrix_type))

    def assemble_residual(
        self, x: PETSc.Vec, b: PETSc.Vec, zero: bool = False, conditions: bool = True
    ) -> None:
        """b = F(x) (``zero``: x is zero; ``conditions``: the Dirichlet rows replaced by
        x - g, else F's own, where the reactions are)."""
        self._take(x)
        if self.coupling is not None:  # the partner of the iterate
            self.coupling.update(x)
        with b.localForm() as b_local:
            b_local.set(0.0)
        self.F_forms.assemble_vector(b)
        self._lift(x, b, conditions)
        if self._D is not None:
            self._refresh_diagonal()
            add_diagonal_product(b, self._D, x)
        if self._damped is not None:
            self._damped.add_offset(b)
        if self.coupling is not None:
            self.coupling.add_residual(b)
        if conditions:
            compat.set_bc(b, self.bcs, x, -1.0)

    def update_jacobian(self, A: PETSc.Mat, P: PETSc.Mat | None = None) -> bool:
        """A = J at ``u`` (+ the coupling of contact pairs, whose growth widens A and P);
        always a change."""
        self.grew = False
        if self.coupling is not None:
            self.coupling.jacobian_changed()
        A.zeroEntries()
        self.J_forms.assemble_matrix(A, self.bcs)
        A.assemble()
        if self._D_bc is not None:
            A.setDiagonal(self._D_bc, addv=PETSc.InsertMode.ADD)
            A.assemble()
        if self.coupling is None:
            return True
        if self.coupling.growth is not None:  # pairs in contact for the first time
            # (A assembled first: PETSc drops the unused entries of a new matrix)
            widen(self.coupling.growth, [A])
            if P is not None:  # the lagged copy: A's sparsity, A's values
                A.copy(P, PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
            self.grew = True
        self.coupling.add_jacobian(A)
        return True

    def petsc_objects(self) -> list:
        """The PETSc objects the system made, for the solver to destroy: those of the
        coupling, if any."""
        return [] if self.coupling is None else self.coupling.petsc_objects()
