"""The contact force of the rigid obstacles that stand still, from operators on the
quadrature points of Gamma_C assembled once (docs/method.md section 12).

With an obstacle that stands still, n_c and g do not depend on u or t, so that at the
quadrature points x_q of the facets of Gamma_C (those of the forms' own rule)

    P_gamma(u)(x_q) = (C u)_q - g_q,        P_Thgamma(v)(x_q) = (B v)_q,

C and B sparse, a row per point and a column per dof of the point's cell (B = C for
Theta = 1). The force terms int_Gamma_C (1/gamma_h) [P_gamma(u)]_+ P_Thgamma(v) are then

    B^T (omega [C u - g]_+),        omega_q = w_q abs(J_f) / gamma_h,

w_q the reference weight and abs(J_f) the facet's Jacobian: the form's quadrature, summed in
another order. A step costs two sparse products and a max, without form assembly.

The rows come from the project's own UFL (the gap, n_c, gamma_h and sigma_n of each
contact), evaluated at the points by a compiled expression without arguments, and from
the Lagrange basis tabulated at the same points; the facet normal n, which a cell
expression cannot see, from the Jacobian: n = J^-T n_ref / norm(J^-T n_ref).
"""

from __future__ import annotations

import basix
import numpy as np
import ufl
from dolfinx import fem
from dolfinx.mesh import exterior_facet_indices
from petsc4py import PETSc

from ..common import compat
from ..physics.material import sigma_n
from .coercivity import constant_value

__all__ = ["QuadratureContact"]

#: The cell of a facet of each cell.
FACET_CELLS = {
    basix.CellType.triangle: basix.CellType.interval,
    basix.CellType.quadrilateral: basix.CellType.interval,
    basix.CellType.tetrahedron: basix.CellType.triangle,
    basix.CellType.hexahedron: basix.CellType.quadrilateral,
}


class QuadratureContact:
    """The force terms of ``contacts`` (obstacles that stand still, of ``problem``) as
    B^T (omega [C u - g]_+) on this rank's owned facets of their Gamma_C, in the local
    dofs (ghosts included: the caller adds them to their owners).

    Args:
        problem: The :class:`~nitsche_dolfinx.model.problem.ContactProblem`.
        contacts: Its contacts whose obstacles stand still (no contact pairs).
        u: The displacement the force is evaluated at; its array is read in place.
    """

    def __init__(self, problem, contacts, u: fem.Function):
        rows = [_contact_rows(problem, contact) for contact in contacts]
        C, B, gap, omega, dofs = (np.concatenate(part) for part in zip(*rows))
        size = u.x.array.size
        self._C = _local_matrix(C, dofs, size)
        rows = _local_matrix(B, dofs, size)
        self._Bt = rows.transpose(PETSc.Mat())  # B^T stored: its product is the faster
        rows.destroy()
        self._gap = gap.ravel()
        self._omega = omega.ravel()
        self._u = PETSc.Vec().createWithArray(u.x.array, comm=PETSc.COMM_SELF)
        self._force, self._points = self._C.createVecs()  # (columns, rows)
        #: The number of quadrature points of Gamma_C on this rank.
        self.points = self._gap.size

    def subtract(self, local: np.ndarray) -> None:
        """``local`` -= B^T (omega [C u - g]_+), ``local`` the array of the local dofs."""
        self._C.mult(self._u, self._points)
        p = self._points.array
        p -= self._gap
        np.maximum(p, 0.0, out=p)
        p *= self._omega
        self._Bt.mult(self._points, self._force)
        local -= self._force.array_r

    def destroy(self) -> None:
        """Free the PETSc objects (this rank's own: not collective)."""
        for obj in (self._C, self._Bt, self._u, self._points, self._force):
            obj.destroy()


