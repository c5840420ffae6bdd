"""The pairing of a contact pair's surfaces (docs/method.md section 11): for each node of
the slave surface Gamma_1, the point of the master surface Gamma_2 it faces.

A pair is a slave surface Gamma_1 and a master surface Gamma_2, on one mesh (two bodies
may be disconnected parts of it). Each node of Gamma_1 is paired with a point of Gamma_2
(:class:`Pairing`): its closest point, or where a line along a given direction meets
Gamma_2, found in the configuration of a displacement (the reference one at first, the
last converged step's when the surfaces have slid: :meth:`Pairing.slid`). That pairing is
a matrix T: (T u)(x_i) = u(pi(x_i)) at the slave nodes x_i, zero elsewhere, so that the
partner displacement on Gamma_1 is the interpolant of u o pi, a function of the same
space, with the contact normal n_c = -(outer normal of Gamma_2) and the gap vector
X(pi(x)) - X(x), X the reference positions, the normal taken at pi(x). A slave node
beyond an end of Gamma_2 (closest points: its closest point on a side of its facet that
no other facet of Gamma_2 has, the node out across it) faces no point of Gamma_2 and has
no partner: it is its own (u - T u = 0), with a gap of a facet's size. The contact terms
of a pair are in :mod:`~nitsche_dolfinx.contact.pairs`.
"""

from __future__ import annotations

import basix
import numpy as np
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc

from ..common import compat
from .master_surface import FACING, MasterSurface, basix_cell, lagrange, places

__all__ = ["REPAIR_SLIP", "Pairing"]

#: A pairing is made again when a slave node near the master surface has slid along it,
#: since the last pairing, by more than this fraction of the size of the facet it is
#: paired with (docs/method.md section 11).
REPAIR_SLIP = 0.03

_ROUNDOFF = 1e-12  # a basis function's value below this at a partner point is a zero


def _lowest_rank(comm, candidate: np.ndarray) -> np.ndarray:
    """For each entry, the lowest rank where ``candidate`` is True (comm.size if none)."""
    ranks = np.where(candidate, comm.rank, comm.size).astype(np.int64)
    lowest = np.empty_like(ranks)
    comm.Allreduce(ranks, lowest, op=MPI.MIN)
    return lowest


