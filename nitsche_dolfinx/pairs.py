"""Contact between two deformable bodies by Nitsche's method (docs/method.md section 11).

A pair is a slave surface Gamma_1 and a master surface Gamma_2, on one mesh (two bodies
may be disconnected parts of it). Each node of Gamma_1 is paired once, in the reference
configuration, with its closest point on Gamma_2 (:class:`Pairing`). That pairing is a
matrix T: (T u)(x_i) = u(pi(x_i)) at the slave nodes x_i, zero elsewhere, so that the
partner displacement on Gamma_1 is the interpolant of u o pi, a function of the same
space. The contact law is that of a rigid obstacle (:class:`~nitsche_dolfinx.contact.
NitscheContact`, the hybrid switch included) with

    u_n = (u - T u) . n_c,   g = (pi(x) - x) . n_c,   n_c = -(outer normal of Gamma_2 at pi(x)),

and the test projection P_Thgamma(v) = (v - T v) . n_c - Theta gamma_h sigma_n(v). The part
of the residual tested by T v is assembled as a vector G on the slave side and added as
T^T G; the Jacobian is exact: with w~ = T w the partner of the scheme's unknown,

    J = dF/dw + (dF/dw~) T + T^T (dG/dw) + T^T (dG/dw~) T.

The unbiased variant is two biased pairs, each surface slave in turn, each with weight 1/2.
"""

from __future__ import annotations

import basix
import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc
from ufl.algorithms import extract_coefficients

from . import compat
from .contact import NitscheContact

__all__ = ["CONTACT_PAIR_VARIANTS", "PairContact", "Pairing", "pair_halves"]

#: ``"unbiased"``: each surface slave in turn with weight 1/2; ``"biased"``: the first
#: surface is the slave, and only its stress enters.
CONTACT_PAIR_VARIANTS = ("unbiased", "biased")

_NEWTON_STEPS = 8  # Gauss-Newton steps of a closest-point projection onto a curved facet
_CANDIDATES = 6  # facets of Gamma_2 (nearest centroids) tried for each slave node
_ROUNDOFF = 1e-12  # a basis function's value below this at a partner point is a zero


def _basix_cell(mesh):
    return getattr(basix.CellType, compat.cell_name(mesh))


