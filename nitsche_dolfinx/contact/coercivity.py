"""A cell-wise bound of the coercivity of A_Thgamma (docs/method.md section 12).

For Theta > 0 the boundary part of A_Thgamma, -Theta int_Gamma_C gamma_h sigma_n(u)
sigma_n(v), is negative: A_Thgamma stays coercive only while gamma0 is small enough for
the mesh. Cell by cell, with a_T the cell's share of the bulk term,

    mu_T = max_v  Theta int_{dT cap Gamma_C} gamma_h sigma_n(v)^2 / a_T(v, v)

over the polynomials v of the cell (the rigid motions, which have no stress, left out).
If every mu_T < 1, A_Thgamma(v, v) = sum_T (a_T(v, v) - the cell's boundary term) > 0:
coercive. mu_T is proportional to gamma0, so gamma0 / max mu_T is the largest gamma0
the bound guarantees. It is a sufficient condition (exact in 1D P1, where max mu_T =
gamma0 E): a mesh may stay coercive a little beyond it. Beyond coercivity an explicit
step grows whatever dt (a negative eigenvalue of M^-1 A), and an implicit one may.

The cells' matrices come from the broken (discontinuous) space of the displacement's
degree, whose matrices are block diagonal, one block per cell; each block of a cell on
Gamma_C is a small dense generalized eigenproblem.
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from dolfinx.mesh import meshtags
from mpi4py import MPI
from petsc4py import PETSc

from ..common import compat

__all__ = ["coercivity_ratio", "constant_value"]

#: Eigenvalues of a cell's bulk matrix below this share of its largest are its rigid
#: motions (zero, but for round-off).
RIGID = 1e-10


def coercivity_ratio(problem) -> float:
    """max_T mu_T over the cells of every Gamma_C of ``problem`` (0 without contact or
    for Theta <= 0), identical on every rank."""
    contacts = [c for c in problem.contacts if constant_value(c.nitsche_theta) > 0]
    if not contacts:
        return 0.0
    mesh = problem.mesh
    W = compat.function_space(mesh, "DG", compat.element_degree(problem.V), (problem.gdim,))
    u, v = ufl.TrialFunction(W), ufl.TestFunction(W)
    cells = _contact_cells(mesh, contacts)
    # the bulk on those cells only: the matrices hold their blocks alone
    marked = meshtags(mesh, mesh.topology.dim, cells, np.ones(len(cells), dtype=np.int32))
    near = problem.dx(subdomain_data=marked, subdomain_id=1)
    bulk = _assembled(ufl.inner(problem.stress(u), ufl.sym(ufl.grad(v))) * near)
    boundary = _assembled(sum(-c.consistency_term(u, v) for c in contacts))
    bs = W.dofmap.index_map_bs
    start = W.dofmap.index_map.local_range[0] * bs
    largest = 0.0
    if len(cells):  # (a rank may hold no cell of Gamma_C)
        nodes = compat.dofmap_array(W)[cells]
        dofs = (nodes[:, :, None] * bs + np.arange(bs)).reshape(len(cells), -1) + start
        dofs = dofs.astype(PETSc.IntType)
        K = np.array([bulk.getValues(d, d) for d in dofs])
        F = np.array([boundary.getValues(d, d) for d in dofs])
        largest = float(np.max(_cell_ratios(K, F)))
    for matrix in (bulk, boundary):
        matrix.destroy()
    return mesh.comm.allreduce(largest, op=MPI.MAX)


def constant_value(constant) -> float:
    """The value of a ``fem.Constant`` (or of a number)."""
    return float(np.asarray(getattr(constant, "value", constant)))


def _assembled(form):
    compiled = fem.form(form)
    matrix = fem_petsc.assemble_matrix(compiled)
    matrix.assemble()
    return matrix


def _contact_cells(mesh, contacts) -> np.ndarray:
    """The owned cells with a facet on one of the ``contacts``' Gamma_C."""
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    to_cell = mesh.topology.connectivity(tdim - 1, tdim)
    cells = set()
    for contact in contacts:
        tags, ids = contact.ds.subdomain_data(), contact.ds.subdomain_id()
        ids = [ids] if isinstance(ids, (int, np.integer)) else list(ids)
        for facet in tags.indices[np.isin(tags.values, ids)]:
            cells.update(to_cell.links(facet).tolist())
    owned = mesh.topology.index_map(tdim).size_local
    return np.array(sorted(c for c in cells if c < owned), dtype=np.int32)


def _cell_ratios(K: np.ndarray, F: np.ndarray) -> np.ndarray:
    """max_v v.F v / v.K v per cell (stacked dense K, F), v in the range of K."""
    ratios = np.empty(len(K))
    for i, (k, f) in enumerate(zip(K, F)):
        k, f = (k + k.T) / 2, (f + f.T) / 2
        values, vectors = np.linalg.eigh(k)
        kept = values > RIGID * values.max()
        scaled = vectors[:, kept] / np.sqrt(values[kept])
        ratios[i] = np.linalg.eigvalsh(scaled.T @ f @ scaled).max()
    return ratios
