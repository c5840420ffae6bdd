"""Lumped and redistributed (modified) mass matrices, as diagonals.

- lumped: the row sums of the consistent mass matrix (P1: all positive);
- redistributed (Khenous, Laborde & Renard 2008): the lumped mass with the mass of
  the nodes of Gamma_C set to zero and moved to the other nodes of the cells
  around them, so that the total mass is kept. With massless contact nodes the
  semi-discrete contact problem is well posed (the contact node follows the
  constraint instantly) and Crank-Nicolson loses its spurious oscillations of
  the contact displacement.

Both are returned as PETSc vectors with the layout of the displacement space:
the diagonal of the mass matrix, the same for every component of a node.
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc

from ..common import compat

__all__ = ["MassMatrix", "lumped_mass", "redistributed_mass"]


def _accumulate(vec: PETSc.Vec) -> None:
    """Add ghost contributions to their owners, then copy owners back to the ghosts."""
    vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    vec.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)


def density(mesh, rho):
    """The density as the forms take it: a number becomes a ``fem.Constant`` (one compiled
    form for every value); a UFL field (one value per cell: several materials) stays."""
    if isinstance(rho, ufl.core.expr.Expr):
        return rho
    return fem.Constant(mesh, float(rho))


def lumped_mass(V, rho) -> PETSc.Vec:
    """The lumped mass on the vector space ``V``: the row sums of the consistent mass matrix
    ``int rho u . v`` for P1; for P2, whose row sums are zero or negative at the vertices
    of triangles and tetrahedra, the diagonal of the consistent mass scaled to the body's
    mass (Hinton, Rock & Zienkiewicz: element by element the same scaling on affine cells
    of one shape, so the masses stay positive and each cell keeps its mass)."""
    if compat.element_degree(V) > 1:
        return _hrz_mass(V, rho)
    ones = fem.Constant(V.mesh, np.ones(V.mesh.geometry.dim))
    rho = density(V.mesh, rho)
    mass = compat.create_vector(V)
    with mass.localForm() as local:
        local.set(0.0)
    fem_petsc.assemble_vector(mass, fem.form(rho * ufl.inner(ones, ufl.TestFunction(V)) * ufl.dx))
    _accumulate(mass)
    return mass


def _hrz_mass(V, rho) -> PETSc.Vec:
    """The diagonal of the consistent mass matrix times body mass / its sum (with several
    materials each cell's diagonal scales with its density, so the one factor is still
    every cell's)."""
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    rho = density(V.mesh, rho)
    matrix = fem_petsc.assemble_matrix(fem.form(rho * ufl.inner(u, v) * ufl.dx))
    matrix.assemble()
    mass = compat.create_vector(V)
    with mass.localForm() as local:
        local.set(0.0)
    matrix.getDiagonal(mass)
    matrix.destroy()
    body = V.mesh.comm.allreduce(fem.assemble_scalar(fem.form(rho * ufl.dx)), op=MPI.SUM)
    bs = V.dofmap.index_map_bs
    mass.scale(body * bs / mass.sum())  # the owned entries
    mass.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
    return mass


def redistributed_mass(V, rho, contact_facets) -> PETSc.Vec:
    """The lumped mass with the mass of the contact nodes moved to their neighbours (P1).

    Each cell's share of the mass of a contact node, ``rho_T |T| / (d + 1)``, goes in
    equal parts to the cell's nodes that are not on Gamma_C (a cell whose nodes are
    all on Gamma_C keeps it). The moves are summed over the owned cells of each
    rank, so the result does not depend on the number of ranks.

    Args:
        V: The (P1, vector) displacement space.
        rho: The density: a number, or a UFL field (one value per cell).
        contact_facets: Local indices of the facets of Gamma_C.
    """
    mesh = V.mesh
    tdim = mesh.topology.dim
    bs = V.dofmap.index_map_bs
    mass = lumped_mass(V, rho)
    with mass.localForm() as local:
        nodal = local.array.reshape(-1, bs)[:, 0].copy()  # the same for every component

    on_contact = np.zeros(len(nodal))
    on_contact[fem.locate_dofs_topological(V, tdim - 1, contact_facets)] = 1.0
    flag = compat.create_vector(V)  # a node on Gamma_C for any rank is one for all
    with flag.localForm() as local:
        local.array.reshape(-1, bs)[:] = on_contact[:, None]
    _accumulate(flag)
    with flag.localForm() as local:
        contact_node = local.array.reshape(-1, bs)[:, 0] > 0

    D = compat.function_space(mesh, "DG", 0)
    cell_mass = fem.Function(D)  # rho_T |T|
    fem_petsc.assemble_vector(
        compat.petsc_vector(cell_mass),
        fem.form(density(mesh, rho) * ufl.TestFunction(D) * ufl.dx),
    )
    num_owned = mesh.topology.index_map(tdim).size_local
    cells = compat.dofmap_array(V)[:num_owned]  # blocked dofs = nodes
    masses = cell_mass.x.array[compat.dofmap_array(D)[:num_owned, 0]]
    contact = contact_node[cells]
    free = ~contact
    moving = contact.any(axis=1) & free.any(axis=1)
    share = masses[moving] / cells.shape[1]  # one node's mass in the cell
    leaving = contact[moving].sum(axis=1)
    arriving = free[moving].sum(axis=1)
    change = np.zeros(len(nodal))
    np.add.at(change, cells[moving][contact[moving]], -np.repeat(share, leaving))
    np.add.at(change, cells[moving][free[moving]], np.repeat(share * leaving / arriving, arriving))

    moved = compat.create_vector(V)
    with moved.localForm() as local:
        local.array.reshape(-1, bs)[:] = change[:, None]
    _accumulate(moved)
    mass.axpy(1.0, moved)
    with mass.localForm() as local:
        values = local.array.reshape(-1, bs)
        values[contact_node] = 0.0  # exactly zero, not round-off
    return mass


class MassMatrix:
    """The mass matrix of a problem as its steps take it: ``"consistent"`` (a form, in the
    equations), or ``"lumped"`` or ``"redistributed"`` (a diagonal, added by the solver).

    Args:
        kind: One of :data:`~nitsche_dolfinx.common.parameters.MASS_MATRICES`.
        V: The displacement space.
        rho: The density: a number, or a UFL field (one value per cell).
        contact_facets: A function giving the local facets of Gamma_C (None: no contact)
            when the redistributed mass is first made (the obstacles are added after the
            problem).
    """

    def __init__(self, kind: str, V, rho, contact_facets):
        self.kind, self.V, self.rho = kind, V, rho
        self._contact_facets = contact_facets
        self._diagonal = None

    def diagonal(self, V=None) -> PETSc.Vec | None:
        """The diagonal as a PETSc vector (None for the consistent mass); on ``V`` (another
        numbering of the displacement space) when given."""
        if self.kind == "consistent":
            return None
        if V is not None:
            return self._make(V)
        if self._diagonal is None:
            self._diagonal = self._make(self.V)
        return self._diagonal

    def _make(self, V) -> PETSc.Vec:
        if self.kind == "lumped":
            return lumped_mass(V, self.rho)
        facets = self._contact_facets()
        if facets is None:
            raise ValueError("mass='redistributed' needs an obstacle: add one first")
        return redistributed_mass(V, self.rho, facets)

    def of_unit_density(self) -> MassMatrix:
        """The same kind of mass with density 1 (what lumps a load per unit volume as this
        mass is lumped: M f / rho with one density, with several)."""
        return MassMatrix(self.kind, self.V, 1.0, self._contact_facets)

    def massless_dofs(self, nodes: bool = False) -> np.ndarray:
        """Local indices (with ghosts) of the dofs whose mass is zero (redistributed mass);
        with ``nodes``, of their nodes (the blocks of the dof array)."""
        diagonal = self.diagonal()
        if diagonal is None:
            return np.zeros(0, dtype=np.int32)
        bs = self.V.dofmap.index_map_bs
        with diagonal.localForm() as local:
            mass = local.array.reshape(-1, bs)[:, 0] if nodes else local.array
            return np.flatnonzero(mass == 0.0).astype(np.int32)