class _MasterSurface:
    """The facets of Gamma_2 whose cell this rank owns, with what a closest-point
    projection needs: the cell's geometry nodes and the facet's reference parametrisation
    X(xi) = X0 + E xi."""

    def __init__(self, V, facets: np.ndarray):
        mesh = V.mesh
        tdim, self.gdim = mesh.topology.dim, mesh.geometry.dim
        fdim = tdim - 1
        mesh.topology.create_connectivity(fdim, tdim)
        mesh.topology.create_connectivity(tdim, fdim)
        f2c, c2f = mesh.topology.connectivity(fdim, tdim), mesh.topology.connectivity(tdim, fdim)
        owned_cells = mesh.topology.index_map(tdim).size_local
        cell_type = _basix_cell(mesh)
        reference = basix.geometry(cell_type)
        facet_vertices = basix.topology(cell_type)[fdim]
        self.geometry_element = basix.create_element(
            basix.ElementFamily.P, cell_type, compat.geometry_degree(mesh),
            basix.LagrangeVariant.equispaced,
        )  # fmt: skip
        self.element = basix.create_element(
            basix.ElementFamily.P, cell_type, compat.element_degree(V),
            basix.LagrangeVariant.equispaced,
        )  # fmt: skip
        geometry = compat.geometry_dofmap(mesh)
        x = mesh.geometry.x[:, : self.gdim]
        self.cells, self.origins, self.edges, self.nodes = [], [], [], []
        for facet in facets:
            cell = int(f2c.links(facet)[0])
            if cell >= owned_cells:
                continue
            local = int(np.flatnonzero(c2f.links(cell) == facet)[0])
            vertices = reference[facet_vertices[local]]
            self.cells.append(cell)
            self.origins.append(vertices[0])
            self.edges.append((vertices[1:] - vertices[0]).T)  # (tdim, fdim)
            self.nodes.append(x[geometry[cell]])
        self.cells = np.asarray(self.cells, dtype=np.int32)
        self.centroids = np.array(
            [self._point(i, self._middle(i))[0] for i in range(len(self.cells))]
        ).reshape(-1, self.gdim)

    def _middle(self, i: int) -> np.ndarray:
        fdim = self.edges[i].shape[1]
        return np.full(fdim, 1.0 / (fdim + 1))

    def _point(self, i: int, xi: np.ndarray):
        """x(X(xi)) on facet i, and d x / d xi (gdim, fdim)."""
        X = self.origins[i] + self.edges[i] @ xi
        table = self.geometry_element.tabulate(1, X[None, :])[:, 0, :, 0]  # (1 + tdim, nodes)
        nodes = self.nodes[i]
        return table[0] @ nodes, (table[1:] @ nodes).T @ self.edges[i]

    def closest(self, points: np.ndarray, direction: np.ndarray | None = None):
        """For each point: the distance to the nearest facet of this rank (inf if none),
        that facet's index, the reference point X in its cell and the outer normal.

        With a unit ``direction`` d, the partner is where the line through the point along
        d meets the surface: the distance is then that of the line to the facet (zero
        where it meets it, plus a tie-break favouring the nearest meeting point), and the
        normal returned is -d."""
        count = len(points)
        distance = np.full(count, np.inf)
        facet = np.full(count, -1, dtype=np.int64)
        X = np.zeros((count, len(self.origins[0]) if len(self.cells) else 1))
        normal = np.zeros((count, self.gdim))
        if not len(self.cells):
            return distance, facet, X, normal
        across = np.eye(self.gdim)
        if direction is not None:  # only the offset across the line counts
            across = across - np.outer(direction, direction)
        offsets = (self.centroids[None, :, :] - points[:, None, :]) @ across
        candidates = np.argsort(np.linalg.norm(offsets, axis=2), axis=1)[:, :_CANDIDATES]
        for q, p in enumerate(points):
            for i in candidates[q]:
                xi, x = self._project(i, p, across)
                d = float(np.linalg.norm(across @ (x - p)))
                if direction is not None:
                    d += 1e-9 * abs(float(direction @ (x - p)))
                if d < distance[q]:
                    distance[q], facet[q] = d, i
                    X[q] = self.origins[i] + self.edges[i] @ xi
                    normal[q] = (
                        -direction if direction is not None else self._outer_normal(i, xi, x)
                    )
        return distance, facet, X, normal

    def _project(self, i: int, p: np.ndarray, across: np.ndarray):
        """The point of facet i closest to p, measured by ``across`` (the identity, or the
        projection across a line): Gauss-Newton in xi, kept in the facet."""
        xi = self._middle(i)
        x, tangent = self._point(i, xi)
        for _ in range(_NEWTON_STEPS if xi.size else 0):
            step = np.linalg.lstsq(across @ tangent, across @ (p - x), rcond=None)[0]
            xi = np.clip(xi + step, 0.0, None)
            if xi.sum() > 1.0:
                xi = xi / xi.sum()
            x, tangent = self._point(i, xi)
        return xi, x

    def _outer_normal(self, i: int, xi: np.ndarray, x: np.ndarray) -> np.ndarray:
        """The unit normal of facet i at x(xi), pointing out of its cell."""
        _, tangent = self._point(i, xi)
        if self.gdim == 1:
            normal = np.ones(1)
        elif self.gdim == 2:
            normal = np.array([tangent[1, 0], -tangent[0, 0]])
        else:
            normal = np.cross(tangent[:, 0], tangent[:, 1])
        inward = self.nodes[i].mean(axis=0) - x
        if normal @ inward > 0:
            normal = -normal
        return normal / np.linalg.norm(normal)


def _surface_nodes(V, facets: np.ndarray):
    """The owned nodes of ``V`` on ``facets`` and their coordinates (from the reference
    points of the element, mapped by the cell's geometry)."""
    mesh = V.mesh
    tdim, gdim = mesh.topology.dim, mesh.geometry.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    f2c = mesh.topology.connectivity(tdim - 1, tdim)
    nodes = fem.locate_dofs_topological(V, tdim - 1, facets)
    nodes = np.unique(nodes[nodes < V.dofmap.index_map.size_local])
    cell_type = _basix_cell(mesh)
    element = basix.create_element(
        basix.ElementFamily.P, cell_type, compat.element_degree(V),
        basix.LagrangeVariant.equispaced,
    )  # fmt: skip
    geometry_element = basix.create_element(
        basix.ElementFamily.P, cell_type, compat.geometry_degree(mesh),
        basix.LagrangeVariant.equispaced,
    )  # fmt: skip
    shape = geometry_element.tabulate(0, element.points)[0, :, :, 0]  # (points, nodes)
    dofmap, geometry = compat.dofmap_array(V), compat.geometry_dofmap(mesh)
    x = mesh.geometry.x[:, :gdim]
    coordinates = {}
    for facet in facets:
        cell = int(f2c.links(facet)[0])
        points = shape @ x[geometry[cell]]
        for node, point in zip(dofmap[cell], points):
            coordinates[int(node)] = point
    # an owned node may lie on facets of other ranks only (dolfinx finds it remotely):
    # its coordinates from a cell of this rank that has it
    missing = np.setdiff1d(nodes, np.fromiter(coordinates, dtype=nodes.dtype))
    for cell, position in zip(*np.nonzero(np.isin(dofmap, missing))):
        coordinates.setdefault(int(dofmap[cell, position]), shape[position] @ x[geometry[cell]])
    return nodes, np.array([coordinates[int(n)] for n in nodes]).reshape(-1, gdim)


