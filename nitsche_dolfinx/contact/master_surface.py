"""The master surface Gamma_2 of a contact pair (docs/method.md section 11): its facets
as parametrised pieces x(xi) of the configuration of a displacement, the closest point of
them to a point (or where a line meets them), their outer normals, the ends of the surface
and, for self-contact, which of its facets face a node.
"""

from __future__ import annotations

import basix
import numpy as np
from scipy.spatial import cKDTree

from ..common import compat
from .projection import closest_points, solve_small

__all__ = ["FACING", "MasterSurface", "basix_cell", "lagrange", "places"]

_CANDIDATES = 6  # facets of Gamma_2 (nearest centroids) tried for each slave node
_SELF_CANDIDATES = 48  # for self-contact: the nearest ones are the node's own neighbours
#: Self-contact: a normal faces a node's own if n . n_own < -FACING.
FACING = 0.5
_FLAT = 0.03  # self-contact: the surface turns where n . n_facet < 1 - _FLAT (14 degrees)
_BEYOND = 0.5  # self-contact: no partner this many facet sizes beyond the surface's end
_NORMAL_BLEND = 1e-6  # closer than this share of a facet's size, its own normal counts


def basix_cell(mesh):
    """The basix cell type of the mesh's cells."""
    return getattr(basix.CellType, compat.cell_name(mesh))


def lagrange(cell_type, degree: int):
    """The equispaced Lagrange element of ``degree`` on ``cell_type`` (basix)."""
    return basix.create_element(
        basix.ElementFamily.P, cell_type, degree, basix.LagrangeVariant.equispaced
    )


def _on_edge(xi: np.ndarray) -> np.ndarray:
    """Whether each point xi of a facet is on its edge or vertex (clamped there)."""
    return (np.min(xi, axis=1, initial=1.0) <= 0.0) | (xi.sum(axis=1) >= 1.0)


def places(nodes: np.ndarray, wanted: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where each of ``wanted`` is in ``nodes`` (global indices, each once), and which of
    them are there at all."""
    order = np.argsort(nodes)
    place = np.minimum(np.searchsorted(nodes[order], wanted), len(nodes) - 1)
    found = nodes[order][place] == wanted
    return order[place], found


class MasterSurface:
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
        cell_type = basix_cell(mesh)
        reference = basix.geometry(cell_type)
        facet_vertices = basix.topology(cell_type)[fdim]
        self.geometry_element = lagrange(cell_type, compat.geometry_degree(mesh))
        self.element = lagrange(cell_type, compat.element_degree(V))
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
        xi_tried, x = closest_points(self.points, tried, targets, across, fdim)
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
        step = solve_small(metric, metric, np.einsum("ndf,nd->nf", tangent, points - x))
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
        place, found = places(nodes, node.ravel())
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
        opposite = np.einsum("nd,nd->n", normal, outward) < -FACING
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
        surface = outward[places(nodes, node_ids[facet, nearest])[0]]
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
