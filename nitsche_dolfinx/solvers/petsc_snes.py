"""The PETSc plumbing of a Newton solver: its options, its SNES, its matrices and the
callbacks into a system of :mod:`nitsche_dolfinx.assembly.systems` (docs/method.md section 8).

The pattern is the one of dolfinx's own ``test_newton.py``: SNES calls back into Python to
assemble the residual and the Jacobian (the system applies ``apply_lifting`` and ``set_bc``
so that Dirichlet conditions hold on every iterate). When a Newton solve has converged, and
what a failed one means, is the policy of :class:`~nitsche_dolfinx.solvers.solver.SNESSolver`.

- :class:`SolverSettings`: a solver's PETSc options under its prefix (Newton's, the linear
  solver's preset with its near-nullspace, the user's), its matrix type and lag;
- :class:`PetscSNES`: the SNES, the Jacobian (and its lagged copy), their near-nullspace,
  the residual and Jacobian callbacks, and the switch to direct solves.
"""

from __future__ import annotations

from typing import Any

from petsc4py import PETSc

from ..common import compat
from .linear_solvers import LAGGED_OPTIONS, LinearSolver, direct_options, has_mumps
from .newton import NEWTON_OPTIONS
from .options import PrefixedOptions, unique_prefix

__all__ = ["PetscSNES", "SolverSettings"]


class SolverSettings:
    """The PETSc options of one solver: Newton's
    (:data:`~nitsche_dolfinx.solvers.newton.NEWTON_OPTIONS`),
    the default direct solve (:func:`~nitsche_dolfinx.solvers.linear_solvers.direct_options`),
    GMRES's
    with a lag, the preset's, then the user's; LDL^T for a symmetric Jacobian (serially,
    with MUMPS, unless a preconditioner was chosen).

    Args:
        comm: The communicator.
        petsc_options: The user's options (they win over the others).
        linear_solver: The preset (:mod:`nitsche_dolfinx.solvers.linear_solvers`), or None: the
            default direct solve.
        lag: The preconditioner lag, for a solver whose Jacobian changes rarely (> 0:
            GMRES preconditioned by the last factorisation).
        symmetric: The Jacobian is symmetric (for contact: Theta = 1 and no friction).
            Serially with MUMPS, the direct solve is then its LDL^T factorisation (pivoting:
            the matrix need not be positive definite), about a third cheaper than LU.
            Under MPI it stays LU: MUMPS's parallel LDL^T failed on the ball (PETSc 3.22).
        options_prefix: The PETSc options prefix (a unique one when None). Options set in
            the options database under it win over all of the above.
    """

    def __init__(
        self, comm, petsc_options: dict[str, Any] | None = None,
        linear_solver: LinearSolver | None = None, lag: int = 0, symmetric: bool = False,
        options_prefix: str | None = None,
    ):  # fmt: skip
        preset = linear_solver or LinearSolver("lu")
        chosen = {**preset.petsc_options, **(petsc_options or {})}
        options = {**NEWTON_OPTIONS, **direct_options(comm)}
        if lag > 0:
            options.update(LAGGED_OPTIONS)
        options.update(chosen)
        if symmetric and comm.size == 1 and "pc_type" not in chosen:
            if options.get("pc_factor_mat_solver_type") == "mumps":
                options["pc_type"] = "cholesky"  # LDL^T with pivoting
        self.linear_solver, self.lag, self.symmetric = preset, int(lag), bool(symmetric)
        self.options = PrefixedOptions(options_prefix or unique_prefix(), options, chosen)

    @property
    def matrix_type(self) -> str | None:
        """The PETSc option ``mat_type``: the type of the Jacobian and of the constant
        matrices (``baij``: 3 x 3 blocks for 3D elasticity, products about three times
        faster than AIJ); None: AIJ."""
        return self.options.string("mat_type")

    def krylov_tolerances_given(self) -> bool:
        """Whether the Krylov tolerances are chosen (by the user or the preset) or are the
        lag's: then Newton does not set them
        (:class:`~nitsche_dolfinx.solvers.newton.InexactSolves`).
        Call while the options are in the database (``options.reading()``)."""
        options = self.options
        chosen = (
            options.given(key) and (key in options.user or key not in options.options)
            for key in ("ksp_rtol", "ksp_atol")
        )
        return any(chosen) or self.lag > 0