class Pairing:
    """The pairing of the nodes of Gamma_1 (slave facets) with Gamma_2 (master facets), in
    the reference configuration, under MPI: with the closest point of Gamma_2 and its
    normal, or, given a unit ``direction`` d, with the point where the line through the
    node along d meets Gamma_2, and n_c = d.

    Attributes:
        T: The PETSc matrix (T u)(x_i) = u(pi(x_i)) at the slave nodes x_i (each
            component), zero rows elsewhere; on the layout of the vectors of ``V``.
        normal: n_c at the slave nodes (a Function of ``V``, zero elsewhere).
        gap_vector: pi(x_i) - x_i at the slave nodes (a Function of ``V``).
    """

    def __init__(self, V, slave_facets: np.ndarray, master_facets: np.ndarray, direction=None):
        mesh, comm = V.mesh, V.mesh.comm
        gdim = mesh.geometry.dim
        index_map, bs = V.dofmap.index_map, V.dofmap.index_map_bs
        nodes, coordinates = _surface_nodes(V, slave_facets)
        every_node = np.concatenate(comm.allgather(index_map.local_to_global(nodes)))
        every_point = np.vstack(comm.allgather(coordinates)).reshape(-1, gdim)
        master = _MasterSurface(V, master_facets)
        distance, facet, X, outer = master.closest(every_point, direction)
        # the rank with the nearest facet computes the node's row (the lowest on a tie)
        nearest = np.empty_like(distance)
        comm.Allreduce(distance, nearest, op=MPI.MIN)
        if not np.all(np.isfinite(nearest)):
            raise ValueError("the master surface of a contact pair has no facet")
        candidate = np.where(distance == nearest, comm.rank, comm.size).astype(np.int64)
        winner = np.empty_like(candidate)
        comm.Allreduce(candidate, winner, op=MPI.MIN)
        mine = np.flatnonzero(winner == comm.rank)

        size = (index_map.size_local * bs, index_map.size_global * bs)
        per_cell = master.element.dim
        self.T = PETSc.Mat().createAIJ((size, size), nnz=(per_cell, per_cell), comm=comm)
        self.T.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
        normal, gap = compat.create_vector(V), compat.create_vector(V)
        dofmap = compat.dofmap_array(V)
        for q in mine:
            cell = master.cells[facet[q]]
            values = master.element.tabulate(0, X[q][None, :])[0, 0, :, 0]
            # the basis functions of the nodes off the facet vanish on it, and at a node
            # all but one: round-off, left out so that T couples only the nodes it pairs
            kept = np.abs(values) > _ROUNDOFF
            values = values[kept]
            columns = index_map.local_to_global(dofmap[cell][kept].astype(np.int32))
            point = master._point(facet[q], self._xi(master, facet[q], X[q]))[0]
            rows = (every_node[q] * bs + np.arange(bs)).astype(PETSc.IntType)
            for component in range(bs):
                self.T.setValues(
                    rows[component], (columns * bs + component).astype(PETSc.IntType), values
                )
            normal.setValues(rows, -outer[q][:bs])
            gap.setValues(rows, (point - every_point[q])[:bs])
        self.T.assemble()
        self.normal, self.gap_vector = fem.Function(V), fem.Function(V)
        for vector, function in ((normal, self.normal), (gap, self.gap_vector)):
            vector.assemble()
            compat.petsc_vector(function).array[:] = vector.array
            function.x.scatter_forward()
            vector.destroy()

    @staticmethod
    def _xi(master: _MasterSurface, i: int, X: np.ndarray) -> np.ndarray:
        """The facet coordinates of the reference point X of facet i."""
        edges = master.edges[i]
        if not edges.size:
            return np.zeros(0)
        return np.linalg.lstsq(edges, X - master.origins[i], rcond=None)[0]

    def apply(self, source: fem.Function, target: fem.Function) -> None:
        """target = T source (the partner values at the slave nodes)."""
        self.T.mult(compat.petsc_vector(source), compat.petsc_vector(target))
        target.x.scatter_forward()

    def destroy(self) -> None:
        self.T.destroy()


