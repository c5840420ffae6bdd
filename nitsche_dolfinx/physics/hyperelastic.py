"""Hyperelastic materials at finite strain: strain energies, stresses and the averaged
stress of the energy-consistent step (docs/method.md section 15).

Total Lagrangian conventions: ``F = I + grad u``, ``C = F^T F``, a strain energy
``W(C)`` per unit reference volume, the second Piola-Kirchhoff stress ``S = 2 dW/dC``,
the first ``P = F S`` (force per reference area on the reference normal N: ``P N``),
the Cauchy stress ``sigma = P F^T / det F``.

In 2D (plane strain) every law sees the 3 x 3 tensor C with ``C_33 = 1``: the out-of-
plane stress ``S_33`` follows from W itself, for the built-in laws and for a user's.

A law is a function ``W(C, constants)`` of a 3 x 3 UFL tensor and the material's
runtime constants (``lmbda``, ``mu``, ``E``, ``nu``: see
:class:`~nitsche_dolfinx.physics.material.MaterialConstants`); :data:`LAWS` names the built-in
ones. Both reduce to linear elasticity with (lambda, mu) at small strains.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import ufl

__all__ = [
    "LAWS",
    "QUADRATIC_LAWS",
    "STEP_POINTS",
    "averaged_stress",
    "cauchy_stress",
    "deformation_gradient",
    "gauss_points",
    "first_piola",
    "neo_hookean",
    "saint_venant_kirchhoff",
    "strain_energy",
    "von_mises_of",
]


def saint_venant_kirchhoff(C, c):
    """W = lambda/2 tr(E)^2 + mu tr(E^2), E = (C - I)/2: quadratic in C, so its averaged
    stress is exact with one point (Simo and Tarnow's scheme)."""
    E = (C - ufl.Identity(3)) / 2
    return c.lmbda / 2 * ufl.tr(E) ** 2 + c.mu * ufl.inner(E, E)


def neo_hookean(C, c):
    """Compressible neo-Hookean: W = mu/2 (tr C - 3) - mu ln J + lambda/2 (ln J)^2,
    J = sqrt(det C)."""
    log_J = ufl.ln(ufl.det(C)) / 2
    return c.mu / 2 * (ufl.tr(C) - 3) - c.mu * log_J + c.lmbda / 2 * log_J**2


#: The built-in strain energies by name: ``Material(law=NAME)`` and ``[material] law``.
LAWS: dict[str, Callable] = {
    "svk": saint_venant_kirchhoff,
    "neo_hookean": neo_hookean,
}
#: The laws whose W is quadratic in C: their averaged stress is the stress at the mean C.
QUADRATIC_LAWS = (saint_venant_kirchhoff,)


def gauss_points(count: int) -> tuple[tuple[float, float], ...]:
    """The Gauss-Legendre points and weights (s, w) on [0, 1], exact for polynomials in s
    of degree 2 count - 1."""
    nodes, weights = np.polynomial.legendre.leggauss(count)
    return tuple(zip(((nodes + 1) / 2).tolist(), (weights / 2).tolist()))


#: The points in s of the averaged stress of a law that is not quadratic in C: for the
#: neo-Hookean law the energy error of a step falls from 1e-8 E with 2 points to 1e-12
#: with 3 and round-off with 4 (docs/method.md section 15).
STEP_POINTS = gauss_points(4)


def deformation_gradient(u):
    """F = I + grad u."""
    dim = u.ufl_shape[0]
    return ufl.Identity(dim) + ufl.grad(u)


def _embedded(C):
    """C (or F) as the 3 x 3 tensor of plane strain (C_33 = 1) in 2D, itself in 3D."""
    if C.ufl_shape[0] == 3:
        return C
    return ufl.as_matrix([[C[0, 0], C[0, 1], 0], [C[1, 0], C[1, 1], 0], [0, 0, 1]])


def _in_plane(S, dim: int):
    """The dim x dim block of a 3 x 3 tensor."""
    if dim == 3:
        return S
    return ufl.as_matrix([[S[i, j] for j in range(dim)] for i in range(dim)])


def _second_piola_3d(law: Callable, constants, C):
    """S = 2 dW/dC as a 3 x 3 tensor, at the (possibly 2D) C."""
    C3 = ufl.variable(_embedded(C))
    return 2 * ufl.diff(law(C3, constants), C3)


def strain_energy(law: Callable, constants, u):
    """W(C(u)) per unit reference volume."""
    F = deformation_gradient(u)
    return law(_embedded(F.T * F), constants)


def first_piola(law: Callable, constants, u):
    """P = F S at the displacement u."""
    F = deformation_gradient(u)
    dim = F.ufl_shape[0]
    return F * _in_plane(_second_piola_3d(law, constants, F.T * F), dim)


def averaged_stress(law: Callable, constants, u_old, u_new):
    """The first Piola stress of the energy-consistent step from u_old to u_new:
    ``F_mid S_avg`` with ``F_mid = (F_old + F_new)/2`` and
    ``S_avg = int_0^1 S(C_old + s (C_new - C_old)) ds`` (docs/method.md section 15).

    Tested with u_new - u_old it gives W(C_new) - W(C_old) (as C_new - C_old =
    2 sym(F_mid^T (F_new - F_old))), and S_avg is symmetric (angular momentum is kept).
    The integral in s is exact with the midpoint for a law quadratic in C
    (:data:`QUADRATIC_LAWS`), else the Gauss rule :data:`STEP_POINTS`.
    """
    F0, F1 = deformation_gradient(u_old), deformation_gradient(u_new)
    dim = F0.ufl_shape[0]
    C0, C1 = F0.T * F0, F1.T * F1
    points = ((0.5, 1.0),) if law in QUADRATIC_LAWS else STEP_POINTS
    S = sum(w * _second_piola_3d(law, constants, C0 + s * (C1 - C0)) for s, w in points)
    return (F0 + F1) / 2 * _in_plane(S, dim)


def cauchy_stress(law: Callable, constants, u):
    """sigma = F S F^T / det F, as a 3 x 3 tensor (plane strain: F_33 = 1, its sigma_33
    from W)."""
    F = deformation_gradient(u)
    C = F.T * F
    S = _second_piola_3d(law, constants, C)
    F3 = _embedded(F)
    return F3 * S * F3.T / ufl.det(F3)


def von_mises_of(stress):
    """The von Mises stress of a 3 x 3 stress tensor."""
    deviator = stress - ufl.tr(stress) / 3 * ufl.Identity(3)
    return ufl.sqrt(1.5 * ufl.inner(deviator, deviator))
