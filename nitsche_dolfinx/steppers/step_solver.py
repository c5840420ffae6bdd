"""The solver of an implicit step's equation F(w) = 0 (docs/method.md section 8): the SNES
of :class:`~nitsche_dolfinx.steppers.implicit.NitscheStepper`, on the affine split of the
bulk (:class:`~nitsche_dolfinx.assembly.affine_system.AffineSystem`) or assembled in full, with
the diagonal mass and damping and the coupling of contact pairs.
"""

from __future__ import annotations

import ufl

from ..assembly.affine_system import AffineSystem, StepForms
from ..assembly.pair_coupling import PairCoupling
from ..assembly.systems import FormSystem
from ..common import compat
from ..contact.terms import ContactTerms, contact_activity, contact_parts
from ..model.problem import ContactProblem
from ..physics.damping import DiagonalDamping
from ..solvers.petsc_snes import SolverSettings
from ..solvers.solver import SNESSolver
from .schemes import TimeScheme

__all__ = ["step_solver"]


def step_solver(
    problem: ContactProblem, scheme: TimeScheme, state: tuple, bcs, settings: SolverSettings,
    reuse_jacobian: bool = True, model=None, dirichlet_dofs=(), bc_values=None,
) -> SNESSolver:  # fmt: skip
    """The SNES of a step's equation F(w) = 0 (docs/method.md section 8).

    Args:
        problem: The problem.
        scheme: The time scheme, which writes F from the problem's terms.
        state: ``(w, u, v, a, dt)``: the unknown, the state at t^n, the step (a Constant).
        bcs: The Dirichlet conditions on ``w``.
        settings: The solver's :class:`~nitsche_dolfinx.solvers.petsc_snes.SolverSettings`.
        reuse_jacobian: Solve the
            :class:`~nitsche_dolfinx.assembly.affine_system.AffineSystem` (the bulk is
            linear elastodynamics: its cell terms are affine in the unknown, and only the
            contact terms on Gamma_C change the Jacobian); False: assemble every
            Jacobian in full (with contact pairs, their coupling added), as at finite
            strains.
        model: The model whose terms F holds (``problem``, or its friction law guarded by
            :class:`~nitsche_dolfinx.steppers.friction.GuardedNewton`).
        dirichlet_dofs: The local indices of the Dirichlet dofs (for contact pairs).
        bc_values: The Function whose values ``bcs`` give the Dirichlet dofs, if any.
    """
    model = problem if model is None else model
    w, u, v, a, _ = state
    test = ufl.TestFunction(problem.V)
    F = scheme.residual(model, *state, test)
    if not reuse_jacobian or problem.finite:  # finite strains: no affine bulk to keep
        # contact pairs: their coupling added to the full Jacobian (docs/method.md
        # section 15)
        coupling = _pair_coupling(problem, scheme, F, state, test, dirichlet_dofs, model)
        diagonal = _mass_diagonal(problem, scheme, state)
        system = FormSystem(F, w, bcs, mass_diagonal=diagonal, coupling=coupling)
        return SNESSolver.for_system(system, settings)
    activity, facet_parts = None, None
    if problem.contacts:  # lets the solver skip the contact Jacobian out of contact
        cellwise = ufl.TestFunction(compat.function_space(problem.mesh, "DG", 0))
        activity = scheme.residual(contact_activity(problem), *state, cellwise)
        facet_parts = [
            scheme.residual(part, *state, test)
            for part in contact_parts(problem, getattr(model, "reference", None))
        ]
    coupling = _pair_coupling(problem, scheme, F, state, test, dirichlet_dofs, model)
    forms = StepForms(F, None, activity, facet_parts, (u, v, a), coupling)
    diagonal = _mass_diagonal(problem, scheme, state)
    system = AffineSystem(forms, w, bcs, diagonal, settings.matrix_type)
    if bc_values is not None:
        system.prescribe(dirichlet_dofs, bc_values)
    return SNESSolver.for_system(system, settings)


def _mass_diagonal(problem: ContactProblem, scheme: TimeScheme, state: tuple):
    """The diagonal mass the solver adds (None: the consistent mass, in the forms); with
    damping, with its alpha part at the scheme's damping velocity v_d(w) = v_0 + c w
    (:class:`~nitsche_dolfinx.physics.damping.DiagonalDamping`, docs/method.md section 14)."""
    diagonal = problem.mass_diagonal()
    if diagonal is None or problem.damping is None:
        return diagonal
    _, u, v, a, dt = state

    def velocity():
        arrays = (u.x.array, v.x.array, a.x.array)
        return scheme.damping_velocity(*arrays, 0.0, float(dt.value))

    def coefficient():
        return scheme.damping_velocity(0.0, 0.0, 0.0, 1.0, float(dt.value))

    return DiagonalDamping(diagonal, problem.damping.alpha, velocity, coefficient)


def _pair_coupling(
    problem, scheme, F, state, test, dirichlet_dofs, model=None
) -> PairCoupling | None:
    """The terms of contact between bodies beyond the UFL forms (None without pairs): each
    pair's partner-tested residual, written by the scheme like its own terms (with the
    friction law of ``model``, guarded or not)."""
    if not problem.pairs:
        return None
    reference = getattr(model, "reference", None)

    def partner_term(pair, u, velocity, force, v):
        return pair.partner_force_terms(u, velocity, force, v, reference)

    residuals = [
        scheme.residual(ContactTerms([pair], partner_term), *state, test) for pair in problem.pairs
    ]
    return PairCoupling(
        problem.pairs, F, residuals, state[0], dirichlet_dofs, problem.symmetric_jacobian
    )