def _contact_rows(problem, contact):
    """The rows of C and B at the quadrature points of the owned facets of ``contact``'s
    Gamma_C, (facets, points, dofs of a cell); g and omega, (facets, points); the cells'
    dofs, (facets, dofs of a cell)."""
    mesh, V = problem.mesh, problem.V
    gdim, bs = problem.gdim, V.dofmap.index_map_bs
    cell = getattr(basix.CellType, compat.cell_name(mesh))
    points, weights = _facet_quadrature(cell, mesh.topology.dim, problem.quadrature_degree)
    expression = _point_data(problem, contact, points)  # (compiled on every rank)
    cells, local_facets = _facets(mesh, problem, contact)
    per_facet, width = weights.size, compat.dofmap_array(V).shape[1] * bs
    if cells.size == 0:  # no facet of Gamma_C on this rank
        rows, points_only = np.zeros((0, per_facet, width)), np.zeros((0, per_facet))
        return rows, rows, points_only, points_only, np.zeros((0, width), dtype=np.int64)
    values = compat.evaluate(expression, mesh, cells, points.shape[0])
    # each facet's block of points: those of its local index
    blocks = local_facets[:, None] * per_facet + np.arange(per_facet)
    values = values[np.arange(cells.size)[:, None], blocks]  # (facets, points, values)
    gap, gamma_h, n_c = values[..., 0], values[..., 1], values[..., 2 : 2 + gdim]
    K, normal, scale = _facet_geometry(values[..., 2 + gdim :], gdim, cell, local_facets)
    stress = values[..., 2 + gdim + K.shape[-2] * gdim :].reshape(*gap.shape, gdim, gdim, gdim)
    element = basix.create_element(basix.ElementFamily.P, cell, compat.element_degree(V),
                                   basix.LagrangeVariant.gll_warped)  # fmt: skip
    table = element.tabulate(1, points)[..., 0][:, blocks]  # (1 + tdim, facets, points, dofs)
    grad = np.einsum("fqij,ifqd->fqjd", K, table[1:])  # physical gradients
    # sigma_n(phi_d e_k) = sum_j d_j phi_d sum_b S_kjb n_b, S_kjb = sigma_n(x_j e_k) for n = e_b
    traction = np.einsum("fqkjb,fqb->fqkj", stress, normal)
    normal_stress = np.einsum("fqjd,fqkj->fqdk", grad, traction)
    displacement = table[0][..., None] * n_c[:, :, None, :]  # u_n of phi_d e_k: (f, q, d, k)
    theta = constant_value(contact.nitsche_theta)
    shape = (*gap.shape, -1)  # a row per point, dof d * bs + k
    C = (displacement - gamma_h[..., None, None] * normal_stress).reshape(shape)
    B = (displacement - theta * gamma_h[..., None, None] * normal_stress).reshape(shape)
    omega = weights * scale / gamma_h
    block_dofs = compat.dofmap_array(V)[cells]
    dofs = (block_dofs[:, :, None] * bs + np.arange(bs)).reshape(cells.size, -1)
    return C, B, gap, omega, dofs


def _facet_geometry(values: np.ndarray, gdim: int, cell, local_facets: np.ndarray):
    """From the Jacobian J at each point (row-major, the first entries of ``values``, of
    shape (facets, points, ...)): its inverse K (tdim x gdim), the facet normal
    n = K^T n_ref / norm(K^T n_ref) and the facet's Jacobian determinant abs(J_f) (1 for a
    vertex), as the forms compute them."""
    reference_normals = basix.cell.facet_outward_normals(cell)[local_facets]
    tdim = reference_normals.shape[-1]
    J = values[..., : gdim * tdim].reshape(*values.shape[:2], gdim, tdim)
    K = np.linalg.pinv(J)
    normal = np.einsum("fqij,fi->fqj", K, reference_normals)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    if tdim == 1:
        return K, normal, np.ones(values.shape[:2])
    facet_jacobian = J @ basix.cell.facet_jacobians(cell)[local_facets][:, None]
    scale = np.sqrt(np.linalg.det(np.swapaxes(facet_jacobian, -1, -2) @ facet_jacobian))
    return K, normal, scale


