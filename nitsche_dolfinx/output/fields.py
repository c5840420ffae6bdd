"""Fields of ``solution.xdmf`` that are not a Function of the state (docs/method.md section 6).

- :class:`NodalMean`: an expression that jumps between cells (a stress), at each node the
  mean of the values of the cells around it;
- :class:`OnBoundary`: a Function at the nodes of a boundary part, zero elsewhere;
- :class:`SurfaceValues`: expressions at the nodes of boundary parts, zero elsewhere (the gap);
- :class:`ContactFields`: ``contact_pressure``, ``gap`` and ``contact_status`` on Gamma_C;
- :class:`OutputMesh`: the mesh on which fields of a higher degree than the geometry are
  written (a P2 field on an affine mesh).

Each has ``evaluate(target)``, which writes it into a Lagrange Function ``target`` of the
output (:class:`~nitsche_dolfinx.output.writers.SolutionWriter`), on every rank, without
gathering anything.
"""

from __future__ import annotations

import numpy as np
from dolfinx import fem
from petsc4py import PETSc

from ..common import compat
from ..contact.nitsche import heaviside, positive_part
from .probes import BoundaryField

__all__ = [
    "CellMean",
    "ContactFields",
    "body_fields",
    "LevelRefresh",
    "NodalMean",
    "OnBoundary",
    "OutputMesh",
    "SurfaceValues",
    "boundary_nodes",
]


def body_fields(problem, u, v) -> dict:
    """The fields of the whole body for the output: displacement, velocity and the von
    Mises stress, as ``{name: (source, value shape)}``; with a material per region, its
    cell tag ``material_id`` (at a node, the mean of the tags of the cells around it: the
    tag inside a region, between two tags on an interface)."""
    shape = (problem.gdim,)
    fields = {
        "displacement": (u, shape),
        "velocity": (v, shape),
        "von_mises": (problem.von_mises(u), ()),
    }
    material_id = getattr(problem.material_constants, "material_id", None)
    if material_id is not None:
        fields["material_id"] = (CellMean(material_id), ())
    return fields


class CellMean:
    """A field constant in each cell (DG0) written at each node as the mean of the values
    of the cells around it (:class:`NodalMean`: the same on any partition), for the output
    (``evaluate(target)``)."""

    def __init__(self, field: fem.Function):
        self.field = field
        self._mean = None

    def evaluate(self, target: fem.Function) -> None:
        """Set ``target`` (a Lagrange Function) to the nodal means of the field; the
        :class:`NodalMean` is made on the space of the first ``target``."""
        if self._mean is None:
            V = target.function_space
            self._mean = NodalMean(self.field, V, compat.element_degree(V))
        self._mean.evaluate(target)


class NodalMean:
    """A UFL expression in ``V`` (Lagrange, of ``degree`` and value ``shape``), its value at
    each node the mean of the values of the cells around the node.

    A field that jumps between cells (a stress) has no value at a node shared by cells;
    dolfinx's interpolation gives it the value of the last cell it visits, which depends
    on the partition of the mesh. Here the expression is interpolated cell by cell into
    the discontinuous space of the same degree, then averaged over the cells of each
    node: the same on any partition and number of ranks, up to round-off.
    """

    def __init__(self, expression, V, degree: int, shape: tuple[int, ...] = ()):
        mesh = V.mesh
        W = compat.function_space(mesh, "DG", degree, shape)
        self._pieces = fem.Function(W)
        self._expression = compat.expression(expression, W)
        cells = mesh.topology.index_map(mesh.topology.dim).size_local  # owned cells
        self._nodes = compat.dofmap_array(V)[:cells].reshape(-1)
        self._cell_nodes = compat.dofmap_array(W)[:cells].reshape(-1)
        self._bs = V.dofmap.index_map_bs
        index_map = V.dofmap.index_map
        self._blocks = index_map.size_local + index_map.num_ghosts
        self._owned = index_map.size_local * self._bs
        counts = fem.Function(V)
        ones = np.ones((self._nodes.size, self._bs))
        self._counts = self._sum(counts, ones)

    def _sum(self, target, values: np.ndarray) -> np.ndarray:
        """Add ``values`` (one row per cell node) into the owned dofs of ``target``, on the
        rank that owns each node; returns the owned entries."""
        array = target.x.array.reshape(-1, self._bs)
        for component in range(self._bs):
            array[:, component] = np.bincount(
                self._nodes, weights=values[:, component], minlength=self._blocks
            )[: len(array)]
        vector = compat.petsc_vector(target)
        vector.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        return target.x.array[: self._owned].copy()

    def evaluate(self, target) -> None:
        """Set ``target`` (a Function on ``V``) to the nodal means of the expression."""
        self._pieces.interpolate(self._expression)
        values = self._pieces.x.array.reshape(-1, self._bs)[self._cell_nodes]
        sums = self._sum(target, values)
        target.x.array[: self._owned] = sums / self._counts
        target.x.scatter_forward()


