"""A small wrapper around PETSc SNES for F(u) = 0 given as UFL forms.

The pattern is the one of dolfinx's own ``test_newton.py``: SNES calls back
into Python to assemble the residual and the Jacobian with ``apply_lifting``
and ``set_bc``, so that Dirichlet conditions hold on every Newton iterate.
The contact terms are only semismooth (the derivative of ``[x]_+`` is the
Heaviside function H(x)): SNES's Newton method is then a semismooth Newton.
"""

from __future__ import annotations

import itertools
from typing import Any

import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from petsc4py import PETSc

from . import compat

__all__ = ["SNESSolver", "SolverError", "DEFAULT_PETSC_OPTIONS", "split_cell_integrals"]

#: Newton with a full step and a direct solve: the semismooth Newton of the talk.
DEFAULT_PETSC_OPTIONS: dict[str, Any] = {
    "snes_type": "newtonls",
    "snes_linesearch_type": "basic",
    "snes_rtol": 1.0e-10,
    "snes_atol": 1.0e-12,
    "snes_stol": 0.0,
    "snes_max_it": 50,
    "ksp_type": "preonly",
    "pc_type": "lu",
}

_REASONS = {
    value: name
    for name, value in vars(PETSc.SNES.ConvergedReason).items()
    if not name.startswith("_") and isinstance(value, int)
}
_prefix_counter = itertools.count()


class SolverError(RuntimeError):
    """SNES did not converge.

    Attributes:
        reason: SNES's converged reason (a negative integer).
        reason_name: Its name, e.g. ``"DIVERGED_MAX_IT"``.
        iterations: Newton iterations done.
        residual_norm: The last residual norm.
        step: The time step that failed, when raised by a simulation (else None).
        t: The time that step was heading for (else None).
    """

    def __init__(self, reason: int, iterations: int, residual_norm: float):
        self.reason = reason
        self.reason_name = _REASONS.get(reason, "UNKNOWN")
        self.iterations = iterations
        self.residual_norm = residual_norm
        self.step = None
        self.t = None
        super().__init__(self._message())

    def _message(self) -> str:
        where = "" if self.step is None else f"at step {self.step} (t = {self.t:.6g}): "
        return (
            f"{where}SNES did not converge: {self.reason_name} (reason {self.reason}) after "
            f"{self.iterations} Newton iterations, last residual norm {self.residual_norm:.6e}"
        )

    def add_context(self, step: int, t: float) -> None:
        """Record the time step and time at which the solve failed (they join the message)."""
        self.step, self.t = step, t
        self.args = (self._message(),)


def split_cell_integrals(form: ufl.Form) -> tuple[ufl.Form, ufl.Form | None]:
    """Split a form into its cell integrals and the rest (facet integrals), or None."""
    cell = [i for i in form.integrals() if i.integral_type() == "cell"]
    rest = [i for i in form.integrals() if i.integral_type() != "cell"]
    return ufl.Form(cell), (ufl.Form(rest) if rest else None)


