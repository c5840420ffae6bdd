"""A small wrapper around PETSc SNES for F(u) = 0 given as UFL forms.

The pattern is the one of dolfinx's own ``test_newton.py``: SNES calls back
into Python to assemble the residual and the Jacobian with ``apply_lifting``
and ``set_bc``, so that Dirichlet conditions hold on every Newton iterate.
The contact terms are only semismooth (the derivative of ``[x]_+`` is the
Heaviside function H(x)): SNES's Newton method is then a semismooth Newton.
"""

from __future__ import annotations

import contextlib
import itertools
from typing import Any

import numpy as np
import ufl
from dolfinx import fem
from petsc4py import PETSc

from . import compat
from .assembly import (
    AffineCellSplit,
    CouplingEntries,
    Forms,
    add_diagonal_product,
    pattern_matrix,
)
from .linear_solvers import InexactSolves, rigid_body_modes

__all__ = [
    "DEFAULT_PETSC_OPTIONS",
    "SNESSolver",
    "SolverError",
    "rigid_body_modes",
]

#: Newton with a full step and a direct solve: the semismooth Newton of the talk. The LU
#: factorisation is MUMPS's where PETSc has it (it is parallel, and uses the BLAS).
#: ``snes_rtol`` is relative to the scale of the step's equation, not to the first
#: residual alone (see :meth:`SNESSolver.solve`); ``snes_atol`` is not set: an absolute
#: tolerance has units, and one that suits a problem in scaled units is below the
#: round-off of the same problem in SI units (a user's ``snes_atol`` is still obeyed).
DEFAULT_PETSC_OPTIONS: dict[str, Any] = {
    "snes_type": "newtonls",
    "snes_linesearch_type": "basic",
    "snes_rtol": 1.0e-10,
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
_SMALLEST = float(np.finfo(float).tiny)  # an absolute tolerance that 0 passes and no norm


class SolverError(RuntimeError):
    """SNES did not converge.

    Attributes:
        reason: SNES's converged reason (a negative integer).
        reason_name: Its name, e.g. ``"DIVERGED_MAX_IT"``.
        iterations: Newton iterations done.
        residual_norm: The last residual norm.
        step: The time step that failed, when raised by a simulation (else None).
        t: The time that step was heading for (else None).
        cut_may_help: Whether smaller steps may succeed where this one failed.
    """

    cut_may_help = True

    def __init__(self, reason: int, iterations: int, residual_norm: float):
        self.reason = reason
        self.reason_name = _REASONS.get(reason, "UNKNOWN")
        self.iterations = iterations
        self.residual_norm = residual_norm
        self.step = None
        self.t = None
        self.hint = None
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

    def add_hint(self, hint: str) -> None:
        """Add what may help (e.g. a smaller gamma0) to the message."""
        self.hint = hint
        self.args = (f"{self._message()}; {hint}",)


_MUMPS: dict = {}


def _solver_options(comm, user_options: dict, lag: int, symmetric: bool) -> dict[str, Any]:
    """The PETSc options of a solver: the defaults, MUMPS where PETSc has it, GMRES with a
    lagged preconditioner, LDL^T for a symmetric Jacobian (serially), then the user's."""
    options = {**DEFAULT_PETSC_OPTIONS}
    if _mumps_available(comm):
        options["pc_factor_mat_solver_type"] = "mumps"
    if lag > 0:
        options.update(ksp_type="gmres", ksp_pc_side="right", ksp_max_it=200)
        options.update(ksp_rtol=1e-12, ksp_atol=1e-14)
    options.update(user_options)
    if symmetric and comm.size == 1 and "pc_type" not in user_options:
        if options.get("pc_factor_mat_solver_type") == "mumps":
            options["pc_type"] = "cholesky"  # LDL^T with pivoting
    return options


def _read_at_each_solve(name: str) -> bool:
    """Whether PETSc reads the option ``name`` again at each solve (viewers, monitors)."""
    return any(word in name for word in ("view", "converged_reason", "monitor"))


def _mumps_available(comm) -> bool:
    """compat.has_mumps, asked once per process."""
    if "found" not in _MUMPS:
        _MUMPS["found"] = compat.has_mumps(comm)
    return _MUMPS["found"]


class SNESSolver:
    """Solve the nonlinear problem F(u; v) = 0 for all v with PETSc SNES.

    Args:
        F: The residual, a UFL form linear in the test function.
        u: The unknown Function; it holds the initial guess and receives the solution.
        bcs: Dirichlet conditions on ``u``.
        J: The Jacobian form; ``ufl.derivative(F, u)`` when omitted.
        petsc_options: PETSc options that override :data:`DEFAULT_PETSC_OPTIONS`.
            Options set in the PETSc options database under ``options_prefix``
            (for example ``-nitsche_snes_monitor`` on the command line) win over both.
        options_prefix: PETSc options prefix of this solver; a unique one when omitted.
        affine_cell_terms: The cell integrals of F are affine in ``u``: all the
            nonlinearity lives on facets, as in linear elastodynamics with contact.
            Their Jacobian is then assembled once, their residual is a matrix-vector
            product, and each Newton iteration assembles only the facet terms. When
            those have not changed since the last iteration the Jacobian is left
            untouched, so that PETSc reuses its factorisation.
        mass_diagonal: A diagonal matrix D (as a vector) added to the problem:
            F(u) + D u and J + D. A lumped mass is given this way: FFCx 0.5 cannot
            compile vertex quadrature.
        preconditioner_lag: With ``affine_cell_terms``: keep factorising the Jacobian
            only when the last linear solve needed more than this many Krylov
            iterations, and solve with GMRES preconditioned by the last factorised
            Jacobian in between (0: factorise every changed Jacobian, solve directly).
        facet_activity: With ``affine_cell_terms``: a linear form with one non-negative
            value per cell (a DG0 test function), zero on the cells where the facet
            terms are inactive: affine in ``u``, with a Jacobian that does not change.
            For contact, the normal force ``int [P_gamma(u)]_+ q``. While it is zero
            on every cell, the facet Jacobian is not re-assembled.
        coupling: With ``affine_cell_terms``: terms of F and J beyond the UFL forms, for
            contact between two bodies (:class:`~nitsche_dolfinx.pair_coupling.PairCoupling`):
            ``update(x)`` before each residual, ``add_residual(b)``, and
            ``jacobian_changed()`` / ``add_jacobian(A)``, and ``growth``: the entries
            the sparsity of the Jacobian lacks (the pairs in contact for the first time).
        cell_state: With ``affine_cell_terms``: the Functions other than ``u`` in which the
            cell terms are affine and which change between solves (the state of the time
            level); their constant part of the residual is then a matrix-vector product
            per Function instead of a cell assembly per solve.
        facet_parts: With ``affine_cell_terms`` and ``facet_activity``: the facet terms
            of F as (affine part, force part), whose sum they are: the force part
            vanishes, with its Jacobian, wherever ``facet_activity`` is zero (the contact
            force). The affine part's constant Jacobian is then assembled once with the
            cell terms, and the force part's only near the contact.
        symmetric: The Jacobian is symmetric (for contact: Theta = 1 and no friction).
            Serially with MUMPS, the default direct solver is then its symmetric LDL^T
            factorisation (``pc_type cholesky``, pivoting: the matrix need not be
            positive definite), about a third cheaper than LU. Under MPI it stays LU:
            MUMPS's parallel LDL^T failed on the ball with PETSc 3.22.

    The PETSc option ``mat_type`` (under the prefix) sets the type of the Jacobian and of
    the constant matrices (``baij``: 3 x 3 blocks for 3D elasticity, about three times
    faster products than AIJ); AIJ by default. With a ``coupling``, the Jacobian's
    sparsity is widened by its ``growth`` (whole blocks for ``baij``).

    With a Krylov method and no ``ksp_rtol``/``ksp_atol`` of the user's, the linear
    solves are as inexact as Newton allows: :attr:`linear_tolerances`
    (:class:`~nitsche_dolfinx.linear_solvers.InexactSolves`).

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
        affine_cell_terms: bool = False,
        preconditioner_lag: int = 0,
        mass_diagonal: PETSc.Vec | None = None,
        facet_activity: ufl.Form | None = None,
        symmetric: bool = False,
        coupling=None,
        cell_state=(),
        facet_parts=None,
    ):
        self.u = u
        self.bcs = list(bcs)
        if J is None:
            J = ufl.derivative(F, u, ufl.TrialFunction(u.function_space))
        self.F_forms = Forms(F)
        self.J_forms = Forms(J)
        self._D, self._D_bc = None, None
        if mass_diagonal is not None:
            self._D = mass_diagonal
            self._D_bc = mass_diagonal.copy()  # zero on Dirichlet rows: they stay identity
            compat.set_bc(self._D_bc, self.bcs, None, 0.0)
        V = u.function_space
        self._b = compat.create_vector(V)
        self._x = compat.create_vector(V)
        self._zero = compat.create_vector(V)
        # the state of the convergence test of the current solve (see solve())
        self._atol, self._roundoff_bound, self._full_steps = 0.0, 0.0, True
        self._first_norm, self._best = 0.0, (0.0, 0)
        self._zero_norm, self._given_atol = 0.0, None
        self._refresh_preconditioner = True  # factorise P at the next Jacobian (lagged)
        self._jacobian_changes: list[bool] = []
        if coupling is not None and not affine_cell_terms:
            raise ValueError("contact between bodies needs affine_cell_terms=True")
        self.preconditioner_lag = int(preconditioner_lag) if affine_cell_terms else 0
        user_options = dict(petsc_options or {})
        comm = V.mesh.comm
        options = _solver_options(comm, user_options, self.preconditioner_lag, symmetric)
        self._options = options  # (set again on a renewed preconditioner)
        self.options_prefix = options_prefix or f"nitsche_{next(_prefix_counter)}_"
        matrix_type = self._matrix_type(options)
        terms = (F, J, self.J_forms, self.bcs, self._D, self._D_bc, facet_activity)
        self._split = (
            AffineCellSplit(
                *terms,
                unknown=u,
                state=cell_state,
                matrix_type=matrix_type,
                facet_parts=facet_parts,
            )
            if affine_cell_terms
            else None
        )
        self._coupling = coupling
        self._symmetric, self._near_nullspace = symmetric, None
        self._A = self._new_matrix(symmetric, matrix_type)
        if mass_diagonal is not None:  # J may have no diagonal of its own (initial acceleration)
            self._A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
        self._P = None
        #: Jacobian evaluations asked by SNES, actual changes of the Jacobian, and
        #: changes of the matrix PETSc factorises (the Jacobian itself, or a lagged copy)
        self.jacobian_evaluations = 0
        self.jacobian_updates = 0
        self.preconditioner_updates = 0
        #: How many times a failed Krylov solve made the solver factorise from then on.
        self.direct_fallbacks = 0
        #: Skip the facet (contact) Jacobian while ``facet_activity`` is zero everywhere;
        #: False assembles it at every evaluation (the reference the skip is checked by).
        self.skip_inactive_facets = True
        #: How far above round-off an exact iterate's residual may be, relative to the
        #: scale of the equation (see :meth:`solve`).
        self.roundoff_bound = 1.0e-6
        #: Full Newton steps stop after this many iterations without a new smallest
        #: residual (semismooth Newton cycling between contact states; the line search
        #: of :meth:`solve_with_line_search` takes over).
        self.stall_limit = 12
        self._create_snes(comm, options, user_options, symmetric, matrix_type)

    def _matrix_type(self, options: dict[str, Any]) -> str | None:
        """The PETSc option ``mat_type``: the database's under our prefix, else ``options``'."""
        name = f"{self.options_prefix}mat_type"
        database = PETSc.Options()
        return database.getString(name) if database.hasName(name) else options.get("mat_type")

    def _create_snes(self, comm, options, user_options, symmetric, matrix_type) -> None:
        """The SNES with its residual and Jacobian callbacks and ``options``."""
        self.snes = PETSc.SNES().create(comm)
        self.snes.setOptionsPrefix(self.options_prefix)
        self.snes.setFunction(self._assemble_residual, self._b)
        if self.preconditioner_lag > 0:
            self._P = self._new_matrix(symmetric, matrix_type)
            self.snes.setJacobian(self._assemble_jacobian, self._A, self._P)
        else:
            self.snes.setJacobian(self._assemble_jacobian, self._A)
        divergence = compat.set_divergence_tolerance(self.snes, 1.0e300)  # residuals may jump
        inserted = self._insert_options(options) + ([divergence] if divergence else [])
        # The database is global and bounded (512 entries in PETSc 3.18): take the
        # options out once read, except the user's viewers and monitors, which PETSc
        # reads again at every solve (they stay until destroy()).
        self._user_option_names = [
            name
            for name in inserted
            if name[len(self.options_prefix) :] in user_options and _read_at_each_solve(name)
        ]
        #: An absolute tolerance the user set (``snes_atol``), obeyed as given; None: the
        #: tolerance follows the scale of each solve's equation (see :meth:`solve`).
        self.user_atol = None
        if PETSc.Options().hasName(f"{self.options_prefix}snes_atol"):
            self.user_atol = PETSc.Options().getReal(f"{self.options_prefix}snes_atol")
        name = f"{self.options_prefix}snes_linesearch_type"
        self._line_search_type = PETSc.Options().getString(name, "basic")
        database = PETSc.Options()
        tolerances = [f"{self.options_prefix}ksp_{name}" for name in ("rtol", "atol")]
        defaults = {f"{self.options_prefix}{key}" for key in options if key not in user_options}
        given = any(database.hasName(n) and n not in defaults for n in tolerances)
        given = given or self.preconditioner_lag > 0  # lagged GMRES: its own tolerances
        try:
            self.snes.setFromOptions()
            self.snes.getKSP().setFromOptions()
        finally:
            for name in inserted:
                if name not in self._user_option_names:
                    PETSc.Options().delValue(name)
        #: When the linear solves stop: Krylov solves whose tolerances follow Newton's.
        krylov = self.snes.getKSP().getType() != "preonly"
        self.linear_tolerances = InexactSolves(krylov and not given)
        self.snes.setConvergenceTest(self._converged)

    def _new_matrix(self, symmetric: bool, matrix_type: str | None) -> PETSc.Mat:
        """A matrix with the sparsity of J: with the split, a copy of the structure of
        its K_bc (already assembled on that sparsity), else dolfinx's for the form."""
        if self._split is not None:
            matrix = self._split.K_bc.duplicate()  # zero values
        else:
            matrix = self.J_forms.create_matrix(matrix_type)
        if symmetric:
            matrix.setOption(PETSc.Mat.Option.SYMMETRIC, True)
        return matrix

    def set_near_nullspace(self, vectors: list[PETSc.Vec]) -> None:
        """Give algebraic multigrid (``pc_type gamg``) the near-nullspace of the Jacobian,
        e.g. :func:`~nitsche_dolfinx.linear_solvers.rigid_body_modes`."""
        nullspace = PETSc.NullSpace().create(vectors=vectors, comm=self.u.function_space.mesh.comm)
        self._near_nullspace = nullspace
        self._A.setNearNullSpace(nullspace)
        if self._P is not None:
            self._P.setNearNullSpace(nullspace)

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

    def _assemble_residual(self, snes, x: PETSc.Vec, b: PETSc.Vec, zero: bool = False) -> None:
        """b = F(x) (``zero``: x is the zero vector, whose product with K is skipped)."""
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        if self._coupling is not None:
            self._coupling.update(x)
        x.copy(compat.petsc_vector(self.u))
        self.u.x.scatter_forward()
        with b.localForm() as b_local:
            b_local.set(0.0)
        if self._split is None:
            self.F_forms.assemble_vector(b)
        elif self._split.F_facet is not None:
            self._split.F_facet.assemble_vector(b)
        if self.bcs:  # (without conditions, lifting would still pack J's coefficients)
            self.J_forms.apply_lifting(b, self.bcs, x, -1.0)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        if self._split is not None:
            self._split.add_cell_residual(None if zero else x, b)
        elif self._D is not None:
            add_diagonal_product(b, self._D, x)
        if self._coupling is not None:
            self._coupling.add_residual(b)
        compat.set_bc(b, self.bcs, x, -1.0)

    def _converged(self, snes, iteration: int, norms) -> int:
        """SNES's convergence test: ||F|| <= the solve's absolute tolerance, or ``snes_rtol``
        times the first residual, or an iterate exact up to round-off (see :meth:`solve`)."""
        fnorm = norms[2]
        reasons = PETSc.SNES.ConvergedReason
        if not np.isfinite(fnorm):
            return reasons.DIVERGED_FNORM_NAN
        if iteration == 0:  # one Newton step at least: the guess is not the solution
            self._first_norm, self._best = fnorm, (fnorm, 0)
            self._set_tolerances(max(fnorm, self._zero_norm), snes.getTolerances()[0])
            return reasons.CONVERGED_FNORM_ABS if fnorm == 0.0 else reasons.ITERATING
        if fnorm < self._best[0]:
            self._best = (fnorm, iteration)
        if fnorm <= self._atol:
            return reasons.CONVERGED_FNORM_ABS
        if fnorm <= snes.getTolerances()[0] * self._first_norm:
            return reasons.CONVERGED_FNORM_RELATIVE
        if iteration >= 2 and self._exact_before(iteration) and fnorm <= self._roundoff_bound:
            return reasons.CONVERGED_SNORM_RELATIVE
        if iteration >= snes.getTolerances()[3]:
            return reasons.DIVERGED_MAX_IT
        if self._full_steps and iteration - self._best[1] >= self.stall_limit:
            return reasons.DIVERGED_MAX_IT  # cycling between contact states: no progress
        return reasons.ITERATING

    def _jacobian_terms_changed(self) -> bool:
        """Assemble the Jacobian's non-constant terms (facets, coupling between bodies);
        True if any differs from the last assembly."""
        changed = self._split.facet_jacobian_changed(self.skip_inactive_facets)
        if self._coupling is not None:  # zero where the facet terms are inactive
            inactive = self.skip_inactive_facets and self._split.inactive
            active_cells = self._split.active_cells()
            changed = self._coupling.jacobian_changed(inactive, active_cells) or changed
            if self._coupling.growth is not None:  # pairs in contact for the first time
                self._widen(self._coupling.growth)
        return changed

    def _widen(self, entries: CouplingEntries) -> None:
        """Add ``entries`` to the sparsity of the Jacobian matrices (PETSc rebuilds them,
        keeping their values: what was set on them is set again) and factorise anew."""
        self._split.widen()
        pattern = pattern_matrix(entries, self._A)
        for matrix in (self._A, self._P):
            if matrix is not None:
                matrix.axpy(1.0, pattern, PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
                if self._symmetric:
                    matrix.setOption(PETSc.Mat.Option.SYMMETRIC, True)
                if self._near_nullspace is not None:
                    matrix.setNearNullSpace(self._near_nullspace)
        pattern.destroy()
        self._renew_preconditioner()

    def _renew_preconditioner(self) -> None:
        """Set the preconditioner up from nothing at the next solve (the Jacobian's
        sparsity grew). Algebraic multigrid is made anew, with its options: reset, GAMG
        keeps level solvers sized for the former hierarchy, and PETSc then fails with
        'Cannot change local size of Amat after use'."""
        pc = self.snes.getKSP().getPC()
        kind = pc.getType()
        pc.reset()
        if kind != "gamg":
            return
        pc.setType("none")  # destroys GAMG's levels
        inserted = self._insert_options(self._options)
        try:
            pc.setType(kind)
            pc.setFromOptions()
        finally:
            for name in inserted:
                if name not in self._user_option_names:
                    PETSc.Options().delValue(name)

    def _exact_before(self, iteration: int) -> bool:
        """Whether iterate ``iteration - 1`` solved the step's equation exactly (up to
        round-off): it came from a full Newton step with the Jacobian that it has itself.
        The bulk is affine and the contact terms piecewise affine, so with the same
        Jacobian (the same contact status at every quadrature point) at both ends of a
        full step, that step landed on the solution, if its linear solve was exact: a
        direct one, or a full Krylov solve (see
        :class:`~nitsche_dolfinx.linear_solvers.InexactSolves`)."""
        changes, k = self._jacobian_changes, iteration - 1
        full = self.linear_tolerances.full(k - 1)
        return k < len(changes) and not changes[k] and self._full_steps and full

    def _set_tolerances(self, scale: float, rtol: float) -> None:
        """The absolute tolerance and the round-off bound of the solve under way, from
        the scale of its equation (see :meth:`solve`)."""
        atol = self._given_atol if self._given_atol is not None else rtol * scale
        self._atol = max(atol, _SMALLEST)
        self._roundoff_bound = self.roundoff_bound * scale

    def _assemble_jacobian(self, snes, x: PETSc.Vec, A: PETSc.Mat, P: PETSc.Mat) -> None:
        self.jacobian_evaluations += 1
        self._jacobian_changes.append(True)
        self._update_jacobian(snes, A, P)
        active = self._split is not None and not self._split.inactive
        index, moved = len(self._jacobian_changes) - 1, self._jacobian_changes[-1]
        self.linear_tolerances.set(snes.getKSP(), index, moved, active, self._atol)

    def _update_jacobian(self, snes, A: PETSc.Mat, P: PETSc.Mat) -> None:
        """Assemble the Jacobian into A (and P) where it changed; see :meth:`_assemble_jacobian`."""
        if self._split is None:  # the whole Jacobian
            A.zeroEntries()
            self.J_forms.assemble_matrix(A, self.bcs)
            A.assemble()
            if self._D is not None:
                A.setDiagonal(self._D_bc, addv=PETSc.InsertMode.ADD)
                A.assemble()
        elif self._jacobian_terms_changed():  # always at the first evaluation
            # every Jacobian is K_bc + B, summed in that order: a run restarted from a
            # checkpoint then factorises bit for bit the matrices of the uninterrupted run
            # (the coupling's terms are added afterwards, on rows of their own too)
            if self._coupling is None:
                self._split.sum_into(A)
            else:
                self._split.sum_into(A, reset=self._coupling.entries)
                self._coupling.add_jacobian(A)
        else:
            self._jacobian_changes[-1] = False
            return  # A unchanged: its PETSc state stays, so the factorisation is reused
        self.jacobian_updates += 1
        if self._P is None:
            self.preconditioner_updates += 1
            return
        ksp = snes.getKSP()
        refresh, self._refresh_preconditioner = self._refresh_preconditioner, False
        if refresh or ksp.getIterationNumber() > self.preconditioner_lag:
            A.copy(P, PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
            self.preconditioner_updates += 1
            ksp.setType("preonly")  # P is A: one direct solve
        else:
            ksp.setType("gmres")  # P lags behind A: let GMRES make up the difference

    def solve(self, atol: float | None = None) -> int:
        """Run SNES from the current value of ``u``.

        The solve has converged when ||F|| <= ``atol``. By default ``atol`` is ``snes_rtol``
        times the scale of the step's equation, the larger of ||F(0)|| and ||F(u_0)||
        (u_0 the initial guess; F(0) holds the loads and the forces of the last state):
        both carry the units of F, so the same physical problem in other units takes the
        same iterations. It has also converged when an iterate solved the equation
        exactly up to round-off (see :meth:`_exact_before`) and ||F|| is at most
        :attr:`roundoff_bound` times the scale: at rest, F(0) and F(u_0) are both
        round-off, and no residual tolerance is reachable.

        Args:
            atol: The absolute tolerance of this solve instead (e.g. one shared by
                several solves of a step); a user's ``snes_atol`` wins over both.

        Returns:
            The number of Newton iterations.

        Raises:
            SolverError: SNES diverged; the message names the reason and the last
                residual norm. ``u`` then holds the last Newton iterate.
        """
        u_vec = compat.petsc_vector(self.u)
        self._new_coefficients()
        # ||F(u_0)|| is SNES's first residual: the convergence test takes it from there
        self._zero_norm = self._norm_at_zero()
        self._given_atol = self.user_atol if self.user_atol is not None else atol
        self._full_steps = self._line_search_type == "basic"
        start = self.u.x.array.copy()
        reason, iterations = self._run_snes(u_vec)
        failed = reason == PETSc.SNES.ConvergedReason.DIVERGED_LINEAR_SOLVE
        if failed and (self._P is not None or self.linear_tolerances.enabled):
            # GMRES on a lagged factorisation, or the Krylov method of a preset, gave up:
            # again, factorising the Jacobian
            self.u.x.array[:] = start
            if self._P is not None:
                self._factorise_at_next_jacobian()
            else:
                self._direct_solves_from_now_on()
            reason, more = self._run_snes(u_vec)
            iterations += more
        if reason <= 0:
            raise SolverError(reason, iterations, self.snes.getFunctionNorm())
        return iterations

    def _direct_solves_from_now_on(self) -> None:
        """Factorise the Jacobian (LU, MUMPS's where PETSc has it) instead of the Krylov
        method whose solve failed: with conjugate gradients, a Jacobian that is not
        positive definite (gamma0 beyond the stability limit of the mesh)."""
        ksp = self.snes.getKSP()
        ksp.reset()
        ksp.setType("preonly")
        ksp.getPC().setType("lu")
        if _mumps_available(self.u.function_space.mesh.comm):
            ksp.getPC().setFactorSolverType("mumps")
        self.linear_tolerances.enabled = False
        self.direct_fallbacks += 1
        if self._split is not None:
            self._factorise_at_next_jacobian()

    def _run_snes(self, u_vec) -> tuple[int, int]:
        """SNES from ``u``, whose value becomes the last iterate; its reason and iterations."""
        self._jacobian_changes = []
        self.linear_tolerances.start()
        u_vec.copy(self._x)
        self.snes.solve(None, self._x)
        self.linear_tolerances.finish(self._jacobian_changes)
        self._x.copy(u_vec)
        self.u.x.scatter_forward()
        return self.snes.getConvergedReason(), self.snes.getIterationNumber()

    def solve_with_line_search(self, atol: float | None = None) -> int:
        """:meth:`solve` with full Newton steps and, should they fail (semismooth Newton
        may cycle between contact states), again from the same start with the ``l2``
        line search; returns the Newton iterations of both."""
        start = self.u.x.array.copy()
        try:
            return self.solve(atol)
        except SolverError as error:
            spent = error.iterations
        self.u.x.array[:] = start
        with self.line_search("l2"):
            try:
                return spent + self.solve(atol)
            except SolverError as error:
                error.iterations += spent
                raise

    def update_constant_terms(self) -> None:
        """Assemble again the constant bulk Jacobian after a constant in it changed (the
        time step); the next Jacobian is then factorised anew."""
        if self._split is not None:
            self._split.update_K()
            self._factorise_at_next_jacobian()

    def _factorise_at_next_jacobian(self) -> None:
        """Make the next Jacobian evaluation sum K_bc + B and factorise it (also when
        lagging), whether or not the contact part changed."""
        self._split.forget_facet_jacobian()
        self._refresh_preconditioner = True

    @contextlib.contextmanager
    def line_search(self, kind: str):
        """Solve with the SNES line search ``kind`` (e.g. ``"l2"``) inside the block."""
        database = PETSc.Options()
        name = f"{self.options_prefix}snes_linesearch_type"
        kept = database.hasName(name)  # set in the database by the user
        previous = database.getString(name) if kept else self._line_search_type
        database[name] = kind
        self.snes.setFromOptions()
        before, self._line_search_type = self._line_search_type, kind
        try:
            yield
        finally:
            self._line_search_type = before
            database[name] = previous
            self.snes.setFromOptions()
            if not kept:
                database.delValue(name)

    def equation_scale(self, new_coefficients: bool = True) -> float:
        """The scale of the equation at the current coefficients: the larger of ||F(0)||
        and ||F(u)|| at the current ``u``, which is left as it was (collective)."""
        return max(self.residual_norm(new_coefficients), self._norm_at_zero())

    def _norm_at_zero(self) -> float:
        """||F(0)|| for the current coefficients (collective); ``u`` is left as it was."""
        u_vec = compat.petsc_vector(self.u)
        u_vec.copy(self._x)
        self._zero.set(0.0)
        self._assemble_residual(self.snes, self._zero, self._b, zero=True)
        self._x.copy(u_vec)
        self.u.x.scatter_forward()
        return self._b.norm()

    def _new_coefficients(self) -> None:
        """What depends on the coefficients other than ``u`` (the constant part of the cell
        terms, the partners of the state across contact pairs), for their new values."""
        if self._split is not None:
            if self._split.constants_changed():  # (gamma0, Theta set by the user)
                self.update_constant_terms()
            self._split.update_cell_residual(self.u)
        if self._coupling is not None:
            self._coupling.update()

    def residual_norm(self, new_coefficients: bool = True) -> float:
        """The Euclidean norm of the residual at the current value of ``u`` (collective).

        Args:
            new_coefficients: The coefficients other than ``u`` changed since the last
                solve or evaluation (with ``affine_cell_terms`` the constant part of the
                cell terms is then re-assembled).
        """
        if new_coefficients:
            self._new_coefficients()
        u_vec = compat.petsc_vector(self.u)
        u_vec.copy(self._x)
        self._assemble_residual(self.snes, self._x, self._b)
        return self._b.norm()

    @property
    def facet_jacobian_assemblies(self) -> int:
        """How many times the facet (contact) Jacobian was assembled."""
        return self._split.assemblies if self._split is not None else self.jacobian_evaluations

    def destroy(self) -> None:
        """Free the PETSc objects (collective)."""
        objects = [self.snes, self._A, self._b, self._x, self._zero]
        if self._P is not None:
            objects.append(self._P)
        if self._split is not None:
            objects.extend(self._split.petsc_objects())
        if self._coupling is not None:
            objects.extend(self._coupling.petsc_objects())
        for obj in objects:
            obj.destroy()
        for name in self._user_option_names:
            PETSc.Options().delValue(name)
