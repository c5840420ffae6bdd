"""Contact between two deformable bodies by Nitsche's method (docs/method.md section 11).

A pair is a slave surface Gamma_1 and a master surface Gamma_2, on one mesh (two bodies
may be disconnected parts of it). Each node of Gamma_1 is paired with a point of Gamma_2
(:class:`Pairing`): its closest point, or where a line along a given direction meets
Gamma_2, found in the configuration of a displacement (the reference one at first, the
last converged step's when the surfaces have slid: :meth:`Pairing.slid`). That pairing is
a matrix T: (T u)(x_i) = u(pi(x_i)) at the slave nodes x_i, zero elsewhere, so that the
partner displacement on Gamma_1 is the interpolant of u o pi, a function of the same
space. The contact law is that of a rigid obstacle (:class:`~nitsche_dolfinx.contact.nitsche.
NitscheContact`, the hybrid switch included) with

    u_n = (u - T u) . n_c,   g = (X(pi(x)) - X(x)) . n_c,   n_c = -(outer normal of Gamma_2),

X the reference positions, the normal taken at pi(x). A slave node beyond an end of
Gamma_2 (closest points: its closest point on a side of its facet that no other facet
of Gamma_2 has, the node out across it) faces no point of Gamma_2 and has no partner:
it is its own (u - T u = 0), with a gap of a facet's size. The test projection is
P_Thgamma(v) = (v - T v) . n_c - Theta gamma_h sigma_n(v). The part of the residual
tested by T v is assembled as a vector G on the slave side and added as T^T G; within a
step T and n_c are fixed, and the Jacobian is exact for them: with w~ = T w the partner
of the scheme's unknown,

    J = dF/dw + (dF/dw~) T + T^T (dG/dw) + T^T (dG/dw~) T.

The unbiased variant is two biased pairs, each surface slave in turn, each with weight 1/2.
Coulomb friction acts on the relative slip velocity (u' - T u')_t, its partner part in G
(docs/method.md section 11, "Friction between bodies").
"""

from __future__ import annotations

import basix
import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc
from scipy.spatial import cKDTree
from ufl.algorithms import extract_coefficients

from ..common import compat
from .nitsche import NitscheContact

__all__ = ["CONTACT_PAIR_VARIANTS", "REPAIR_SLIP", "PairContact", "Pairing", "pair_halves"]

#: ``"unbiased"``: each surface slave in turn with weight 1/2; ``"biased"``: the first
#: surface is the slave, and only its stress enters.
CONTACT_PAIR_VARIANTS = ("unbiased", "biased")

#: A pairing is made again when a slave node near the master surface has slid along it,
#: since the last pairing, by more than this fraction of the size of the facet it is
#: paired with (docs/method.md section 11).
REPAIR_SLIP = 0.03

_NEWTON_STEPS = 12  # Newton steps of a closest-point projection onto a curved facet
_HALVINGS = 8  # halvings of a Newton step that does not bring the point nearer
_XI_TOLERANCE = 1e-13  # a Newton step below this (in facet coordinates) ends the projection
_LAST_STEP = 1e-8  # a Newton step below this is the last: the next would be round-off
_SMALL_STEP = 1e-6  # a Newton step below this is taken without comparing distances
_CANDIDATES = 6  # facets of Gamma_2 (nearest centroids) tried for each slave node
_SELF_CANDIDATES = 48  # for self-contact: the nearest ones are the node's own neighbours
_FACING = 0.5  # self-contact: a normal faces a node's own if n . n_own < -_FACING
_FLAT = 0.03  # self-contact: the surface turns where n . n_facet < 1 - _FLAT (14 degrees)
_BEYOND = 0.5  # self-contact: no partner this many facet sizes beyond the surface's end
_ROUNDOFF = 1e-12  # a basis function's value below this at a partner point is a zero
_NORMAL_BLEND = 1e-6  # closer than this share of a facet's size, its own normal counts


def _basix_cell(mesh):
    return getattr(basix.CellType, compat.cell_name(mesh))


def _lagrange(cell_type, degree: int):
    return basix.create_element(
        basix.ElementFamily.P, cell_type, degree, basix.LagrangeVariant.equispaced
    )


def _lowest_rank(comm, candidate: np.ndarray) -> np.ndarray:
    """For each entry, the lowest rank where ``candidate`` is True (comm.size if none)."""
    ranks = np.where(candidate, comm.rank, comm.size).astype(np.int64)
    lowest = np.empty_like(ranks)
    comm.Allreduce(ranks, lowest, op=MPI.MIN)
    return lowest


def _on_edge(xi: np.ndarray) -> np.ndarray:
    """Whether each point xi of a facet is on its edge or vertex (clamped there)."""
    return (np.min(xi, axis=1, initial=1.0) <= 0.0) | (xi.sum(axis=1) >= 1.0)