def boundary_nodes(V, facets: np.ndarray) -> np.ndarray:
    """Which local nodes (blocks) of the Lagrange space ``V`` lie on ``facets``, the same on
    every rank that holds a node (collective: a rank may hold a node of a facet it does not
    have)."""
    marker = fem.Function(V)
    bs = V.dofmap.index_map_bs
    dofs = fem.locate_dofs_topological(V, V.mesh.topology.dim - 1, facets)
    marker.x.array.reshape(-1, bs)[dofs] = 1.0
    vector = compat.petsc_vector(marker)
    vector.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    marker.x.scatter_forward()
    return marker.x.array.reshape(-1, bs)[:, 0] > 0


class OnBoundary:
    """A Function written at the nodes of a part of the boundary, zero at every other node.

    A P1 field on the boundary (zero at the other vertices) interpolated into a space of
    higher degree would take half its boundary value at the middle of each edge from the
    boundary into the body: written at the nodes on the boundary only, the field in the
    file is the field on the boundary, as ParaView draws it on the surface.

    Args:
        function: The Function (a :class:`~nitsche_dolfinx.output.probes.BoundaryField`'s).
        facets: The facets of the part, local indices.
    """

    def __init__(self, function, facets: np.ndarray):
        self.function, self.facets = function, facets
        self._target = None  # the Function of the last call, and its nodes on the part

    def evaluate(self, target) -> None:
        """Set ``target`` (a Lagrange Function) to the Function at the nodes of the part."""
        if self._target is not target:
            self._target = target
            self._outside = ~boundary_nodes(target.function_space, self.facets)
        target.interpolate(self.function)
        bs = target.function_space.dofmap.index_map_bs
        target.x.array.reshape(-1, bs)[self._outside] = 0.0


class SurfaceValues:
    """Scalar expressions, each at the nodes of its part of the boundary, the least of them
    where parts meet or overlap, and zero at every node on none of them.

    Zero, not NaN, off the parts: dolfinx's XDMF writer evaluates a field cell by cell, so
    that a NaN at one node of a cell spreads to all its nodes.

    The expressions must be continuous across cells (u, x and nodal Functions): their value
    at a node is then the same from every cell, and on every partition.

    Args:
        mesh: The mesh.
        parts: ``[(expression, facets)]``, facets as local facet indices.
    """

    def __init__(self, mesh, parts):
        self.mesh = mesh
        self.parts = list(parts)
        self._target = None  # the Function of the last call, its expressions and nodes

    def _compile(self, target) -> None:
        V = target.function_space
        self._compiled = [
            (compat.expression(-expression, V), boundary_nodes(V, facets))
            for expression, facets in self.parts
        ]
        self._target, self._scratch = target, fem.Function(V)

    def evaluate(self, target) -> None:
        """Set ``target`` (a scalar Lagrange Function) to the values, zero off the parts."""
        if self._target is not target:
            self._compile(target)
        # the largest of the negated values (-inf off the parts), every rank holding a node
        # with the same parts: a rank's nodes are all evaluated, ghosts included
        values = np.full(target.x.array.shape, -np.inf)
        for expression, nodes in self._compiled:
            self._scratch.interpolate(expression)
            values[nodes] = np.maximum(values[nodes], self._scratch.x.array[nodes])
        target.x.array[:] = np.where(np.isfinite(values), -values, 0.0)