class SNESSolver:
    """Solve the nonlinear problem F(u; v) = 0 for all v with PETSc SNES.

    Args:
        F: The residual, a UFL form linear in the test function.
        u: The unknown Function; it holds the initial guess and receives the solution.
        bcs: Dirichlet conditions on ``u``.
        J: The Jacobian form; ``ufl.derivative(F, u)`` when omitted.
        constant_jacobian: The integrals of J that do not depend on ``u`` (for example the
            bulk terms of a problem whose only nonlinearity lives on a boundary; see
            :func:`split_cell_integrals`). It is
            assembled once; each Jacobian evaluation then assembles only J minus this
            part, and when that has not changed since the last evaluation the matrix
            is left untouched, so that PETSc reuses its factorisation.
        petsc_options: PETSc options that override :data:`DEFAULT_PETSC_OPTIONS`.
            Options set in the PETSc options database under ``options_prefix``
            (for example ``-nitsche_snes_monitor`` on the command line) win over both.
        options_prefix: PETSc options prefix of this solver; a unique one when omitted.

    Example:
        >>> solver = SNESSolver(F, u, bcs, petsc_options={"snes_monitor": None})
        >>> iterations = solver.solve()
    """

    def __init__(
        self,
        F: ufl.Form,
        u: fem.Function,
        bcs=(),
        J: ufl.Form | None = None,
        petsc_options: dict[str, Any] | None = None,
        options_prefix: str | None = None,
        constant_jacobian: ufl.Form | None = None,
    ):
        self.u = u
        self.bcs = list(bcs)
        self.F_form = fem.form(F)
        if J is None:
            J = ufl.derivative(F, u, ufl.TrialFunction(u.function_space))
        self.J_form = fem.form(J)
        V = u.function_space
        self._b = compat.create_vector(V)
        self._x = compat.create_vector(V)
        self._A = compat.create_matrix(self.J_form)
        self.jacobian_evaluations = 0
        self.jacobian_updates = 0
        self._split = None
        if constant_jacobian is not None:
            self._setup_split(J, constant_jacobian)

        comm = V.mesh.comm
        self.snes = PETSc.SNES().create(comm)
        self.options_prefix = options_prefix or f"nitsche_{next(_prefix_counter)}_"
        self.snes.setOptionsPrefix(self.options_prefix)
        self.snes.setFunction(self._assemble_residual, self._b)
        self.snes.setJacobian(self._assemble_jacobian, self._A)
        compat.set_divergence_tolerance(self.snes, 1.0e300)  # contact residuals may jump
        inserted = self._insert_options({**DEFAULT_PETSC_OPTIONS, **(petsc_options or {})})
        try:
            self.snes.setFromOptions()
            self.snes.getKSP().setFromOptions()
        finally:
            # the database is global and bounded: take our entries out again
            for name in inserted:
                PETSc.Options().delValue(name)

    def _insert_options(self, options: dict[str, Any]) -> list[str]:
        """Put ``options`` in the database under our prefix, except those the user set there."""
        database = PETSc.Options()
        inserted = []
        for key, value in options.items():
            name = f"{self.options_prefix}{key}"
            if database.hasName(name):
                continue
            database[name] = "" if value is None else value
            inserted.append(name)
        return inserted

    def _assemble_residual(self, snes, x: PETSc.Vec, b: PETSc.Vec) -> None:
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        x.copy(compat.petsc_vector(self.u))
        self.u.x.scatter_forward()
        with b.localForm() as b_local:
            b_local.set(0.0)
        fem_petsc.assemble_vector(b, self.F_form)
        compat.apply_lifting(b, self.J_form, self.bcs, x, -1.0)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        compat.set_bc(b, self.bcs, x, -1.0)

    def _setup_split(self, J: ufl.Form, constant: ufl.Form) -> None:
        """Assemble the constant integrals once; keep a matrix for the others and its last value."""
        constant_integrals = constant.integrals()
        varying_integrals = [i for i in J.integrals() if i not in constant_integrals]
        A_constant = compat.create_matrix(self.J_form)
        fem_petsc.assemble_matrix(A_constant, fem.form(constant), self.bcs, 1.0)
        A_constant.assemble()
        if not varying_integrals:
            self._split = (A_constant, None, None, None)
            return
        varying_form = fem.form(ufl.Form(varying_integrals))
        self._split = (A_constant, varying_form, compat.create_matrix(self.J_form), None)

    def _assemble_jacobian(self, snes, x: PETSc.Vec, A: PETSc.Mat, P: PETSc.Mat) -> None:
        self.jacobian_evaluations += 1
        if self._split is None or self.jacobian_updates == 0:
            # the whole Jacobian: always without a split, and once with one (it gives A
            # its full sparsity, which the cheaper updates below then keep)
            A.zeroEntries()
            fem_petsc.assemble_matrix(A, self.J_form, self.bcs)
            A.assemble()
            self.jacobian_updates += 1
            if self._split is None or self._split[1] is None:
                return
        A_constant, varying_form, B, B_last = self._split
        if varying_form is None:
            return  # the Jacobian is constant
        B.zeroEntries()
        fem_petsc.assemble_matrix(B, varying_form, self.bcs, 0.0)
        B.assemble()
        if B_last is not None and B.equal(B_last):
            return  # A unchanged: its PETSc state stays, so the factorisation is reused
        if B_last is not None:
            subset = PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN
            A.zeroEntries()
            A.axpy(1.0, A_constant, subset)
            A.axpy(1.0, B, subset)
            B_last.destroy()
            self.jacobian_updates += 1
        self._split = (A_constant, varying_form, B, B.copy())

    def solve(self) -> int:
        """Run SNES from the current value of ``u``.

        Returns:
            The number of Newton iterations.

        Raises:
            SolverError: SNES diverged; the message names the reason and the last
                residual norm. ``u`` then holds the last Newton iterate.
        """
        u_vec = compat.petsc_vector(self.u)
        u_vec.copy(self._x)
        self.snes.solve(None, self._x)
        reason = self.snes.getConvergedReason()
        iterations = self.snes.getIterationNumber()
        self._x.copy(u_vec)
        self.u.x.scatter_forward()
        if reason <= 0:
            raise SolverError(reason, iterations, self.snes.getFunctionNorm())
        return iterations

    def destroy(self) -> None:
        """Free the PETSc objects (collective)."""
        matrices = [m for m in (self._split or ()) if isinstance(m, PETSc.Mat)]
        for obj in (self.snes, self._A, self._b, self._x, *matrices):
            obj.destroy()