def _places(nodes: np.ndarray, wanted: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where each of ``wanted`` is in ``nodes`` (global indices, each once), and which of
    them are there at all."""
    order = np.argsort(nodes)
    place = np.minimum(np.searchsorted(nodes[order], wanted), len(nodes) - 1)
    found = nodes[order][place] == wanted
    return order[place], found


def _definite(m: np.ndarray) -> np.ndarray:
    """Whether each of a stack of 1x1 or 2x2 symmetric matrices is positive definite."""
    if m.shape[1] == 1:
        return m[:, 0, 0] > 0
    return (m[:, 0, 0] > 0) & (m[:, 0, 0] * m[:, 1, 1] - m[:, 0, 1] * m[:, 1, 0] > 0)


def _solve_small(matrix: np.ndarray, fallback: np.ndarray, right: np.ndarray) -> np.ndarray:
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


class _MasterSurface:
    """The facets of Gamma_2 whose cell this rank owns, as arrays over the facets: the
    cell, its geometry nodes and dofs, and the facet's reference parametrisation
    X(xi) = X0 + E xi; the surface is followed in the configuration of a displacement
    (:meth:`move`)."""

    def __init__(self, V, facets: np.ndarray):
        mesh, self.index_map = V.mesh, V.dofmap.index_map
        self._nodes_of_facets = None
        tdim, self.gdim = mesh.topology.dim, mesh.geometry.dim
        fdim = tdim - 1
        mesh.topology.create_connectivity(fdim, tdim)
        mesh.topology.create_connectivity(tdim, fdim)
        f2c, c2f = mesh.topology.connectivity(fdim, tdim), mesh.topology.connectivity(tdim, fdim)
        owned_cells = mesh.topology.index_map(tdim).size_local
        cell_type = _basix_cell(mesh)
        reference = basix.geometry(cell_type)
        facet_vertices = basix.topology(cell_type)[fdim]
        self.geometry_element = _lagrange(cell_type, compat.geometry_degree(mesh))
        self.element = _lagrange(cell_type, compat.element_degree(V))
        # the same element of degree 1 or 2 (nodes in one order): a displaced point is one
        # sum over the displaced nodes
        self._one_element = compat.geometry_degree(mesh) == compat.element_degree(V) <= 2
        # the second derivatives of the basis functions in the order (i, j) of d2/dXi dXj
        unit = np.eye(tdim, dtype=int)
        self._second = np.array(
            [[basix.index(*(unit[i] + unit[j])) for j in range(tdim)] for i in range(tdim)]
        )
        cells, origins, edges = [], [], []
        self._locals = []  # each facet's index among its cell's facets
        vertex_dofs = [int(self.element.entity_dofs[0][v][0]) for v in range(len(reference))]
        self._vertex_dofs = []  # each facet's vertices, as dofs of its cell, in xi's order
        for facet in facets:
            cell = int(f2c.links(facet)[0])
            if cell >= owned_cells:
                continue
            local = int(np.flatnonzero(c2f.links(cell) == facet)[0])
            vertices = reference[facet_vertices[local]]
            cells.append(cell)
            self._locals.append(local)
            self._vertex_dofs.append([vertex_dofs[v] for v in facet_vertices[local]])
            origins.append(vertices[0])
            edges.append((vertices[1:] - vertices[0]).T)  # (tdim, fdim)
        count = len(cells)
        self.cells = np.asarray(cells, dtype=np.int32)
        self.origins = np.asarray(origins, dtype=float).reshape(count, tdim)
        self.edges = np.asarray(edges, dtype=float).reshape(count, tdim, fdim)
        self.nodes = mesh.geometry.x[:, : self.gdim][compat.geometry_dofmap(mesh)[self.cells]]
        self.dofs = compat.dofmap_array(V)[self.cells]  # (facets, dofs of a cell), blocked
        self.bs = V.dofmap.index_map_bs
        self.shift, self._displaced = None, None
        # the size of each facet: its longest edge (its length in 1D: none, 1)
        corners = [self.points(np.arange(count), corner)[0] for corner in self._corners(fdim)]
        self.size = np.ones(count)
        if fdim:
            self.size = np.max(
                [np.linalg.norm(a - b, axis=1) for a in corners for b in corners], axis=0
            )
        self.move(None)

    @staticmethod
    def _corners(fdim: int) -> list[np.ndarray]:
        """The facet coordinates xi of the vertices of a simplex facet."""
        return [np.zeros(fdim)] + [np.eye(fdim)[k] for k in range(fdim)]

    def move(self, u: np.ndarray | None) -> None:
        """Follow the surface displaced by ``u`` (the local values of a Function of the
        displacement space, ghosts included; None: the reference configuration)."""
        self.shift, self._displaced = None, None
        if u is not None:
            self.shift = u.reshape(-1, self.bs)[self.dofs][..., : self.gdim]
            if self._one_element:
                self._displaced = self.nodes + self.shift
        fdim = self.edges.shape[2]
        middle = np.full((len(self.cells), fdim), 1.0 / (fdim + 1))
        self.centroids = self.points(np.arange(len(self.cells)), middle)[0]
        centres = self.nodes.mean(axis=1)
        if self.shift is not None:
            centres = centres + self.shift.mean(axis=1)
        self.centres = centres  # a point inside each (displaced) cell

    def points(self, facet: np.ndarray, xi: np.ndarray, displaced: bool = True, second=False):
        """The points x(X(xi)) of the ``facet`` (an index per point; ``xi`` (points, fdim),
        or one xi for all), displaced unless told otherwise, and dx/dxi (points, gdim,
        fdim); with ``second``, also d2x/dxi2 (points, gdim, fdim, fdim)."""
        fdim, tdim = self.edges.shape[2], self.edges.shape[1]
        if not len(facet):  # (basix tabulates no empty set of points)
            empty = np.zeros((0, self.gdim, fdim))
            return (np.zeros((0, self.gdim)), empty, np.zeros((0, self.gdim, fdim, fdim)))[
                : 3 if second else 2
            ]
        xi = np.broadcast_to(xi, (len(facet), fdim))
        edges = self.edges[facet]
        X = self.reference_point(facet, xi)
        order = 2 if second else 1
        sources = [(self.geometry_element, self.nodes[facet])]
        if displaced and self._displaced is not None:
            sources = [(self.geometry_element, self._displaced[facet])]
        elif displaced and self.shift is not None:
            sources.append((self.element, self.shift[facet]))
        x, jacobian, hessian = 0.0, 0.0, 0.0
        for element, values in sources:
            table = element.tabulate(order, X)[..., 0]  # (derivatives, points, nodes)
            x = x + np.einsum("nk,nkd->nd", table[0], values)
            jacobian = jacobian + np.einsum("jnk,nkd->ndj", table[1 : 1 + tdim], values)
            if second:
                hessian = hessian + np.einsum("ijnk,nkd->ndij", table[self._second], values)
        tangent = np.einsum("ndj,njf->ndf", jacobian, edges)
        if not second:
            return x, tangent
        half = np.einsum("ndij,nif->ndfj", hessian, edges)
        return x, tangent, np.einsum("ndfj,njg->ndfg", half, edges)

    def reference_point(self, facet: np.ndarray, xi: np.ndarray) -> np.ndarray:
        """The reference-cell coordinates X(xi) of the points."""
        return self.origins[facet] + np.einsum("nij,nj->ni", self.edges[facet], xi)

    def _candidates(
        self, points: np.ndarray, direction: np.ndarray | None, exhaustive: bool = False,
        wanted: int = _CANDIDATES,
    ) -> np.ndarray:  # fmt: skip
        """For each point, the facets with the nearest centroids (measured across the line
        along ``direction``, if given): a k-d tree search, n log n; ``exhaustive``: every
        facet (the reference the search is checked by)."""
        count = len(self.cells) if exhaustive else min(wanted, len(self.cells))
        centroids = self.centroids
        if direction is not None:  # coordinates across the line
            basis = np.linalg.svd(np.eye(self.gdim) - np.outer(direction, direction))[0]
            basis = basis[:, : self.gdim - 1]
            centroids, points = centroids @ basis, points @ basis
        if exhaustive or not centroids.shape[1]:  # (1D along the line: all as near)
            return np.broadcast_to(np.arange(count), (len(points), count))
        _, nearest = cKDTree(centroids).query(points, k=count)
        return np.asarray(nearest).reshape(len(points), count)

    def closest(
        self, points: np.ndarray, direction: np.ndarray | None = None, exhaustive=False,
        facing=None,
    ):  # fmt: skip
        """For each point: the distance to the nearest facet of this rank (inf if none),
        that facet's index, its facet coordinates xi there, and the outer normal.

        With a unit ``direction`` d, the partner is where the line through the point along
        d meets the surface: the distance is then that of the line to the facet (zero
        where it meets it, plus a tie-break favouring the nearest meeting point), and the
        normal returned is -d. ``facing``: self-contact, ``(outward, nodes, size)`` for
        the points: their own outer normals, global node indices and facet sizes; only
        facets facing the point count (:meth:`_facing`)."""
        fdim = self.edges.shape[2]
        distance = np.full(len(points), np.inf)
        facet = np.full(len(points), -1, dtype=np.int64)
        xi = np.zeros((len(points), fdim))
        normal = np.zeros((len(points), self.gdim))
        if not len(self.cells) or not len(points):
            return distance, facet, xi, normal
        across = np.eye(self.gdim)
        if direction is not None:  # only the offset across the line counts
            across = across - np.outer(direction, direction)
        count = _SELF_CANDIDATES if facing is not None else _CANDIDATES
        candidates = self._candidates(points, direction, exhaustive, count)
        tried = candidates.ravel()
        targets = np.repeat(points, candidates.shape[1], axis=0)
        xi_tried, x = self._project(tried, targets, across)
        offset = x - targets
        length = np.linalg.norm(offset @ across, axis=1)
        if direction is not None:
            length += 1e-9 * np.abs(offset @ direction)
        if facing is not None:
            per_point = candidates.shape[1]
            own = [np.repeat(part, per_point, axis=0) for part in facing[:2]]
            length[~self._facing(tried, xi_tried, x, targets, *own)] = np.inf
        best = np.argmin(length.reshape(candidates.shape), axis=1)  # the first on a tie
        chosen = np.arange(len(points)) * candidates.shape[1] + best
        distance, facet, xi = length[chosen], tried[chosen], xi_tried[chosen]
        if direction is not None:
            normal[:] = -direction
        else:
            sides = None if facing is None else facing[:2]
            normal = self._closest_normal(facet, xi, x[chosen], points, sides)
        return distance, facet, xi, normal

    def open_sides(self, comm) -> np.ndarray:
        """Which sides of each facet are an end of the surface: (facets, fdim + 1), side k
        the one opposite the facet's vertex k (where its barycentric coordinate lambda_k
        vanishes: lambda_0 = 1 - sum(xi), lambda_k = xi_k), an end where no other facet of
        the surface has it (a vertex of a curve, an edge of a surface); collective."""
        fdim, count = self.edges.shape[2], len(self.cells)
        if not fdim:  # (1D: the surface is a point, it has no sides)
            return np.zeros((count, 1), dtype=bool)
        dofs = np.asarray(self._vertex_dofs, dtype=np.int64).reshape(count, fdim + 1)
        local = np.take_along_axis(self.dofs, dofs, axis=1).astype(np.int32).ravel()
        vertices = self.index_map.local_to_global(local).reshape(count, fdim + 1)
        sides = np.sort(
            np.stack([np.delete(vertices, k, axis=1) for k in range(fdim + 1)], axis=1), axis=2
        )  # (facets, fdim + 1, fdim): each side by its vertices' global indices
        every = np.concatenate(comm.allgather(sides.reshape(-1, fdim)))
        keys, counts = np.unique(every, axis=0, return_counts=True)
        once = {tuple(key) for key in keys[counts == 1]}
        return np.array([tuple(side) in once for side in sides.reshape(-1, fdim)],
                        dtype=bool).reshape(count, fdim + 1)  # fmt: skip

    def beyond_open_side(self, facet, xi, points, open_sides) -> np.ndarray:
        """Whether each point lies beyond an end of the surface: its closest point x(xi) is
        on a side of the facet that is an end (``open_sides``, :meth:`open_sides`), and the
        point's offset from it, along the facet's tangent plane, leads out across that
        side by more than :data:`_NORMAL_BLEND` of the facet (the barycentric coordinate
        of the opposite vertex, continued linearly to the point's tangential offset, is
        below -_NORMAL_BLEND). Such a point faces no point of the surface (docs/method.md
        section 11)."""
        if not len(facet) or not xi.shape[1]:  # (1D: a point has no sides)
            return np.zeros(len(facet), dtype=bool)
        x, tangent = self.points(facet, xi)
        metric = np.einsum("ndf,ndg->nfg", tangent, tangent)
        step = _solve_small(metric, metric, np.einsum("ndf,nd->nf", tangent, points - x))
        reach = xi + step
        barycentric = np.hstack([1.0 - reach.sum(axis=1, keepdims=True), reach])
        out = open_sides[facet] & (barycentric < -_NORMAL_BLEND)
        return _on_edge(xi) & out.any(axis=1)

    def facet_normals(self, facet: np.ndarray, xi: np.ndarray) -> np.ndarray:
        """The facets' own outer normals at their points xi (in the current configuration)."""
        return self._outer_normal(facet, xi, self.points(facet, xi)[0])

    def own_normals(self, nodes: np.ndarray):
        """For nodes of the surface itself (global indices of ``index_map``): the sum of
        the outer normals of this rank's facets through each, at the node (zero if none),
        and the size of the largest of them."""
        normal, size = np.zeros((len(nodes), self.gdim)), np.zeros(len(nodes))
        if not len(self.cells) or not len(nodes):
            return normal, size
        facet, xi, node = self._facet_nodes()
        place, found = _places(nodes, node.ravel())
        place = place[found]
        facet = np.repeat(facet, node.shape[1])[found]
        xi = xi.reshape(-1, xi.shape[-1])[found]
        at = self.points(facet, xi)[0]
        np.add.at(normal, place, self._outer_normal(facet, xi, at))
        np.maximum.at(size, place, self.size[facet])
        return normal, size

    def _facet_nodes(self):
        """Each facet's nodes: the facets (0, 1, ...), the nodes' facet coordinates
        (facets, nodes, fdim) and global indices (facets, nodes); computed once."""
        if self._nodes_of_facets is None:
            closure = self.element.entity_closure_dofs[self.edges.shape[2]]
            xi, node = [], []
            for i, local in enumerate(self._locals):
                dofs = closure[local]
                on = self.element.points[dofs] - self.origins[i]  # (the dofs' points, in xi)
                xi.append(np.linalg.lstsq(self.edges[i], on.T, rcond=None)[0].T)
                node.append(self.dofs[i][dofs])
            node = self.index_map.local_to_global(np.concatenate(node).astype(np.int32))
            self._nodes_of_facets = (
                np.arange(len(self.cells)),
                np.array(xi),
                node.reshape(len(self.cells), -1),
            )
        return self._nodes_of_facets

    def _facing(self, facet, xi, x, points, outward, node) -> np.ndarray:
        """Self-contact: whether the point x of each facet is a partner for its point,
        the node ``node`` whose own outer normal is ``outward``: the facet faces it
        (their normals more than opposite: n . n_own < -1/2), x is in front of it (less
        than the facet's size behind its tangent plane), and the facet is not one of the
        node's own (the surface near a node faces it only at a sharp concave corner)."""
        normal = self._outer_normal(facet, xi, x)
        opposite = np.einsum("nd,nd->n", normal, outward) < -_FACING
        front = np.einsum("nd,nd->n", x - points, outward) > -self.size[facet]
        own = (self._facet_nodes()[2][facet] == node[:, None]).any(axis=1)
        return opposite & front & ~own

    def _closest_normal(self, facet, xi, partner: np.ndarray, points: np.ndarray, sides=None):
        """The outer normal of Gamma_2 seen from each point: the facet's own where the
        closest point is inside the facet; where it is on the facet's edge or vertex,
        along the line from the point to it (outward: away from the point outside the
        body, towards it inside), which turns continuously around the edge or vertex
        from one facet's normal to the next (the facets' own normals jump there, and
        round-off picks the facet among equally near ones). Within round-off of the
        surface, where that line has no direction, the facet's normal, blended in over a
        millionth of the facet's size. ``sides``: self-contact, ``(outward, nodes)``, the
        outer normals at the surface's nodes (:meth:`_surface_turns`): where the surface
        does not turn at the edge (it ends there, or goes on in the facet's plane), the
        facet's normal, the plane going on past the edge; where it turns, outside or
        inside by the surface's normal at the facet's node nearest to the closest point."""
        own = self._outer_normal(facet, xi, partner)
        on_edge = _on_edge(xi)
        line = partner - points
        length = np.linalg.norm(line, axis=1)
        side, turns = own, on_edge
        if sides is not None:
            turns, surface = self._surface_turns(facet, xi, own, sides)
            turns &= on_edge
            side = np.where(on_edge[:, None], surface, own)
        outside = np.einsum("nd,nd->n", line, side) <= 0
        along = np.where(outside, -1.0, 1.0)[:, None] * line / np.maximum(length, 1e-300)[:, None]
        weight = np.clip(length / (_NORMAL_BLEND * self.size[facet]), 0.0, 1.0) * turns
        normal = weight[:, None] * along + (1.0 - weight[:, None]) * own
        return normal / np.linalg.norm(normal, axis=1, keepdims=True)

    def _surface_turns(self, facet, xi, own, sides):
        """Self-contact: whether the surface turns at the points xi of the facets (its
        normal at the facet's node nearest to xi, from ``sides`` = ``(outward, nodes)``,
        differs from the facet's own normal ``own``), and that normal. On a flat part of
        the surface and at its end, where the surface's normal is that of its last facet,
        it does not."""
        outward, nodes = sides
        _, node_xi, node_ids = self._facet_nodes()
        nearest = np.argmin(np.linalg.norm(node_xi[facet] - xi[:, None], axis=2), axis=1)
        surface = outward[_places(nodes, node_ids[facet, nearest])[0]]
        return np.einsum("nd,nd->n", surface, own) < 1.0 - _FLAT, surface

    def beyond_end(self, facet, xi, points, sides) -> np.ndarray:
        """Self-contact: whether each point is beyond the end of the surface, its closest
        point on an edge of the facet where the surface does not turn
        (:meth:`_surface_turns`), farther than :data:`_BEYOND` times the facet's size
        from it along the facet (not across: in contact, across is the penetration)."""
        if not len(facet):
            return np.zeros(0, dtype=bool)
        partner = self.points(facet, xi)[0]
        own = self._outer_normal(facet, xi, partner)
        on_edge = _on_edge(xi)
        turns = self._surface_turns(facet, xi, own, sides)[0]
        offset = points - partner
        along = offset - np.einsum("nd,nd->n", offset, own)[:, None] * own
        far = np.linalg.norm(along, axis=1) > _BEYOND * self.size[facet]
        return on_edge & ~turns & far

    def _project(self, facet: np.ndarray, targets: np.ndarray, across: np.ndarray):
        """The points of the facets closest to the targets, measured by ``across`` (the
        identity, or the projection across a line): Newton's method on the squared
        distance in xi, with its curvature term (Gauss-Newton where the Hessian is not
        positive definite) and halved steps where a step does not bring the point nearer,
        kept in the facet; each point until its step is below round-off. Returns xi and
        the points."""
        fdim = self.edges.shape[2]
        xi = np.full((len(facet), fdim), 1.0 / (fdim + 1))
        x, tangent, curvature = self.points(facet, xi, second=True)
        active = np.arange(len(facet)) if fdim else np.zeros(0, dtype=np.int64)
        for _ in range(_NEWTON_STEPS):
            if not active.size:
                break
            offset = (x[active] - targets[active]) @ across  # (``across`` is symmetric)
            t = tangent[active]
            gradient = np.einsum("ndf,nd->nf", t, offset)
            gauss_newton = np.einsum("ndf,dg->nfg", t, across) @ t
            hessian = gauss_newton + np.einsum("nd,ndfg->nfg", offset, curvature[active])
            step = -_solve_small(hessian, gauss_newton, gradient)
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
                new = self.points(facet[trying], trial, second=True)
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

    def _outer_normal(self, facet: np.ndarray, xi: np.ndarray, x: np.ndarray) -> np.ndarray:
        """The unit normals of the facets at x(xi), pointing out of their cells."""
        _, tangent = self.points(facet, xi)
        if self.gdim == 1:
            normal = np.ones((len(facet), 1))
        elif self.gdim == 2:
            normal = np.stack([tangent[:, 1, 0], -tangent[:, 0, 0]], axis=1)
        else:
            normal = np.cross(tangent[:, :, 0], tangent[:, :, 1])
        inward = np.einsum("nd,nd->n", normal, self.centres[facet] - x) > 0
        normal[inward] *= -1.0
        return normal / np.linalg.norm(normal, axis=1, keepdims=True)


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


