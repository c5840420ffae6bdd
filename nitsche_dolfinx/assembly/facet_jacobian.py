"""The facet (contact) part B of a step's Jacobian, assembled where the contact is
(docs/method.md section 8).

- :class:`ContactFacets`: the facets of the cells in contact, with a ring of neighbours;
- :class:`FacetJacobian`: B, made on the sparsity of those facets, assembled on the facets
  of the cells in contact at the iterate, left alone while the contact terms are
  inactive everywhere, and compared with its last value so that an unchanged Jacobian
  keeps its factorisation.
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc

from ..common import compat
from ..common.collective import any_rank
from ..meshing.facet_selectors import facet_cells, facet_vertices
from .forms import Forms, with_facet_quadrature

__all__ = ["ContactFacets", "FacetJacobian", "RESTRICTED_FROM"]

#: Forms restricted to the facets near contact are compiled again on fewer facets once
#: they are assembled on more than this many times the facets needed (plus a few).
_SHRINK = 2
#: B is made near the contact, on the facets of :class:`ContactFacets`, when Gamma_C has
#: at least this many facets (over all ranks); on fewer, following the contact costs more
#: than the assembly it saves (docs/method.md section 8), and B lives on all of them.
RESTRICTED_FROM = 64


class ContactFacets:
    """The facets on which terms that vanish out of contact are assembled: those of the
    cells whose contact terms are active, with one ring of neighbours (facets sharing a
    vertex) as a margin, so that the set is made again only when the contact zone has
    moved beyond it, or when it holds more than :data:`_SHRINK` times the facets needed.
    All facets at first. A term that is exactly zero on the other facets has the same
    values to the bit on these (its sums lack only zeros), whatever their history.

    Args:
        mesh: The mesh.
        tags: The facet tags of the exterior facet integrals.
        ids: The tags of the facets (subdomain ids of the integrals).
    """

    def __init__(self, mesh, tags, ids):
        self._mesh = mesh
        chosen = np.isin(tags.values, np.asarray(list(ids)))
        order = np.argsort(tags.indices[chosen], kind="stable")
        self.facets = tags.indices[chosen][order].astype(np.int32)
        self._values = tags.values[chosen][order].astype(np.int32)
        self._cells = facet_cells(mesh, self.facets)
        self._vertices = facet_vertices(mesh, self.facets)
        self.current = np.ones(len(self.facets), dtype=bool)
        self.needed = None  # the facets of the cells in contact at the last update

    @classmethod
    def of_measure(cls, mesh, ds) -> ContactFacets:
        """The facets of the measure ``ds(tag)``."""
        return cls(mesh, ds.subdomain_data(), [ds.subdomain_id()])

    @classmethod
    def of_form(cls, mesh, form: ufl.Form) -> ContactFacets | None:
        """The facets of the exterior facet integrals of ``form`` when there are enough of
        them to follow the contact (:data:`RESTRICTED_FROM`); None if fewer, or unless each
        integral has facet tags and an integer subdomain id (an integral over every facet
        has no tags to restrict). Collective."""
        integrals = [i for i in form.integrals() if i.integral_type() == "exterior_facet"]
        ids = [integral.subdomain_id() for integral in integrals]
        if not integrals or not all(isinstance(i, (int, np.integer)) for i in ids):
            return None
        tags = integrals[0].subdomain_data()
        if tags is None or any(i.subdomain_data() is not tags for i in integrals):
            return None
        facets = cls(mesh, tags, set(ids))
        count = mesh.comm.allreduce(len(facets.facets), op=MPI.SUM)
        return facets if count >= RESTRICTED_FROM else None

    def update(self, active_cells: np.ndarray) -> bool:
        """Take the facets of ``active_cells`` and their neighbours when the contact has
        left the current ones, or uses few of them; True if the set changed."""
        needed = self.needed = active_cells[self._cells]
        marked = np.zeros(self._vertices.max(initial=-1) + 1, dtype=bool)
        marked[self._vertices[needed].ravel()] = True
        wanted = marked[self._vertices].any(axis=1) if len(self._vertices) else needed
        beyond = (needed & ~self.current).any()
        loose = self.current.sum() > _SHRINK * wanted.sum() + 8
        if beyond or loose:
            self.current = wanted
            return True
        return False

    def compiled_on(self, forms: Forms, chosen: np.ndarray) -> Forms:
        """``forms``, compiled on all the facets, on the facets ``chosen`` (a mask, such as
        :attr:`current` or :attr:`needed`): no compilation."""
        return forms.on_facets(self.facets[chosen], self._values[chosen])


class FacetJacobian:
    """B, the Jacobian of the facet terms that vanish, with their derivatives, wherever the
    contact is inactive (the normal force; docs/method.md section 8).

    B is made on the sparsity of the facets near the contact (:class:`ContactFacets`, when
    Gamma_C has at least :data:`RESTRICTED_FROM` facets; else on all of them), of PETSc
    type ``matrix_type``, and assembled on the facets of the cells in contact at the
    iterate. Its CSR structure (:attr:`indptr`, :attr:`columns`, :attr:`entry_rows`, the
    local row of each entry) and its values (:attr:`values`) are read after each
    assembly; :attr:`generation` counts the times it was made.

    Args:
        J_facet: The Jacobian of the facet terms (UFL), on every facet of Gamma_C.
        bcs: Dirichlet conditions (zero rows and columns in B).
        activity: The activity, a linear form with one non-negative value per cell (a DG0
            test function), zero on the cells where the terms are inactive: the normal
            force ``int [P_gamma(u)]_+ q`` (None: B is assembled at every evaluation).
        degrees: The quadrature degree of each facet integral of B, given to the activity
            so that it is nonzero on each cell where B is.
        matrix_type: The PETSc type of B (blocked insertion is faster).
        facets: With an activity, the :class:`ContactFacets` of J_facet to make B on near
            the contact (J_facet is then the force terms alone, zero wherever the activity
            is); None: B lives on all of J_facet's facets.
    """

    def __init__(
        self, J_facet: ufl.Form, bcs, activity=None, degrees=None, matrix_type=None,
        facets: ContactFacets | None = None,
    ):  # fmt: skip
        self.bcs = bcs
        self._matrix_type = matrix_type
        #: The forms on all the facets (B's first sparsity), and on B's facets.
        self.all_forms = Forms(J_facet)
        self.forms = self.all_forms
        self._on_needed = None  # (facets, the forms on them) of the last assembly of B
        #: The :class:`ContactFacets` B follows (None: B lives on all the facets).
        self.facets = facets if activity is not None else None
        self.B = None
        self.generation = 0
        self._make()
        self._comm = self.B.getComm().tompi4py()
        #: The local rows where B can have entries, on any of the facets.
        self.facet_rows = np.flatnonzero(np.diff(self.indptr) > 0)
        self.activity = None
        self._activity_fresh = False  # the activity of the last assembly is known
        if activity is not None:
            self.activity = fem.form(with_facet_quadrature(activity, degrees or {}))
            space = activity.arguments()[0].ufl_function_space()
            self._activity = compat.create_vector(space)
            self._activity_dofs = compat.dofmap_array(space)[:, 0]  # a value per cell
        self._known = False  # whether B holds a Jacobian to compare the next with
        self._former = None  # the nonzero entries of that Jacobian if B was made since
        self.inactive = False  # whether B was assembled with the terms inactive everywhere
        self.assemblies = 0

    def _make(self) -> None:
        """Make B on the sparsity of :attr:`forms`, assembled, with its CSR structure."""
        if self.B is not None:
            self._former = self.nonzero_entries()  # to compare the next B with
            self.B.destroy()
        self.B = self.forms.create_matrix(self._matrix_type)
        # the Dirichlet rows get a zero diagonal, which B's sparsity of the facets of
        # Gamma_C may lack on a rank (Dirichlet conditions far from the contact, under MPI:
        # PETSc refused the insertion): let it in at this first assembly only, which sets
        # the sparsity (the CSR structure read below must stay B's)
        self.B.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
        # on all of the forms' facets: PETSc keeps only the entries assembled into a new B
        self.forms.assemble_matrix(self.B, self.bcs, 0.0)
        self.B.assemble()
        self.B.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, True)
        self.indptr, self.columns, self.values = self.B.getValuesCSR()
        lengths = np.diff(self.indptr)
        self.entry_rows = np.repeat(np.arange(len(lengths)), lengths)
        self.generation += 1

    def nonzero_entries(self) -> tuple[np.ndarray, np.ndarray]:
        """B's nonzero entries: their local rows and global columns (together, their place
        whatever B's sparsity), and their values."""
        nonzero = self.values != 0.0
        width = np.int64(self.B.getSize()[1])
        keys = self.entry_rows[nonzero] * width + self.columns[nonzero]
        return keys, self.values[nonzero]

    def inactive_everywhere(self) -> bool:
        """Whether the activity is zero on every cell (collective; False without one)."""
        if self.activity is None:
            return False
        with self._activity.localForm() as local:
            local.set(0.0)
        fem_petsc.assemble_vector(self._activity, self.activity)
        self._activity.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        self._activity.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        self._activity_fresh = True
        return self._activity.norm(PETSc.NormType.NORM_INFINITY) == 0.0

    def active_cells(self) -> np.ndarray | None:
        """Whether each local cell (owned and ghost) has active terms at the iterate of the
        last :meth:`update` (a nonzero activity); None if that call did not evaluate it."""
        if not self._activity_fresh:
            return None
        with self._activity.localForm() as local:
            return local.array_r[self._activity_dofs] > 0.0

    def update(self, skip_inactive: bool = True) -> bool:
        """Assemble B at the current coefficients (unless the terms are inactive now and
        were at the last assembly, and ``skip_inactive``); True if it differs from the
        last one on any rank (collective)."""
        self._activity_fresh = False
        inactive = skip_inactive and self.inactive_everywhere()
        if inactive and self.inactive and self._known:
            return False  # inactive now and at the last assembly: the same Jacobian
        self.inactive = inactive
        self.assemblies += 1
        before = self.values
        if self.facets is None or not self._follow_contact():  # (else B is made)
            self.B.zeroEntries()
            self.on_contact().assemble_matrix(self.B, self.bcs, 0.0)
            self.B.assemble()
            self.values = self.B.getValuesCSR()[2]
        if self._former is None:  # the same sparsity: the same values
            same = self._known and np.array_equal(self.values, before)
        else:  # the nonzero entries in the same places, with the same values
            same = self._known and all(map(np.array_equal, self.nonzero_entries(), self._former))
        self._former, self._known = None, True
        return any_rank(self._comm, not same)

    def forget(self) -> None:
        """Make the next :meth:`update` assemble B and report a change."""
        self._known = False

    def on_contact(self) -> Forms:
        """The forms on the facets of the cells in contact at the iterate (taken by
        :meth:`_follow_contact`; :attr:`forms` before it): the force terms are zero on the
        others, so B gets the values it gets on all of the facets, to the bit (its sums
        lack only zeros), for a fraction of the work."""
        return self.forms if self._on_needed is None else self._on_needed[1]

    def _follow_contact(self) -> bool:
        """Follow the contact of the iterate: when it has moved beyond the facets of B's
        sparsity or left most of them, make B on the facets near it, assembled at the
        iterate, and return True; when the facets of the cells in contact changed on a
        rank, take them for B's assembly (:meth:`_on_contact`). Collective: the ranks make
        B and the forms together (dolfinx may make a facet form collectively)."""
        if not self._activity_fresh:
            self.inactive_everywhere()
        changed = self.facets.update(self.active_cells())
        needed = self.facets.needed
        moved = self._on_needed is None or not np.array_equal(self._on_needed[0], needed)
        flags = np.array([changed, moved], dtype=np.int32)
        self._comm.Allreduce(MPI.IN_PLACE, flags, op=MPI.MAX)
        if flags[1]:
            self._on_needed = (needed, self.facets.compiled_on(self.all_forms, needed))
        if flags[0]:
            self.forms = self.facets.compiled_on(self.all_forms, self.facets.current)
            self._make()  # on their sparsity: its work scales with them
            return True
        return False

    def petsc_objects(self) -> list:
        """Its PETSc objects, for the system that holds it to destroy: B and the vector of
        the activity."""
        return [self.B] + ([self._activity] if self.activity is not None else [])