class ContactFields:
    """The contact fields on Gamma_C of a problem at the displacement ``u``, for output
    (docs/method.md section 6): one field of each kind for all the obstacles and contact
    pairs together.

    - ``contact_pressure``: lambda_h = -(1/gamma_h) [P_gamma(u)]_+ <= 0, the lumped L2
      projection onto P1 of the sum over the contacts of each part of Gamma_C (zero off
      Gamma_C); each slave surface of a contact pair has its own lambda_h, unweighted;
    - ``gap``: g - u_n at the nodes of Gamma_C (< 0: penetration), the least over the
      contacts of a node; for a contact pair u_n = (u - T u) . n_c; zero off Gamma_C;
    - ``contact_status``: the lumped L2 projection onto P1 of H(P_gamma(u)) (of the sum
      of the forces where several contacts share a part): 1 in contact, 0 apart, in between
      at the edge of the contact zone; with the hybrid scheme, the switch of the step that
      starts at this level (the midpoint rule where 1, Crank-Nicolson where 0). Zero off
      Gamma_C.

    Args:
        problem: The :class:`~nitsche_dolfinx.model.problem.ContactProblem` (with contacts).
        u: The displacement of the time level.
        pressure: A P1 Function to write as ``contact_pressure`` instead of lambda_h (the
            multiplier of the mixed method).
        in_contact: The indicator of the contact set on Gamma_C (a UFL expression) instead
            of H(P_gamma(u)).
    """

    def __init__(self, problem, u, pressure=None, in_contact=None):
        self.problem = problem
        mesh, contacts = problem.mesh, problem.contacts
        tags = sorted(set(problem.contact_tags))
        ds = problem.ds(tuple(tags))
        self.pressure = None
        if pressure is None:
            self.pressure = BoundaryField(
                mesh,
                (),
                ds,
                lambda mu: sum(c.pressure(u) * mu * c.ds for c in contacts),
                "contact_pressure",
            )
            pressure = self.pressure.function
        if in_contact is None:  # per part of Gamma_C: in contact with any of its obstacles
            groups = {tag: [] for tag in tags}
            for contact, tag in zip(contacts, problem.contact_tags):
                groups[tag].append(positive_part(contact.projection(u)))
            in_contact = {tag: heaviside(sum(forces)) for tag, forces in groups.items()}
        else:
            in_contact = {tag: in_contact for tag in tags}
        self.status = BoundaryField(
            mesh,
            (),
            ds,
            lambda mu: sum(value * mu * problem.ds(tag) for tag, value in in_contact.items()),
            "contact_status",
        )
        self.gap = SurfaceValues(
            mesh,
            [
                (-contact.penetration(u), problem.facets(tag))  # g - u_n
                for contact, tag in zip(contacts, problem.contact_tags)
            ],
        )
        #: The facets of Gamma_C, every contact's.
        self.facets = np.unique(np.concatenate([problem.facets(tag) for tag in tags]))
        self._pressure = pressure

    def fields(self) -> dict:
        """``{name: (source, shape)}`` for
        :class:`~nitsche_dolfinx.output.writers.SolutionWriter`."""
        return {
            "contact_pressure": (OnBoundary(self._pressure, self.facets), ()),
            "gap": (self.gap, ()),
            "contact_status": (OnBoundary(self.status.function, self.facets), ()),
        }

    def update(self) -> None:
        """Evaluate the projections at the current state (before a field output)."""
        self.problem.update_partners()
        if self.pressure is not None:
            self.pressure.update()
        self.status.update()


class LevelRefresh:
    """Runs ``refresh()`` at most once per time level (``level()``, e.g. a stepper's step
    index and time), when a field source that needs it is first evaluated: the projections
    of the contact and friction fields are computed for the levels that are written only,
    whoever writes them (:meth:`Simulation.run <nitsche_dolfinx.simulation.Simulation.run>`
    or a time loop of the user's with :class:`~nitsche_dolfinx.output.writers.SolutionWriter`).

    Args:
        refresh: Brings the sources up to date with the state (collective).
        level: The current level, any value that changes from one level to the next.
    """

    def __init__(self, refresh, level):
        self._refresh, self._level, self._done = refresh, level, None

    def ensure(self) -> None:
        """Refresh, unless done at this level already."""
        level = self._level()
        if level != self._done:
            self._refresh()
            self._done = level

    def wrap(self, source) -> _Refreshed:
        """``source`` (an object with ``evaluate(target)``), refreshed before it is evaluated."""
        return _Refreshed(source, self)


class _Refreshed:
    """A field source evaluated after its :class:`LevelRefresh`."""

    def __init__(self, source, refresh: LevelRefresh):
        self.source, self._refresh = source, refresh

    def evaluate(self, target) -> None:
        self._refresh.ensure()
        self.source.evaluate(target)