def _edge_nodes(V, facets: np.ndarray, comm) -> np.ndarray:
    """The nodes inside the edges of ``facets`` (P2: each edge's midpoint), each with the
    two vertices of its edge: rows (node, vertex, vertex) of global indices, those of
    every rank; none for P1 or in 1D (collective)."""
    mesh = V.mesh
    tdim = mesh.topology.dim
    fdim = tdim - 1
    cell_type = _basix_cell(mesh)
    element = _lagrange(cell_type, compat.element_degree(V))
    rows = []
    if fdim >= 1 and any(len(dofs) for dofs in element.entity_dofs[1]):
        topology = basix.topology(cell_type)
        f2c, c2f = mesh.topology.connectivity(fdim, tdim), mesh.topology.connectivity(tdim, fdim)
        vertex = [int(element.entity_dofs[0][v][0]) for v in range(len(topology[0]))]
        dofmap = compat.dofmap_array(V)
        for facet in facets:
            cell = int(f2c.links(facet)[0])
            local = int(np.flatnonzero(c2f.links(cell) == facet)[0])
            corners = set(topology[fdim][local])
            for edge, ends in enumerate(topology[1]):
                if set(ends) <= corners:
                    for dof in element.entity_dofs[1][edge]:
                        rows.append(dofmap[cell][[dof, vertex[ends[0]], vertex[ends[1]]]])
    local = np.asarray(rows, dtype=np.int32).reshape(-1)
    rows = V.dofmap.index_map.local_to_global(local).reshape(-1, 3)
    every = np.concatenate(comm.allgather(rows.astype(np.int64))).reshape(-1, 3)
    return np.unique(every, axis=0)


