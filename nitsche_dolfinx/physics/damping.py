"""Rayleigh damping C = alpha M + beta K (docs/method.md section 14).

M is the problem's own mass (consistent as a form, or the lumped or redistributed
diagonal, which the solver adds as a matrix), K the bulk stiffness a(u, v) alone (not the
Nitsche terms on Gamma_C). alpha [1/time] and beta [time] are runtime constants: changing them
recompiles nothing. The modal damping ratio of a mode of circular frequency omega is
``zeta = alpha / (2 omega) + beta omega / 2``.

- :class:`RayleighDamping`: the coefficients and the damping force C v in UFL;
- :class:`DiagonalDamping`: alpha D v_d(w) for a diagonal mass D, the velocity v_d of the
  scheme affine in the step's unknown w, as the solver takes it: a diagonal added to the
  Jacobian and a vector to the residual;
- :class:`DampingPower`: v . C v by matrix-vector products, for the dissipation column;
- :func:`damped_stable_step`: the Verlet scheme's stable step with stiffness damping.
"""

from __future__ import annotations

import math

import numpy as np
from dolfinx import fem
from petsc4py import PETSc

from ..common.collective import sum_over_ranks
from ..common.parameters import require, require_real

__all__ = [
    "DampingPower",
    "DiagonalDamping",
    "RayleighDamping",
    "check_damping",
    "damped_stable_step",
]


def _coefficient(value, name: str, what: str) -> float:
    """A damping coefficient: a finite real number >= 0 (:class:`ParameterError` naming
    ``name`` otherwise)."""
    require_real(value, name, what)
    require(value >= 0.0, name, value, f"{what} must be >= 0")
    return float(value)


def check_damping(alpha: float = 0.0, beta: float = 0.0) -> tuple[float, float]:
    """(alpha, beta) as numbers, each a finite real number >= 0; :class:`ParameterError`
    naming ``damping_alpha`` or ``damping_beta`` otherwise."""
    return (
        _coefficient(alpha, "damping_alpha", "the damping coefficient alpha"),
        _coefficient(beta, "damping_beta", "the damping coefficient beta"),
    )


class RayleighDamping:
    """The coefficients of C = alpha M + beta K as ``fem.Constant`` attributes ``alpha`` and
    ``beta`` (their ``.value`` may change between runs).

    Args:
        mesh: The mesh.
        alpha: The mass-proportional coefficient, >= 0 [1/time].
        beta: The stiffness-proportional coefficient, >= 0 [time].
    """

    def __init__(self, mesh, alpha: float = 0.0, beta: float = 0.0):
        alpha, beta = check_damping(alpha, beta)
        self.alpha = fem.Constant(mesh, alpha)
        self.beta = fem.Constant(mesh, beta)

    @property
    def values(self) -> tuple[float, float]:
        """(alpha, beta) as numbers."""
        return float(np.asarray(self.alpha.value)), float(np.asarray(self.beta.value))

    def force(self, problem, velocity, test):
        """(C v, test) in UFL: beta a(v, test), plus alpha <rho v, test> with the consistent
        mass (a diagonal mass takes its part through :class:`DiagonalDamping`)."""
        form = self.beta * problem.bulk_stiffness(velocity, test)
        if problem.mass == "consistent":
            form = form + self.alpha * problem.inertia(velocity, test)
        return form


class DiagonalDamping:
    """A diagonal mass D with its damping alpha D v_d(w), where the scheme's damping velocity
    is affine in the unknown, ``v_d(w) = v_0 + c w`` (docs/method.md section 14): the solver
    adds the diagonal ``(1 + alpha c) D`` to the Jacobian and to the residual's product,
    and the vector ``alpha D v_0`` to the residual.

    Args:
        diagonal: D, a PETSc vector with ghosts.
        alpha: The ``fem.Constant`` alpha.
        velocity: ``velocity()``: v_0, a numpy array of the local dofs (ghosts included).
        coefficient: ``coefficient()``: c (None: 0, the initial acceleration's
            ``D a0 + alpha D v0``).
    """

    def __init__(self, diagonal: PETSc.Vec, alpha, velocity, coefficient=None):
        self._mass = diagonal
        self.alpha = alpha
        self._velocity = velocity
        self._coefficient = coefficient
        #: The diagonal the solver adds, (1 + alpha c) D (updated by :meth:`refresh`).
        self.vector = diagonal.copy()
        self.refresh()

    def key(self) -> tuple:
        """What :attr:`vector` depends on: alpha and c."""
        c = 0.0 if self._coefficient is None else float(self._coefficient())
        return (float(np.asarray(self.alpha.value)), c)

    def refresh(self) -> None:
        """Set :attr:`vector` to (1 + alpha c) D for the current alpha and step."""
        alpha, c = self.key()
        self._mass.copy(self.vector)
        self.vector.scale(1.0 + alpha * c)

    def add_offset(self, b: PETSc.Vec) -> None:
        """b += alpha D v_0 (owned entries)."""
        n = b.getLocalSize()
        with self._mass.localForm() as local:
            mass = local.array[:n]
        b.array[:] += self.key()[0] * mass * self._velocity()[:n]


class DampingPower:
    """x . C x = alpha x . M x + beta x . K x over all ranks, by products with the mass
    matrix M (consistent, or diagonal) and the bulk stiffness K.

    Args:
        damping: The :class:`RayleighDamping`.
        mass: ``mass(x, y)``: y = M x (PETSc vectors, owned entries).
        stiffness: K, a PETSc matrix.
        comm: The communicator.
    """

    def __init__(self, damping: RayleighDamping, mass, stiffness: PETSc.Mat, comm):
        self.damping, self._mass, self._stiffness, self.comm = damping, mass, stiffness, comm
        self._x, self._y = stiffness.createVecs()
        self._force = self._y.duplicate()

    def force(self, x: np.ndarray, out: PETSc.Vec, mass_velocity=None) -> PETSc.Vec:
        """out = beta K x + alpha M y (owned entries), y = ``mass_velocity`` (default x), for
        the local arrays ``x`` and y (their owned entries)."""
        alpha, beta = self.damping.values
        n = self._x.getLocalSize()
        self._x.array[:] = x[:n]
        self._stiffness.mult(self._x, out)
        out.scale(beta)
        if alpha != 0.0:
            if mass_velocity is not None:
                self._x.array[:] = mass_velocity[:n]
            self._mass(self._x, self._y)
            out.axpy(alpha, self._y)
        return out

    def __call__(self, x: np.ndarray) -> float:
        """x . C x, identical on every rank."""
        force = self.force(x, self._force)
        n = self._x.getLocalSize()
        local = float(x[:n] @ force.array_r)
        return float(sum_over_ranks(self.comm, [local])[0])

    def destroy(self) -> None:
        """Free the work vectors (collective); the stiffness stays its owner's."""
        for vector in (self._x, self._y, self._force):
            vector.destroy()


def damped_stable_step(largest: float, bulk_largest: float, beta: float) -> float:
    """The Verlet step's stability limit with stiffness damping (docs/method.md section 14):
    the largest tau with ``tau^2 lambda + 2 tau beta lambda_K <= 4``, lambda the estimate of
    the whole operator's largest eigenvalue (of M^-1 times its stiffness), lambda_K that of
    the bulk stiffness, whose velocity the damping force lags by half a step. For one mode,
    omega tau <= 2 (sqrt(1 + xi^2) - xi) with xi = beta omega / 2; alpha does not bound it."""
    if beta == 0.0:
        return 2.0 / math.sqrt(largest)
    b = beta * bulk_largest
    return (math.sqrt(b * b + 4.0 * largest) - b) / largest