class OutputMesh:
    """A mesh whose nodes are the nodes of a Lagrange space ``V`` of a higher degree than
    the geometry of its mesh: the same cells, with a geometry of the degree of ``V``.

    A Function of ``V`` (or of its vector space) is written on it node for node
    (:meth:`transfer`): a P2 field on an affine mesh keeps its values at the mid-edges,
    and ParaView draws its quadratic cells. Each cell stays on the rank that owns it in
    the mesh of ``V``, so that building it moves nothing between ranks but what the ranks
    share (the nodes on their boundaries), and a transfer is a local copy.
    """

    def __init__(self, V):
        mesh, index_map = V.mesh, V.dofmap.index_map
        self.degree = compat.element_degree(V)
        local = index_map.size_local + index_map.num_ghosts
        global_index = index_map.local_to_global(np.arange(local, dtype=np.int32))
        global_index = np.asarray(global_index, dtype=np.int64)
        owned_cells = mesh.topology.index_map(mesh.topology.dim).size_local
        dofs = compat.dofmap_array(V)[:owned_cells]
        x = V.tabulate_dof_coordinates()[: index_map.size_local, : mesh.geometry.dim]
        self.mesh = compat.mesh_keeping_cells(
            mesh.comm,
            global_index[dofs],
            x,
            compat.cell_name(mesh),
            self.degree,
            lambda: _sharing_ranks(index_map, dofs, mesh.comm),
        )
        # the node of each dof of the new mesh's space: a dof of V, by its global index
        nodes = np.asarray(self.mesh.geometry.input_global_indices, dtype=np.int64)
        order = np.argsort(global_index)
        found = order[np.searchsorted(global_index, nodes, sorter=order).clip(0, local - 1)]
        if not np.array_equal(global_index[found], nodes):
            raise RuntimeError("the output mesh has a node that is not a dof of this rank")
        W = compat.function_space(self.mesh, "Lagrange", self.degree)
        self._source = np.full(W.dofmap.index_map.size_local + W.dofmap.index_map.num_ghosts, -1)
        self._source[compat.dofmap_array(W).reshape(-1)] = found[
            compat.geometry_dofmap(self.mesh).reshape(-1)
        ]
        if np.any(self._source < 0):
            raise RuntimeError("the output mesh has a dof in no cell")

    def function(self, name: str, shape: tuple[int, ...] = ()) -> fem.Function:
        """A Function of the Lagrange space of the mesh's degree, of value ``shape``."""
        space = compat.function_space(self.mesh, "Lagrange", self.degree, shape)
        return fem.Function(space, name=name)

    def transfer(self, source: fem.Function, target: fem.Function) -> None:
        """Copy a Function of ``V`` (or of its vector space) into ``target``, node by node."""
        bs = target.function_space.dofmap.index_map_bs
        target.x.array.reshape(-1, bs)[:] = source.x.array.reshape(-1, bs)[self._source]


def _sharing_ranks(index_map, cell_dofs: np.ndarray, comm) -> tuple[np.ndarray, np.ndarray]:
    """For each cell (a row of local dofs of ``index_map``), its rank then the other ranks
    that hold one of its dofs, as ``(offsets, ranks)`` (collective: each rank tells the
    owners of its ghost dofs that it holds them)."""
    ghosts = np.asarray(index_map.ghosts, dtype=np.int64)
    owners = np.asarray(index_map.owners, dtype=np.int64)
    order = np.argsort(owners, kind="stable")
    counts = np.bincount(owners, minlength=comm.size)
    received_counts = np.asarray(comm.alltoall(counts.tolist()))
    received = np.empty(received_counts.sum(), dtype=np.int64)
    comm.Alltoallv([ghosts[order], counts], [received, received_counts])
    # (local dof, another rank holding it): our dofs held elsewhere, the owners of our ghosts
    holders: dict[int, set] = {}
    size_local = index_map.size_local
    start = index_map.local_range[0]
    dofs = np.concatenate([received - start, size_local + np.arange(len(ghosts))])
    others = np.concatenate([np.repeat(np.arange(comm.size), received_counts), owners])
    pairs = zip(dofs.tolist(), others.tolist())
    for dof, rank in pairs:
        holders.setdefault(dof, set()).add(rank)
    ranks = [[comm.rank] for _ in range(len(cell_dofs))]
    shared = np.zeros(size_local + len(ghosts), dtype=bool)
    shared[list(holders)] = True
    for cell in np.flatnonzero(shared[cell_dofs].any(axis=1)):  # on a rank boundary
        holding = set().union(*(holders.get(dof, ()) for dof in cell_dofs[cell].tolist()))
        ranks[cell].extend(sorted(holding - {comm.rank}))
    offsets = np.cumsum([0] + [len(cell) for cell in ranks])
    return offsets, np.array([rank for cell in ranks for rank in cell], dtype=np.int64)