class Pairing:
    """The pairing of the nodes of Gamma_1 (slave facets) with Gamma_2 (master facets),
    under MPI: with the closest point of Gamma_2 and its normal (none beyond an end of
    Gamma_2: :meth:`_MasterSurface.beyond_open_side`), or, given a unit
    ``direction`` d, with the point where the line through the node along d meets Gamma_2,
    and n_c = d. Made in the reference configuration, and again by :meth:`pair` in that of
    a displacement (when the surfaces have slid, :meth:`slid`).

    Attributes:
        T: The PETSc matrix (T u)(x_i) = u(pi(x_i)) at the slave nodes x_i (each
            component), zero rows elsewhere; on the layout of the vectors of ``V``. A new
            matrix at each pairing.
        normal: n_c at the slave nodes (a Function of ``V``, zero elsewhere).
        gap_vector: X(pi(x_i)) - X(x_i) at the slave nodes, X the reference positions (a
            Function of ``V``).
        displacement: The displacement the pairing was made in (a Function of ``V``).
        generation: The number of pairings made so far.
    """

    def __init__(self, V, slave_facets: np.ndarray, master_facets: np.ndarray, direction=None):
        self.V, self.direction = V, direction
        comm, gdim = V.mesh.comm, V.mesh.geometry.dim
        #: A surface paired with itself: each node with the nearest point of the surface
        #: that faces it, away from its own neighbourhood (:meth:`_MasterSurface._facing`).
        self.self_contact = np.array_equal(np.sort(slave_facets), np.sort(master_facets))
        self._nodes, self._positions = _surface_nodes(V, slave_facets)
        # the slave nodes of every rank, which each rank projects: the same at each pairing
        global_nodes = V.dofmap.index_map.local_to_global(self._nodes)
        self._every_node = np.concatenate(comm.allgather(global_nodes))
        self._every_position = np.vstack(comm.allgather(self._positions)).reshape(-1, gdim)
        self._master = _MasterSurface(V, master_facets)
        # the ends of Gamma_2, beyond which a node paired by closest points faces nothing
        self._open_sides, self._edge_nodes = None, None
        if direction is None and not self.self_contact:
            self._open_sides = self._master.open_sides(comm)
            self._edge_nodes = _edge_nodes(V, slave_facets, comm)
        self.normal, self.gap_vector = fem.Function(V), fem.Function(V)
        self.displacement = fem.Function(V)
        self._scale = fem.Function(V)  # the size of each slave node's partner facet
        self._partner_work = compat.create_vector(V)  # work: T u
        self.T = None
        self.generation = 0
        self.pair()

    def pair(self, u: fem.Function | None = None, exhaustive: bool = False) -> None:
        """Pair the surfaces in the configuration displaced by ``u`` (None: the reference
        one), each slave node with every facet of Gamma_2 if ``exhaustive`` (the reference
        of the search); collective."""
        V, comm = self.V, self.V.mesh.comm
        gdim, bs = V.mesh.geometry.dim, V.dofmap.index_map_bs
        index_map = V.dofmap.index_map
        if u is None:
            self.displacement.x.array[:] = 0.0
        else:
            self.displacement.x.array[:] = u.x.array
        moved = None if u is None else self.displacement.x.array
        if moved is not None:
            points = self._positions + moved.reshape(-1, bs)[self._nodes][:, :gdim]
        every_node, every_position = self._every_node, self._every_position
        every_point = every_position
        if moved is not None:
            every_point = np.vstack(comm.allgather(points)).reshape(-1, gdim)
        master = self._master
        master.move(moved)
        facing = self._own_sides(every_node) if self.self_contact else None
        distance, facet, xi, outer = master.closest(every_point, self.direction, exhaustive, facing)
        # the rank with the nearest facet computes the node's row (the lowest on a tie)
        nearest = np.empty_like(distance)
        comm.Allreduce(distance, nearest, op=MPI.MIN)
        paired = np.isfinite(nearest)
        if not self.self_contact and not paired.all():
            raise ValueError("the master surface of a contact pair has no facet")
        winner = _lowest_rank(comm, paired & (distance == nearest))
        mine = np.flatnonzero(winner == comm.rank)
        alone = np.zeros(0, dtype=np.int64)  # the nodes without a partner that this rank writes
        if self.self_contact:
            beyond = master.beyond_end(facet[mine], xi[mine], every_point[mine], facing[:2])
            mine, alone = self._alone(mine, paired, outer, facing[0], beyond)
            outward, _, size = facing
            alone_normal, alone_size = outward[alone], size[alone]
        elif self._open_sides is not None:  # beyond an end of Gamma_2: no partner
            beyond = master.beyond_open_side(
                facet[mine], xi[mine], every_point[mine], self._open_sides
            )
            beyond = self._beyond_with_edges(mine, beyond)
            alone, mine = mine[beyond], mine[~beyond]
            # the facet's own normal: the plane of the surface going on past its end
            alone_normal = -master.facet_normals(facet[alone], xi[alone])
            alone_size = master.size[facet[alone]]
        facet, xi = facet[mine], xi[mine]

        # T's rows: the basis functions of the partner's cell at the partner point; those
        # of the nodes off the facet vanish on it, and at a node all but one: round-off,
        # left out so that T couples only the nodes it pairs
        values = np.zeros((0, master.element.dim))
        if len(mine):  # (basix tabulates no empty set of points)
            values = master.element.tabulate(0, master.reference_point(facet, xi))[0, :, :, 0]
        kept = np.abs(values) > _ROUNDOFF
        owner = np.repeat(np.arange(len(mine)), kept.sum(axis=1))  # of each kept value
        columns = index_map.local_to_global(master.dofs[facet][kept].astype(np.int32))
        component = np.arange(bs)
        order = np.argsort((owner[:, None] * bs + component).ravel(), kind="stable")
        columns = (columns[:, None] * bs + component).ravel()[order]
        entries = np.repeat(values[kept], bs)[order]
        rows = (every_node[mine][:, None] * bs + component).ravel()
        indptr = np.concatenate([[0], np.cumsum(np.repeat(kept.sum(axis=1), bs))])
        size = (index_map.size_local * bs, index_map.size_global * bs)
        per_cell = master.element.dim
        T = PETSc.Mat().createAIJ((size, size), nnz=(per_cell, per_cell), comm=comm)
        T.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
        T.setValuesIJV(
            indptr.astype(PETSc.IntType), columns.astype(PETSc.IntType), entries,
            PETSc.InsertMode.INSERT_VALUES, rows.astype(PETSc.IntType),
        )  # fmt: skip
        partner = master.points(facet, xi, displaced=False)[0]  # its reference position
        normal, gap = -outer[mine], partner - every_position[mine]
        scale = master.size[facet]
        if len(alone):
            lonely = (every_node[alone][:, None] * bs + component).ravel()
            T.setValuesIJV(  # each its own partner: u - T u = 0, a gap of a facet's size
                np.arange(len(lonely) + 1, dtype=PETSc.IntType), lonely.astype(PETSc.IntType),
                np.ones(len(lonely)), PETSc.InsertMode.INSERT_VALUES,
                lonely.astype(PETSc.IntType),
            )  # fmt: skip
            rows = np.concatenate([rows, lonely])
            normal = np.vstack([normal, alone_normal])
            gap = np.vstack([gap, alone_size[:, None] * alone_normal])
            scale = np.concatenate([scale, alone_size])
        T.assemble()
        if self.T is not None:
            self.T.destroy()
        self.T = T
        nodal = {
            self.normal: normal[:, :bs],
            self.gap_vector: gap[:, :bs],
            self._scale: np.repeat(scale[:, None], bs, axis=1),
        }
        for function, value in nodal.items():
            vector = compat.create_vector(V)
            vector.setValues(rows.astype(PETSc.IntType), np.ascontiguousarray(value).ravel())
            vector.assemble()
            compat.petsc_vector(function).array[:] = vector.array
            function.x.scatter_forward()
            vector.destroy()
        self._paired_relative = self._relative(self.displacement)
        self.generation += 1

    def _beyond_with_edges(self, mine: np.ndarray, beyond: np.ndarray) -> np.ndarray:
        """Of the nodes this rank paired (``mine``), those without a partner: those
        ``beyond`` an end of Gamma_2 and, for P2, the midpoints of the edges of Gamma_1
        with such a vertex (collective). A gap g at a vertex without a partner and nearly
        0 at the rest of its facet would interpolate to -g/8 at 3/4 of its edge (the
        vertex's basis function there); with the midpoint g too, it interpolates to
        g (1 - phi), phi <= 1 the basis functions of the nodes with partners
        (docs/method.md section 11)."""
        if not len(self._edge_nodes):
            return beyond
        lonely = np.zeros(len(self._every_node), dtype=np.int8)
        lonely[mine[beyond]] = 1
        self.V.mesh.comm.Allreduce(MPI.IN_PLACE, lonely, op=MPI.MAX)
        place = _places(self._every_node, self._edge_nodes.ravel())[0].reshape(-1, 3)
        ends = (lonely[place[:, 1]] == 1) | (lonely[place[:, 2]] == 1)
        lonely[place[ends, 0]] = 1
        return lonely[mine] == 1

    def _alone(self, mine: np.ndarray, paired, outer: np.ndarray, outward, beyond):
        """Self-contact: of the nodes this rank paired (``mine``), those whose contact
        normal faces them, and the nodes without a partner that this rank is to write:
        those no facet faces (by the rank they come from), and those of ``mine`` whose
        nearest point is seen at a glancing angle (the line to an edge where the surface
        turns does not face the node) or is ``beyond`` the surface's end
        (docs/method.md section 11)."""
        comm = self.V.mesh.comm
        origin = np.repeat(np.arange(comm.size), comm.allgather(len(self._nodes)))
        faces = np.einsum("nd,nd->n", outer[mine], outward[mine]) < -_FACING
        faces &= ~beyond
        alone = np.flatnonzero(~paired & (origin == comm.rank))
        return mine[faces], np.concatenate([alone, mine[~faces]])

    def _own_sides(self, nodes: np.ndarray):
        """Self-contact: each node's own outer normal (the mean of the normals of its
        facets there: at a corner, between its faces), the node itself and the size of
        its largest facet (collective)."""
        normal, size = self._master.own_normals(nodes)
        comm = self.V.mesh.comm
        comm.Allreduce(MPI.IN_PLACE, normal, op=MPI.SUM)
        comm.Allreduce(MPI.IN_PLACE, size, op=MPI.MAX)
        return normal / np.linalg.norm(normal, axis=1, keepdims=True), nodes, size

    def _relative(self, u: fem.Function) -> np.ndarray:
        """u - T u at the owned slave nodes, (nodes, bs)."""
        self.T.mult(compat.petsc_vector(u), self._partner_work)
        bs = self.V.dofmap.index_map_bs
        relative = compat.petsc_vector(u).array_r - self._partner_work.array_r
        return relative.reshape(-1, bs)[self._nodes]

    def slid(self, u: fem.Function, fraction: float = REPAIR_SLIP) -> bool:
        """Whether a slave node near the master surface (its gap below the size of its
        partner's facet) has slid along it, relative to its partner and since the pairing,
        by more than ``fraction`` of that size: the tangential part of the change of
        u - T u (collective). The nodes farther away do not count: the contact terms
        vanish there."""
        if self.self_contact:  # (a node that no facet faced may face one now)
            return True
        bs = self.V.dofmap.index_map_bs
        relative = self._relative(u)
        n = self.normal.x.array.reshape(-1, bs)[self._nodes]
        change = relative - self._paired_relative
        tangential = change - np.einsum("nd,nd->n", change, n)[:, None] * n
        scale = self._scale.x.array.reshape(-1, bs)[self._nodes, 0]
        g = self.gap_vector.x.array.reshape(-1, bs)[self._nodes]
        near = np.einsum("nd,nd->n", g - relative, n) < scale
        slid = np.linalg.norm(tangential[near], axis=1) / scale[near]
        local = np.max(slid, initial=0.0)
        return self.V.mesh.comm.allreduce(local, op=MPI.MAX) > fraction

    def apply(self, source: fem.Function, target: fem.Function) -> None:
        """target = T source (the partner values at the slave nodes)."""
        self.T.mult(compat.petsc_vector(source), compat.petsc_vector(target))
        target.x.scatter_forward()

    def destroy(self) -> None:
        """Free T and the work vector (collective)."""
        self.T.destroy()
        self._partner_work.destroy()