def _facets(mesh, problem, contact):
    """The cells of the owned exterior facets of ``contact``'s Gamma_C and each facet's
    index in its cell: the facets its forms integrate over."""
    tdim = mesh.topology.dim
    tag = problem.contact_tags[problem.contacts.index(contact)]
    mesh.topology.create_connectivity(tdim - 1, tdim)
    mesh.topology.create_connectivity(tdim, tdim - 1)
    facets = np.intersect1d(problem.facets(tag), exterior_facet_indices(mesh.topology))
    facets = facets[facets < mesh.topology.index_map(tdim - 1).size_local]
    to_cells = mesh.topology.connectivity(tdim - 1, tdim)
    to_facets = mesh.topology.connectivity(tdim, tdim - 1)
    cells = np.array([to_cells.links(f)[0] for f in facets], dtype=np.int32)
    local = np.array([np.flatnonzero(to_facets.links(c) == f)[0] for c, f in zip(cells, facets)],
                     dtype=np.int64)  # fmt: skip
    return cells, local


def _facet_quadrature(cell, tdim: int, degree: int):
    """The forms' quadrature rule on a facet, its points mapped onto each facet of the
    reference cell in turn ((facets of a cell x points, tdim)), and its weights."""
    if tdim == 1:  # a facet is a vertex: one point, weight 1
        facet_points, weights = np.zeros((1, 0)), np.ones(1)
    else:
        facet_points, weights = basix.make_quadrature(FACET_CELLS[cell], degree)
    geometry = basix.geometry(cell)
    points = []
    for vertices in basix.topology(cell)[tdim - 1]:
        origin = geometry[vertices[0]]
        axes = geometry[vertices[1:tdim]] - origin  # (a quadrilateral's first two edges)
        points.append(origin + facet_points @ axes)
    return np.concatenate(points), np.asarray(weights)


def _point_data(problem, contact, points: np.ndarray) -> fem.Expression:
    """g, gamma_h, n_c, the Jacobian J (row-major) and the normal stress of the unit
    gradients sigma_n(sigma(x_j e_k)) for n = e_b (index k, j, b): every quantity of the
    rows but the basis, as the contact's own UFL writes them, at the reference ``points``."""
    mesh, gdim = problem.mesh, problem.gdim
    tdim = mesh.topology.dim
    x = ufl.SpatialCoordinate(mesh)
    J = ufl.Jacobian(mesh)
    unit = [ufl.as_vector([1.0 if i == b else 0.0 for i in range(gdim)]) for b in range(gdim)]
    stresses = []
    for k in range(gdim):
        for j in range(gdim):  # the displacement x_j e_k, of gradient e_k e_j^T
            field = ufl.as_vector([x[j] if i == k else 0.0 for i in range(gdim)])
            stresses += [sigma_n(contact.stress(field), e, contact.n_c) for e in unit]
    values = [contact.gap, contact.gamma_h, *(contact.n_c[i] for i in range(gdim)),
              *(J[i, j] for i in range(gdim) for j in range(tdim)), *stresses]  # fmt: skip
    return fem.Expression(ufl.as_vector(values), points)


def _local_matrix(rows: np.ndarray, dofs: np.ndarray, size: int) -> PETSc.Mat:
    """The sequential matrix of ``rows`` (facets, points, dofs of a cell) with the columns
    ``dofs`` (facets, dofs of a cell) of each facet's points, ``size`` columns."""
    facets, per_facet, width = rows.shape
    order = np.argsort(dofs, axis=1)
    columns = np.take_along_axis(dofs, order, axis=1)
    values = np.take_along_axis(rows, order[:, None, :], axis=2)
    indices = np.repeat(columns, per_facet, axis=0).astype(PETSc.IntType).ravel()
    pointer = np.arange(0, facets * per_facet * width + 1, width, dtype=PETSc.IntType)
    matrix = PETSc.Mat().createAIJ((facets * per_facet, size), comm=PETSc.COMM_SELF,
                                   csr=(pointer, indices, values.ravel()))  # fmt: skip
    matrix.assemble()
    return matrix
