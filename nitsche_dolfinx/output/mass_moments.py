"""The mass of the body and its moments, from its mass matrix (docs/method.md section 4): the
kinetic energy, the linear momentum, the centre of mass and the angular momentum, of the
whole mesh and of each body, reduced over MPI; the matrices of bilinear forms they and the
energies are products with.
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from petsc4py import PETSc

from ..common import compat
from ..common.collective import sum_over_ranks
from .history import (
    angular_momentum_columns,
    body_columns,
    centre_of_mass_columns,
    momentum_columns,
)

__all__ = ["MassMoments", "assembled_matrix"]


def _diagonal_matrix(diagonal):
    """A PETSc AIJ matrix with the given diagonal."""
    matrix = PETSc.Mat().createAIJ(
        (diagonal.getSizes(), diagonal.getSizes()), nnz=1, comm=diagonal.getComm()
    )
    matrix.setDiagonal(diagonal)
    return matrix


def assembled_matrix(form) -> PETSc.Mat:
    """The matrix of a bilinear form, in blocks of the space's block size (BAIJ: for 3D
    vectors, products about three times faster than AIJ)."""
    compiled = fem.form(form)
    matrix = compat.create_matrix(compiled, "baij")
    fem_petsc.assemble_matrix(matrix, compiled)
    matrix.assemble()
    return matrix


class MassMoments:
    """The mass of the body and its moments, from its mass matrix M (consistent, or the
    lumped or redistributed diagonal): the kinetic energy 1/2 v . M v, the total linear
    momentum (the rows of M v summed by component), the centre of mass (those of
    M (x + u), over the mass; x the positions of the nodes, which the displacement space
    interpolates exactly when it holds the geometry) and the angular momentum about the
    origin, sum_i (x_i + u_i) x (M v)_i over the nodes, and sum_i x_i x (M v)_i, the one
    linear elasticity keeps (docs/method.md section 4); the first three also over the
    nodes of each body of the model (``ContactProblem.add_body``), whose rows are its own
    mass matrix's.

    Args:
        model: The :class:`~nitsche_dolfinx.model.problem.ContactProblem`.
    """

    def __init__(self, model):
        self.comm = model.mesh.comm
        self.model = model
        trial, test = ufl.TrialFunction(model.V), ufl.TestFunction(model.V)
        diagonal = model.mass_diagonal()
        if diagonal is None:
            self.matrix = assembled_matrix(model.inertia(trial, test))
        else:  # lumped or redistributed mass: a diagonal matrix
            self.matrix = _diagonal_matrix(diagonal)
            self.matrix.assemble()
        self._work = self.matrix.createVecLeft()
        self._displaced = self.matrix.createVecLeft()  # M u
        self.bs = model.V.dofmap.index_map_bs
        self.momentum_names = momentum_columns(self.bs)
        self.centre_names = centre_of_mass_columns(self.bs)
        self.angular_names = angular_momentum_columns(self.bs)
        self.reference_names = angular_momentum_columns(self.bs, reference=True)
        positions = fem.Function(model.V)
        positions.interpolate(lambda x: x[: self.bs])
        #: The nodes' positions (owned rows) and the rows of M x (of the undeformed body).
        self._positions = self._rows(positions.x.array).copy()
        self._first_moment_rows = self._rows(self._product(positions, self._work)).copy()
        self._first_moment = sum_over_ranks(self.comm, self._first_moment_rows.sum(axis=0))
        positions.x.array[:] = 1.0
        self._mass_rows = self._rows(self._product(positions, self._work))[:, 0].copy()
        self.mass = float(sum_over_ranks(self.comm, [self._mass_rows.sum()])[0])
        self._body_masses: list[float] = []  # of model.bodies, once asked for

    def _rows(self, array) -> np.ndarray:
        """The owned part of a dof array, one row per node."""
        owned = self._work.getLocalSize()
        return np.asarray(array)[:owned].reshape(-1, self.bs)

    def _product(self, function, out) -> np.ndarray:
        """M f into ``out``; its owned entries."""
        self.matrix.mult(compat.petsc_vector(function), out)
        return out.array

    def sums(self, function) -> np.ndarray:
        """M f summed by component over all ranks (M f stays in the work vector)."""
        return sum_over_ranks(self.comm, self._rows(self._product(function, self._work)).sum(0))

    def inertia_norm(self, v, dt: float) -> float:
        """||M v|| / dt over all ranks: the force that would stop the velocity ``v`` in a
        step ``dt``."""
        self._product(v, self._work)
        return self._work.norm() / dt

    def momentum(self, v) -> np.ndarray:
        """The total linear momentum, by component: the rows of M v summed."""
        return self.sums(v)

    def kinetic(self, v) -> float:
        """1/2 v . M v."""
        self.matrix.mult(compat.petsc_vector(v), self._work)
        return 0.5 * self._work.dot(compat.petsc_vector(v))

    def centre_of_mass(self, u) -> np.ndarray:
        """The centre of mass of the body deformed by ``u``, by component."""
        return (self._first_moment + self.sums(u)) / self.mass

    def _angular(self, positions: np.ndarray, momenta: np.ndarray) -> np.ndarray:
        """sum_i x_i x p_i over the rows (2D: its z component; 1D: none)."""
        if self.bs == 1:
            return np.zeros(0)
        if self.bs == 2:
            return np.array(
                [np.sum(positions[:, 0] * momenta[:, 1] - positions[:, 1] * momenta[:, 0])]
            )
        return np.cross(positions, momenta).sum(axis=0)

    def values(self, u, v) -> dict[str, float]:
        """The momentum, centre-of-mass and angular momentum columns at the state (u, v),
        of the whole mesh and of each body, with one reduction over the ranks."""
        momenta = self._rows(self._product(v, self._work))
        displaced = self._rows(self._product(u, self._displaced))
        current = self._positions + self._rows(u.x.array)
        parts = [momenta, displaced, current]
        local = [momenta.sum(0), displaced.sum(0), self._angular(current, momenta)]
        local.append(self._angular(self._positions, momenta))
        bodies = self.model.bodies
        for body in bodies:
            momenta_b, displaced_b, current_b = (part[body.nodes] for part in parts)
            moment = self._first_moment_rows[body.nodes].sum(0) + displaced_b.sum(0)
            local += [momenta_b.sum(0), moment, self._angular(current_b, momenta_b)]
        if len(self._body_masses) != len(bodies):
            self._body_masses = sum_over_ranks(
                self.comm, [self._mass_rows[body.nodes].sum() for body in bodies]
            ).tolist()
        ends = np.cumsum([part.size for part in local])[:-1]
        sums = iter(np.split(sum_over_ranks(self.comm, np.concatenate(local)), ends))
        momentum, centre = next(sums), (self._first_moment + next(sums)) / self.mass
        values = {
            **dict(zip(self.momentum_names, momentum.tolist())),
            **dict(zip(self.centre_names, centre.tolist())),
            **dict(zip(self.angular_names, next(sums).tolist())),
            **dict(zip(self.reference_names, next(sums).tolist())),
        }
        for body, mass in zip(bodies, self._body_masses):
            each = [next(sums), next(sums) / mass, next(sums)]
            values.update(zip(body_columns(body.tag, self.bs), np.concatenate(each).tolist()))
        return values
