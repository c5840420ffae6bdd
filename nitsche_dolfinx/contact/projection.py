"""The closest point of a curved facet to a point (docs/method.md section 11): Newton's
method on the squared distance in the facet coordinates xi, for many points at once.

A facet is x(xi), xi in the reference simplex (an interval or a triangle), given by the
``points`` of its surface
(:meth:`~nitsche_dolfinx.contact.master_surface.MasterSurface.points`); the distance is
measured by ``across``, the identity or the projection across a line (a pairing along a
direction).
"""

from __future__ import annotations

import numpy as np

__all__ = ["closest_points", "solve_small"]

_NEWTON_STEPS = 12  # Newton steps of a closest-point projection onto a curved facet
_HALVINGS = 8  # halvings of a Newton step that does not bring the point nearer
_XI_TOLERANCE = 1e-13  # a Newton step below this (in facet coordinates) ends the projection
_LAST_STEP = 1e-8  # a Newton step below this is the last: the next would be round-off
_SMALL_STEP = 1e-6  # a Newton step below this is taken without comparing distances


def _definite(m: np.ndarray) -> np.ndarray:
    """Whether each of a stack of 1x1 or 2x2 symmetric matrices is positive definite."""
    if m.shape[1] == 1:
        return m[:, 0, 0] > 0
    return (m[:, 0, 0] > 0) & (m[:, 0, 0] * m[:, 1, 1] - m[:, 0, 1] * m[:, 1, 0] > 0)


def solve_small(matrix: np.ndarray, fallback: np.ndarray, right: np.ndarray) -> np.ndarray:
    """matrix^-1 right for a stack of 1x1 or 2x2 systems, the ``fallback`` matrices where
    ``matrix`` is not positive definite; a singular one (a line along a facet) gets a
    little of its own scale on its diagonal."""

    chosen = np.where(_definite(matrix)[:, None, None], matrix, fallback)
    trace = np.trace(chosen, axis1=1, axis2=2)
    chosen = chosen + (1e-12 * np.abs(trace) + 1e-300)[:, None, None] * np.eye(matrix.shape[1])
    if matrix.shape[1] == 1:
        return right / chosen[:, 0]
    a, b, c, d = chosen[:, 0, 0], chosen[:, 0, 1], chosen[:, 1, 0], chosen[:, 1, 1]
    determinant = a * d - b * c
    return np.stack([d * right[:, 0] - b * right[:, 1], a * right[:, 1] - c * right[:, 0]],
                    axis=1) / determinant[:, None]  # fmt: skip


def _into_facet(xi: np.ndarray) -> np.ndarray:
    """The facet coordinates xi (points, fdim) moved to the nearest point of the reference
    simplex facet xi >= 0, sum(xi) <= 1 (an interval or a triangle)."""
    inside = np.clip(xi, 0.0, None)
    beyond = inside.sum(axis=1) > 1.0
    if xi.shape[1] == 1:
        inside[beyond] = 1.0
    elif beyond.any():  # onto the edge xi_1 + xi_2 = 1
        first = np.clip((xi[beyond, 0] - xi[beyond, 1] + 1.0) / 2, 0.0, 1.0)
        inside[beyond] = np.stack([first, 1.0 - first], axis=1)
    return inside


def closest_points(points, facet: np.ndarray, targets: np.ndarray, across: np.ndarray, fdim: int):
    """The points of the facets closest to the targets, measured by ``across`` (the
    identity, or the projection across a line): Newton's method on the squared
    distance in xi, with its curvature term (Gauss-Newton where the Hessian is not
    positive definite) and halved steps where a step does not bring the point nearer,
    kept in the facet; each point until its step is below round-off.

    Args:
        points: The facets' points x(xi), their derivatives and with ``second`` their
            second derivatives
            (:meth:`~nitsche_dolfinx.contact.master_surface.MasterSurface.points`).
        facet: The facet of each target (an index into the surface's facets).
        targets: The points to project, (points, gdim).
        across: The matrix that measures the offsets (symmetric).
        fdim: The dimension of the facets.

    Returns:
        The facet coordinates xi of the closest points and the points.
    """
    xi = np.full((len(facet), fdim), 1.0 / (fdim + 1))
    x, tangent, curvature = points(facet, xi, second=True)
    active = np.arange(len(facet)) if fdim else np.zeros(0, dtype=np.int64)
    for _ in range(_NEWTON_STEPS):
        if not active.size:
            break
        offset = (x[active] - targets[active]) @ across  # (``across`` is symmetric)
        t = tangent[active]
        gradient = np.einsum("ndf,nd->nf", t, offset)
        gauss_newton = np.einsum("ndf,dg->nfg", t, across) @ t
        hessian = gauss_newton + np.einsum("nd,ndfg->nfg", offset, curvature[active])
        step = -solve_small(hessian, gauss_newton, gradient)
        # a small Newton step (on a positive definite Hessian: near the closest point,
        # where Newton converges quadratically) is taken as it is: the change of the
        # distance it makes is round-off, and would halve it for nothing; below
        # _LAST_STEP the next would be below round-off, and it is the last
        size = np.abs(step).max(axis=1)
        sure = _definite(hessian) & (size < _SMALL_STEP)
        last = sure & (size < _LAST_STEP)
        before = xi[active]
        distance = np.einsum("nd,nd->n", offset, offset)
        trying, scale = active, np.ones(len(active))
        position = np.arange(len(active))  # of the tried points among the active ones
        for _ in range(_HALVINGS):  # halve the steps that do not bring the point nearer
            trial = _into_facet(xi[trying] + scale[position, None] * step[position])
            new = points(facet[trying], trial, second=True)
            new_offset = (new[0] - targets[trying]) @ across
            nearer = np.einsum("nd,nd->n", new_offset, new_offset) <= distance[position]
            nearer |= sure[position]
            taken = trying[nearer]
            xi[taken] = trial[nearer]
            x[taken], tangent[taken], curvature[taken] = (part[nearer] for part in new)
            trying, position = trying[~nearer], position[~nearer]
            if not trying.size:
                break
            scale[position] /= 2
        moved = np.abs(xi[active] - before).max(axis=1)  # (a point kept at an edge: 0)
        active = active[(moved >= _XI_TOLERANCE) & ~last]
    return xi, x