class PetscSNES:
    """SNES on ``system`` with ``settings``: the residual and the Jacobian assembled by the
    system into the solver's vector and matrices.

    With a lag (``settings.lag`` > 0), PETSc factorises a copy P of the Jacobian A, taken
    again only when the last linear solve needed more Krylov iterations than the lag (GMRES
    preconditioned by P in between). An unchanged Jacobian is left untouched, so that
    PETSc reuses its factorisation.

    Args:
        system: The system (:class:`~nitsche_dolfinx.assembly.systems.FormSystem` or
            :class:`~nitsche_dolfinx.assembly.affine_system.AffineSystem`).
        settings: The :class:`SolverSettings`.
        after_jacobian: Called as ``after_jacobian(ksp, changed, active)`` after each
            Jacobian evaluation: whether it changed, and whether the system's facet terms
            are active (the Newton policy sets the linear solve's tolerances there).

    After construction, :attr:`user_atol`, :attr:`line_search_type` and
    :attr:`krylov_tolerances_given` say what the options asked for.
    """

    def __init__(self, system, settings: SolverSettings, after_jacobian):
        self.system, self.settings = system, settings
        self.u = system.u
        self._after_jacobian = after_jacobian
        V = system.u.function_space
        self.b, self.x, self._zero = (compat.create_vector(V) for _ in range(3))
        self._nullspace = settings.linear_solver.near_nullspace_of(V)
        self.A = self._new_matrix()
        self.P = self._new_matrix() if settings.lag > 0 else None
        self._refresh = True  # factorise P at the next Jacobian (lagged)
        #: Jacobian evaluations asked by SNES, actual changes of the Jacobian, and
        #: changes of the matrix PETSc factorises (the Jacobian itself, or a lagged copy)
        self.jacobian_evaluations = self.jacobian_updates = self.preconditioner_updates = 0
        #: How many times a failed Krylov solve made the solver factorise from then on.
        self.direct_fallbacks = 0
        self.snes = PETSc.SNES().create(system.comm)
        self.snes.setOptionsPrefix(settings.options.prefix)
        self.snes.setFunction(lambda snes, x, b: system.assemble_residual(x, b), self.b)
        self.snes.setJacobian(self._jacobian, self.A, self.A if self.P is None else self.P)
        options = settings.options
        divergence = compat.divergence_tolerance(self.snes, 1.0e300)  # residuals may jump
        with options.reading({**options.options, **divergence}):
            atol = options.string("snes_atol") if options.given("snes_atol") else None
            #: An absolute tolerance the user set (``snes_atol``), else None.
            self.user_atol = None if atol is None else float(atol)
            self.line_search_type = options.string("snes_linesearch_type")
            self.krylov_tolerances_given = settings.krylov_tolerances_given()
            self.snes.setFromOptions()
            self.snes.getKSP().setFromOptions()

    @property
    def krylov(self) -> bool:
        """Whether the linear solves are Krylov solves (not one direct solve)."""
        return self.snes.getKSP().getType() != "preonly"

    def _new_matrix(self) -> PETSc.Mat:
        matrix = self.system.create_matrix(self.settings.matrix_type)
        self._matrix_options(matrix)
        return matrix

    def _matrix_options(self, matrix: PETSc.Mat) -> None:
        """What PETSc must know of a Jacobian matrix: its symmetry, its near-nullspace."""
        if self.settings.symmetric:
            matrix.setOption(PETSc.Mat.Option.SYMMETRIC, True)
        if self._nullspace is not None:
            matrix.setNearNullSpace(self._nullspace)

    def _jacobian(self, snes, x: PETSc.Vec, A: PETSc.Mat, P: PETSc.Mat) -> None:
        self.jacobian_evaluations += 1
        changed = self._update_jacobian(snes, A)
        self._after_jacobian(snes.getKSP(), changed, self.system.facet_terms_active)

    def _update_jacobian(self, snes, A: PETSc.Mat) -> bool:
        """A = J where it changed (and P, lagged); whether it changed."""
        changed = self.system.update_jacobian(A, self.P)
        if self.system.grew:  # the sparsity grew: PETSc made the matrices anew
            for matrix in (A, self.P):
                if matrix is not None:
                    self._matrix_options(matrix)
            self._renew_preconditioner()
        if not changed:
            return False
        self.jacobian_updates += 1
        if self.P is None:
            self.preconditioner_updates += 1
            return True
        ksp = snes.getKSP()
        refresh, self._refresh = self._refresh, False
        if refresh or ksp.getIterationNumber() > self.settings.lag:
            A.copy(self.P, PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
            self.preconditioner_updates += 1
            ksp.setType("preonly")  # P is A: one direct solve
        else:
            ksp.setType("gmres")  # P lags behind A: let GMRES make up the difference
        return True

    def _renew_preconditioner(self) -> None:
        """Set the preconditioner up from nothing at the next solve (the Jacobian's sparsity
        grew). Algebraic multigrid is made anew, with its options: reset, GAMG keeps level
        solvers sized for the former hierarchy, and PETSc then fails with 'Cannot change
        local size of Amat after use'."""
        pc = self.snes.getKSP().getPC()
        kind = pc.getType()
        pc.reset()
        if kind != "gamg":
            return
        pc.setType("none")  # destroys GAMG's levels
        with self.settings.options.reading():
            pc.setType(kind)
            pc.setFromOptions()

    def factorise_at_next_jacobian(self) -> None:
        """Make the next Jacobian evaluation sum the Jacobian anew and factorise it (also
        when lagging), whether or not the contact part changed."""
        self.system.forget_jacobian()
        self._refresh = True

    def direct_solves_from_now_on(self) -> None:
        """Factorise the Jacobian (:func:`~nitsche_dolfinx.solvers.linear_solvers.direct_options`)
        instead of the Krylov method of the preset."""
        ksp = self.snes.getKSP()
        ksp.reset()
        ksp.setType("preonly")
        ksp.getPC().setType("lu")
        if has_mumps(self.system.comm):
            ksp.getPC().setFactorSolverType("mumps")
        self.direct_fallbacks += 1
        self.factorise_at_next_jacobian()

    def run(self) -> tuple[int, int]:
        """SNES from ``u``, whose value becomes the last iterate; its reason and iterations."""
        u_vec = compat.petsc_vector(self.u)
        u_vec.copy(self.x)
        self.snes.solve(None, self.x)
        self.x.copy(u_vec)
        self.u.x.scatter_forward()
        return self.snes.getConvergedReason(), self.snes.getIterationNumber()

    def residual_norm(self, at_zero: bool = False) -> float:
        """||F|| at the current ``u``, or (``at_zero``) at u = 0, ``u`` being left as it was
        (collective)."""
        u_vec = compat.petsc_vector(self.u)
        u_vec.copy(self.x)
        if at_zero:
            self._zero.set(0.0)
            self.system.assemble_residual(self._zero, self.b, zero=True)
            self.x.copy(u_vec)
            self.u.x.scatter_forward()
        else:
            self.system.assemble_residual(self.x, self.b)
        return self.b.norm()

    def destroy(self) -> None:
        """Free the PETSc objects (collective)."""
        objects = [self.snes, self.A, self.b, self.x, self._zero]
        objects += [self.P] if self.P is not None else []
        for obj in objects + self.system.petsc_objects():
            obj.destroy()
        self.settings.options.destroy()