class _PartnerSurface:
    """The master surface as seen from the slave nodes, behind the interface of a rigid
    obstacle (:mod:`nitsche_dolfinx.physics.obstacles`): n_c and g interpolated from the nodes."""

    def __init__(self, pairing: Pairing):
        self.pairing = pairing

    def normal(self, x):
        return self.pairing.normal

    def gap(self, x):
        return ufl.dot(self.pairing.gap_vector, self.pairing.normal)


class PairContact(NitscheContact):
    """One biased half of a contact pair: Gamma_1 (``ds``) against its partner surface.

    The law is :class:`~nitsche_dolfinx.contact.nitsche.NitscheContact`'s with the relative
    normal displacement (u - T u) . n_c and, with friction, the relative slip velocity
    (u' - T u')_t, every term multiplied by ``weight`` (1/2 for each half of the
    unbiased variant). The part tested by the partner's displacement,
    :meth:`partner_force_terms`, is assembled apart and added through T^T
    (:class:`~nitsche_dolfinx.assembly.pair_coupling.PairCoupling`).

    Args:
        pairing: The :class:`Pairing` of Gamma_1 with Gamma_2.
        weight: 1 (biased) or 1/2 (a half of the unbiased variant).
        follow: Pair the surfaces again in the configuration of the last converged step
            when they have slid (:meth:`Pairing.slid`); False: in the reference
            configuration only.
        friction: The Coulomb coefficient mu_f (a ``fem.Constant``), or None.

    The other arguments are those of :class:`~nitsche_dolfinx.contact.nitsche.NitscheContact`.
    """

    def __init__(
        self, pairing, ds, stress, gamma_h, nitsche_theta, weight: float, follow: bool = True,
        friction=None,
    ):  # fmt: skip
        super().__init__(_PartnerSurface(pairing), ds, stress, gamma_h, nitsche_theta, friction)
        self.pairing = pairing
        self.weight = float(weight)
        self.follow = bool(follow)
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

    def partner_force_terms(self, u, velocity, force, v, reference=None):
        """The terms of :meth:`force_terms` tested by the partner (``v`` standing for T v):
        :meth:`partner_term` and, with friction, :meth:`friction_partner_term`."""
        form = self.partner_term(force, v)
        if self.frictional:
            velocity = self._velocity(velocity)
            form = form + self.friction_partner_term(u, velocity, force, v, reference)
        return form

    # -- Coulomb friction on the relative slip (docs/method.md section 11) -----------

    def slip_velocity(self, velocity):
        """The relative tangential velocity (u' - T u')_t."""
        return self.tangential(velocity - self.partner(velocity))

    def tangential_consistency_term(self, u, v):
        return self.weight * super().tangential_consistency_term(u, v)

    def friction_term(self, u, velocity, normal_force, v, reference=None):
        """The slave's part, weighted: the test's tangential part is v_t (the partner's,
        -(T v)_t, is :meth:`friction_partner_term`)."""
        return self.weight * super().friction_term(u, velocity, normal_force, v, reference)

    def friction_partner_term(self, u, velocity, normal_force, v, reference=None):
        """weight int lambda_t . (T v)_t, with ``v`` standing for T v: the friction term's
        part tested by the partner, -(T v)_t in the relative test v_t - (T v)_t."""
        traction = self.friction_traction(u, velocity, normal_force, reference)
        return self.weight * ufl.dot(traction, self.tangential(v)) * self.ds

    def friction_work(self, u, velocity, normal_force, v):
        """The friction term tested with the increment ``v`` of both bodies: the slave's
        part and the partner's, on T v (``v`` a tracked Function)."""
        slave = self.friction_term(u, velocity, normal_force, v)
        return slave + self.friction_partner_term(u, velocity, normal_force, self.partner(v))

    def energy_correction(self, u):
        return self.weight * super().energy_correction(u)

    def force(self, u):
        return self.weight * super().force(u)

    def area(self, u):
        return self.weight * super().area(u)