class _PartnerSurface:
    """The master surface as seen from the slave nodes, behind the interface of a rigid
    obstacle (:mod:`nitsche_dolfinx.obstacles`): n_c and g interpolated from the nodes."""

    def __init__(self, pairing: Pairing):
        self.pairing = pairing

    def normal(self, x):
        return self.pairing.normal

    def gap(self, x):
        return ufl.dot(self.pairing.gap_vector, self.pairing.normal)


class PairContact(NitscheContact):
    """One biased half of a contact pair: Gamma_1 (``ds``) against its partner surface.

    The law is :class:`~nitsche_dolfinx.contact.NitscheContact`'s with the relative
    normal displacement (u - T u) . n_c, every term multiplied by ``weight`` (1/2 for
    each half of the unbiased variant). The part tested by the partner's displacement,
    :meth:`partner_term`, is assembled apart and added through T^T
    (:class:`PairCoupling`).

    Args:
        pairing: The :class:`Pairing` of Gamma_1 with Gamma_2.
        weight: 1 (biased) or 1/2 (a half of the unbiased variant).
        The others are those of :class:`~nitsche_dolfinx.contact.NitscheContact`.
    """

    def __init__(self, pairing, ds, stress, gamma_h, nitsche_theta, weight: float):
        super().__init__(_PartnerSurface(pairing), ds, stress, gamma_h, nitsche_theta)
        self.pairing = pairing
        self.weight = float(weight)
        self.partners: dict = {}  # Function -> its partner T f

    def track(self, functions) -> None:
        """Give each Function of the state (u, v, a and the unknown) a partner T f."""
        for function in functions:
            if function not in self.partners:
                self.partners[function] = fem.Function(function.function_space)

    def update(self, functions=None) -> None:
        """Recompute the partners of ``functions`` (default: of every tracked Function)."""
        for function in self.partners if functions is None else functions:
            self.pairing.apply(function, self.partners[function])

    def partner(self, expression):
        """The expression with every tracked Function f replaced by its partner T f."""
        replaced = ufl.replace(expression, self.partners)
        tracked = set(self.partners.values())
        for coefficient in extract_coefficients(replaced):
            space = getattr(coefficient, "function_space", None)
            if space is not None and space == self.pairing.normal.function_space:
                if coefficient not in tracked and coefficient not in self._surface():
                    raise ValueError(
                        f"contact pair: {coefficient} has no partner (not in the state)"
                    )
        return replaced

    def _surface(self):
        return (self.pairing.normal, self.pairing.gap_vector)

    # -- the law of NitscheContact with the partner -----------------------------------

    def normal_displacement(self, u):
        """(u - T u) . n_c (for the test function: v . n_c, see :meth:`test_projection`)."""
        return ufl.dot(u - self.partner(u), self.n_c)

    def test_projection(self, v):
        """v . n_c - Theta gamma_h sigma_n(v): the slave's part; the partner's is
        :meth:`partner_term`."""
        return ufl.dot(v, self.n_c) - self.nitsche_theta * self.gamma_h * self.sigma_n(v)

    def consistency_term(self, u, v):
        return self.weight * super().consistency_term(u, v)

    def contact_term(self, force, v):
        return self.weight * super().contact_term(force, v)

    def partner_term(self, force, v):
        """-weight int (1/gamma_h) force (T v) . n_c, with ``v`` standing for T v."""
        return -self.weight * force / self.gamma_h * ufl.dot(v, self.n_c) * self.ds

    def energy_correction(self, u):
        return self.weight * super().energy_correction(u)

    def force(self, u):
        return self.weight * super().force(u)

    def area(self, u):
        return self.weight * super().area(u)


def pair_halves(problem, tag_a: int, tag_b: int, variant: str, direction) -> list[PairContact]:
    """The biased halves of a contact pair of ``problem`` (a
    :class:`~nitsche_dolfinx.model.ContactProblem`) between the facets ``tag_a`` and
    ``tag_b``: one, slave ``tag_a``, with weight 1 (``"biased"``), or one per surface
    with weight 1/2 (``"unbiased"``); paired along the unit vector ``direction`` (from
    ``tag_a`` towards ``tag_b``; reversed for the other half) or, None, with closest
    points."""
    facets = {tag: problem.facets(tag) for tag in (tag_a, tag_b)}
    sides = [(tag_a, tag_b, direction)]
    if variant == "unbiased":
        sides.append((tag_b, tag_a, None if direction is None else -direction))
    weight = 1.0 if variant == "biased" else 0.5
    halves = []
    for slave, master, along in sides:
        pairing = Pairing(problem.V, facets[slave], facets[master], along)
        halves.append(
            PairContact(
                pairing,
                problem.ds(slave),
                problem.stress,
                problem.gamma_h,
                problem.nitsche_theta,
                weight,
            )  # fmt: skip
        )
    return halves
