"""The Newton solver of a step: PETSc SNES (:mod:`nitsche_dolfinx.solvers.petsc_snes`) with the
Newton policy of docs/method.md section 8.

The contact terms are only semismooth (the derivative of ``[x]_+`` is the Heaviside
function H(x)): SNES's Newton method is then a semismooth Newton. A solve converges by
:class:`~nitsche_dolfinx.solvers.newton.ConvergenceTest`, its Krylov solves as inexact as Newton
allows (:class:`~nitsche_dolfinx.solvers.newton.InexactSolves`); when a Krylov solve fails, again
with direct solves; when full Newton steps cycle between contact states
(:meth:`SNESSolver.solve_with_line_search`), again with a line search. Smaller steps are the
time loop's (:class:`~nitsche_dolfinx.simulation.Simulation`).
"""

from __future__ import annotations

import contextlib
from typing import Any

from petsc4py import PETSc

from ..assembly.systems import FormSystem
from .newton import ConvergenceTest, InexactSolves
from .petsc_snes import PetscSNES, SolverSettings

__all__ = ["SNESSolver", "SolverError"]

_REASONS = {
    value: name
    for name, value in vars(PETSc.SNES.ConvergedReason).items()
    if not name.startswith("_") and isinstance(value, int)
}


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


class SNESSolver:
    """Solve F(u; v) = 0 for all v with PETSc SNES.

    ``SNESSolver(F, u, bcs)`` solves a problem given as UFL forms
    (:class:`~nitsche_dolfinx.assembly.systems.FormSystem`); :meth:`for_system` a step's system
    (:class:`~nitsche_dolfinx.assembly.affine_system.AffineSystem`): its constant Jacobian
    assembled once, the contact part when it changes, the Jacobian left untouched when it
    did not, so that PETSc reuses its factorisation.

    Args:
        F: The residual, a UFL form linear in the test function.
        u: The unknown Function; it holds the initial guess and receives the solution.
        bcs: Dirichlet conditions on ``u``.
        J: The Jacobian form; ``ufl.derivative(F, u)`` when omitted.
        petsc_options: PETSc options that override the defaults
            (:class:`~nitsche_dolfinx.solvers.petsc_snes.SolverSettings`).
        options_prefix: The PETSc options prefix; a unique one when omitted.
        mass_diagonal: A diagonal matrix D (as a vector) added: F(u) + D u and J + D.
        linear_solver: A preset of :mod:`nitsche_dolfinx.solvers.linear_solvers` (None: lu).

    Attributes: ``snes`` (PETSc's), ``system``, ``petsc``
    (:class:`~nitsche_dolfinx.solvers.petsc_snes.PetscSNES`: its matrices and its counts of
    Jacobians and factorisations), ``convergence`` and ``linear_tolerances`` (the policy).

    Example:
        >>> solver = SNESSolver(F, u, bcs, petsc_options={"snes_monitor": None})
        >>> iterations = solver.solve()
    """

    def __init__(
        self, F, u, bcs=(), J=None, petsc_options: dict[str, Any] | None = None,
        options_prefix: str | None = None, mass_diagonal=None, linear_solver=None,
    ):  # fmt: skip
        comm = u.function_space.mesh.comm
        settings = SolverSettings(comm, petsc_options, linear_solver, 0, False, options_prefix)
        self._setup(FormSystem(F, u, bcs, J, mass_diagonal), settings)

    @classmethod
    def for_system(cls, system, settings: SolverSettings) -> SNESSolver:
        """The solver of ``system`` (:mod:`nitsche_dolfinx.assembly.systems`) with ``settings``."""
        solver = cls.__new__(cls)
        solver._setup(system, settings)
        return solver

    def _setup(self, system, settings: SolverSettings) -> None:
        self.system, self.u = system, system.u
        self.petsc = PetscSNES(system, settings, self._after_jacobian)
        self.snes = self.petsc.snes
        #: When the linear solves stop: Krylov solves whose tolerances follow Newton's.
        self.linear_tolerances = InexactSolves(
            self.petsc.krylov and not self.petsc.krylov_tolerances_given
        )
        self.convergence = ConvergenceTest(self.linear_tolerances, self.petsc.user_atol)
        self.snes.setConvergenceTest(self.convergence)
        #: A norm of the forces that the equation balances (the loads', the supports'), a
        #: floor of its scale: a body at rest in equilibrium has F(0) and F(u_0) of
        #: round-off, and its solve converges against this scale (0: none known).
        self.force_scale = 0.0
        self._line_search_type = self.petsc.line_search_type

    def _after_jacobian(self, ksp, changed: bool, active: bool) -> None:
        """Record whether the Jacobian changed at this iterate (the contact set moved), and
        set the tolerances of the linear solve that follows."""
        changes = self.convergence.jacobian_changes
        changes.append(changed)
        self.linear_tolerances.set(ksp, len(changes) - 1, changed, active, self.convergence.atol)

    def solve(self, atol: float | None = None) -> int:
        """Run SNES from the current value of ``u`` (the convergence test of
        :class:`~nitsche_dolfinx.solvers.newton.ConvergenceTest`).

        Args:
            atol: The absolute tolerance of this solve (e.g. one shared by several solves
                of a step); a user's ``snes_atol`` wins over it.

        Returns:
            The number of Newton iterations.

        Raises:
            SolverError: SNES diverged; the message names the reason and the last
                residual norm. ``u`` then holds the last Newton iterate.
        """
        self._new_coefficients()
        # ||F(u_0)|| is SNES's first residual: the convergence test takes it from there
        full_steps = self._line_search_type == "basic"
        zero_norm = max(self.petsc.residual_norm(at_zero=True), self.force_scale)
        self.convergence.start(zero_norm, atol, full_steps)
        start = self.u.x.array.copy()
        reason, iterations = self._run()
        failed = reason == PETSc.SNES.ConvergedReason.DIVERGED_LINEAR_SOLVE
        if failed and (self.petsc.P is not None or self.linear_tolerances.enabled):
            # GMRES on a lagged factorisation, or the Krylov method of a preset, gave up:
            # again, factorising the Jacobian (with conjugate gradients, a Jacobian that is
            # not positive definite: gamma0 beyond the stability limit)
            self.u.x.array[:] = start
            if self.petsc.P is not None:
                self.petsc.factorise_at_next_jacobian()
            else:
                self.petsc.direct_solves_from_now_on()
                self.linear_tolerances.enabled = False
            reason, more = self._run()
            iterations += more
        if reason <= 0:
            raise SolverError(reason, iterations, self.snes.getFunctionNorm())
        return iterations

    def _run(self) -> tuple[int, int]:
        """One SNES solve from ``u``: its reason and iterations."""
        self.convergence.restart()
        self.linear_tolerances.start()
        result = self.petsc.run()
        self.linear_tolerances.finish(self.convergence.jacobian_changes)
        return result

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

    @contextlib.contextmanager
    def line_search(self, kind: str):
        """Solve with the SNES line search ``kind`` (e.g. ``"l2"``) inside the block."""
        before = self._line_search_type
        options = self.petsc.settings.options
        with options.replaced("snes_linesearch_type", kind, self.snes.setFromOptions):
            self._line_search_type = kind
            try:
                yield
            finally:
                self._line_search_type = before

    def update_constant_terms(self) -> None:
        """Assemble again the constant Jacobian after a constant in it changed (the time
        step); the next Jacobian is then factorised anew."""
        self.system.update_constant_terms()
        self.petsc.factorise_at_next_jacobian()

    def _new_coefficients(self) -> None:
        """What depends on the coefficients other than ``u`` (a constant of the Jacobian
        set by the user, the constant part of the cell terms, the partners of the state
        across contact pairs), for their new values."""
        if self.system.constants_changed():
            self.update_constant_terms()
        self.system.new_coefficients()

    def residual_norm(self, new_coefficients: bool = True) -> float:
        """The Euclidean norm of the residual at the current value of ``u`` (collective).

        Args:
            new_coefficients: The coefficients other than ``u`` changed since the last
                solve or evaluation.
        """
        if new_coefficients:
            self._new_coefficients()
        return self.petsc.residual_norm()

    def equation_scale(self, new_coefficients: bool = True) -> float:
        """The scale of the equation at the current coefficients: the larger of ||F(0)||
        and ||F(u)|| at the current ``u``, which is left as it was (collective)."""
        return max(self.residual_norm(new_coefficients), self.petsc.residual_norm(at_zero=True))

    @property
    def facet_jacobian_assemblies(self) -> int:
        """How many times the facet (contact) Jacobian was assembled."""
        count = self.system.facet_jacobian_assemblies
        return self.petsc.jacobian_evaluations if count is None else count

    def destroy(self) -> None:
        """Free the PETSc objects (collective)."""
        self.petsc.destroy()