def pair_halves(
    problem, tag_a: int, tag_b: int, variant: str, direction, follow: bool = True,
    kind: type = PairContact,
) -> list[PairContact]:  # fmt: skip
    """The biased halves of a contact pair of ``problem`` (a
    :class:`~nitsche_dolfinx.model.problem.ContactProblem`) between the facets ``tag_a`` and
    ``tag_b``: one, slave ``tag_a``, with weight 1 (``"biased"``), or one per surface
    with weight 1/2 (``"unbiased"``); paired along the unit vector ``direction`` (from
    ``tag_a`` towards ``tag_b``; reversed for the other half) or, None, with closest
    points; ``follow``: paired again as the surfaces slide (:meth:`Pairing.slid`).
    ``tag_a == tag_b``: self-contact, one half with weight 1/2 (each node of the surface
    is a slave, so that each touching pair of points is counted twice, as in the unbiased
    variant), paired again at every step. ``kind``: the class of the halves
    (:class:`PairContact`, or the finite-strain one of
    :class:`~nitsche_dolfinx.contact.finite.FinitePairContact`)."""
    facets = {tag: problem.facets(tag) for tag in (tag_a, tag_b)}
    sides = [(tag_a, tag_b, direction)]
    if variant == "unbiased" and tag_a != tag_b:
        sides.append((tag_b, tag_a, None if direction is None else -direction))
    weight = 1.0 if variant == "biased" and tag_a != tag_b else 0.5
    halves = []
    for slave, master, along in sides:
        pairing = Pairing(problem.V, facets[slave], facets[master], along)
        halves.append(
            kind(
                pairing,
                problem.ds(slave),
                problem.stress,
                problem.gamma_h,
                problem.nitsche_theta,
                weight,
                follow,
                problem.friction,
            )  # fmt: skip
        )
    return halves