def _surface_nodes(V, facets: np.ndarray):
    """The owned nodes of ``V`` on ``facets`` and their coordinates (from the reference
    points of the element, mapped by the cell's geometry)."""
    mesh = V.mesh
    tdim, gdim = mesh.topology.dim, mesh.geometry.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    f2c = mesh.topology.connectivity(tdim - 1, tdim)
    nodes = fem.locate_dofs_topological(V, tdim - 1, facets)
    nodes = np.unique(nodes[nodes < V.dofmap.index_map.size_local])
    cell_type = basix_cell(mesh)
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
    cell_type = basix_cell(mesh)
    element = lagrange(cell_type, compat.element_degree(V))
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
    Gamma_2: :meth:`~nitsche_dolfinx.contact.master_surface.MasterSurface.beyond_open_side`),
    or, given a unit ``direction`` d, with the point where the line through the node along
    d meets Gamma_2, and n_c = d. Made in the reference configuration, and again by
    :meth:`pair` in that of a displacement (when the surfaces have slid, :meth:`slid`).

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
        #: that faces it, away from its own neighbourhood
        #: (:meth:`~nitsche_dolfinx.contact.master_surface.MasterSurface._facing`).
        self.self_contact = np.array_equal(np.sort(slave_facets), np.sort(master_facets))
        self._nodes, self._positions = _surface_nodes(V, slave_facets)
        # the slave nodes of every rank, which each rank projects: the same at each pairing
        global_nodes = V.dofmap.index_map.local_to_global(self._nodes)
        self._every_node = np.concatenate(comm.allgather(global_nodes))
        self._every_position = np.vstack(comm.allgather(self._positions)).reshape(-1, gdim)
        self._master = MasterSurface(V, master_facets)
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
        every_point = self._move_to(u)
        master = self._master
        facing = self._own_sides(self._every_node) if self.self_contact else None
        distance, facet, xi, outer = master.closest(every_point, self.direction, exhaustive, facing)
        paired, mine = self._winners(distance)
        mine, alone, alone_normal, alone_size = self._without_partner(
            mine, paired, facet, xi, outer, every_point, facing
        )
        facet, xi = facet[mine], xi[mine]
        T, rows = self._matrix(self._every_node[mine], facet, xi, self._every_node[alone])
        if self.T is not None:
            self.T.destroy()
        self.T = T
        partner = master.points(facet, xi, displaced=False)[0]  # its reference position
        normal, gap = -outer[mine], partner - self._every_position[mine]
        scale = master.size[facet]
        if len(alone):  # each its own partner: u - T u = 0, a gap of a facet's size
            normal = np.vstack([normal, alone_normal])
            gap = np.vstack([gap, alone_size[:, None] * alone_normal])
            scale = np.concatenate([scale, alone_size])
        self._set_nodal(rows, normal, gap, scale)
        self._paired_relative = self._relative(self.displacement)
        self.generation += 1

    def _move_to(self, u: fem.Function | None) -> np.ndarray:
        """Follow the configuration displaced by ``u`` (None: the reference one): keep
        ``u`` as :attr:`displacement`, move Gamma_2 and return the points of the slave
        nodes of every rank (collective)."""
        V, comm = self.V, self.V.mesh.comm
        gdim, bs = V.mesh.geometry.dim, V.dofmap.index_map_bs
        if u is None:
            self.displacement.x.array[:] = 0.0
        else:
            self.displacement.x.array[:] = u.x.array
        moved = None if u is None else self.displacement.x.array
        every_point = self._every_position
        if moved is not None:
            points = self._positions + moved.reshape(-1, bs)[self._nodes][:, :gdim]
            every_point = np.vstack(comm.allgather(points)).reshape(-1, gdim)
        self._master.move(moved)
        return every_point

    def _winners(self, distance: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Which slave nodes some rank found a facet for, and those this rank pairs: the
        rank with the nearest facet computes the node's row (the lowest on a tie;
        collective)."""
        comm = self.V.mesh.comm
        nearest = np.empty_like(distance)
        comm.Allreduce(distance, nearest, op=MPI.MIN)
        paired = np.isfinite(nearest)
        if not self.self_contact and not paired.all():
            raise ValueError("the master surface of a contact pair has no facet")
        winner = _lowest_rank(comm, paired & (distance == nearest))
        return paired, np.flatnonzero(winner == comm.rank)

    def _without_partner(self, mine, paired, facet, xi, outer, every_point, facing):
        """Of the nodes this rank paired (``mine``), those that keep their partner, and the
        nodes without a partner that this rank writes, with their normal and the size of
        their gap: for self-contact those of :meth:`_alone`; by closest points those
        beyond an end of Gamma_2 (:meth:`_beyond_with_edges`; collective)."""
        master = self._master
        alone = np.zeros(0, dtype=np.int64)
        alone_normal, alone_size = np.zeros((0, self.V.mesh.geometry.dim)), np.zeros(0)
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
        return mine, alone, alone_normal, alone_size

    def _matrix(self, nodes: np.ndarray, facet: np.ndarray, xi: np.ndarray, alone: np.ndarray):
        """T, assembled, and its rows: at the slave ``nodes`` (global indices) the values
        of the basis functions of the partner's cell at the points xi of its ``facet``;
        at the nodes ``alone``, without a partner, the node itself (collective)."""
        V, comm, master = self.V, self.V.mesh.comm, self._master
        bs, index_map = V.dofmap.index_map_bs, V.dofmap.index_map
        # T's rows: the basis functions of the partner's cell at the partner point; those
        # of the nodes off the facet vanish on it, and at a node all but one: round-off,
        # left out so that T couples only the nodes it pairs
        values = np.zeros((0, master.element.dim))
        if len(nodes):  # (basix tabulates no empty set of points)
            values = master.element.tabulate(0, master.reference_point(facet, xi))[0, :, :, 0]
        kept = np.abs(values) > _ROUNDOFF
        owner = np.repeat(np.arange(len(nodes)), kept.sum(axis=1))  # of each kept value
        columns = index_map.local_to_global(master.dofs[facet][kept].astype(np.int32))
        component = np.arange(bs)
        order = np.argsort((owner[:, None] * bs + component).ravel(), kind="stable")
        columns = (columns[:, None] * bs + component).ravel()[order]
        entries = np.repeat(values[kept], bs)[order]
        rows = (nodes[:, None] * bs + component).ravel()
        indptr = np.concatenate([[0], np.cumsum(np.repeat(kept.sum(axis=1), bs))])
        size = (index_map.size_local * bs, index_map.size_global * bs)
        per_cell = master.element.dim
        T = PETSc.Mat().createAIJ((size, size), nnz=(per_cell, per_cell), comm=comm)
        T.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
        T.setValuesIJV(
            indptr.astype(PETSc.IntType), columns.astype(PETSc.IntType), entries,
            PETSc.InsertMode.INSERT_VALUES, rows.astype(PETSc.IntType),
        )  # fmt: skip
        if len(alone):
            lonely = (alone[:, None] * bs + component).ravel()
            T.setValuesIJV(  # each its own partner: u - T u = 0
                np.arange(len(lonely) + 1, dtype=PETSc.IntType), lonely.astype(PETSc.IntType),
                np.ones(len(lonely)), PETSc.InsertMode.INSERT_VALUES,
                lonely.astype(PETSc.IntType),
            )  # fmt: skip
            rows = np.concatenate([rows, lonely])
        T.assemble()
        return T, rows

    def _set_nodal(self, rows, normal, gap, scale) -> None:
        """Write n_c, the gap vector and the partner facets' sizes at the slave dofs
        ``rows`` (global indices; collective)."""
        bs = self.V.dofmap.index_map_bs
        nodal = {
            self.normal: normal[:, :bs],
            self.gap_vector: gap[:, :bs],
            self._scale: np.repeat(scale[:, None], bs, axis=1),
        }
        for function, value in nodal.items():
            vector = compat.create_vector(self.V)
            vector.setValues(rows.astype(PETSc.IntType), np.ascontiguousarray(value).ravel())
            vector.assemble()
            compat.petsc_vector(function).array[:] = vector.array
            function.x.scatter_forward()
            vector.destroy()

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
        place = places(self._every_node, self._edge_nodes.ravel())[0].reshape(-1, 3)
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
        faces = np.einsum("nd,nd->n", outer[mine], outward[mine]) < -FACING
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
