"""One pipeline for every gmsh mesh of the package, generated or read from a ``.msh`` file.

1. gmsh is started one way (:func:`gmsh_session`: quietly, on rank 0 only);
2. rank 0 builds the model (a generator of :mod:`~nitsche_dolfinx.meshing.shapes` or
   :mod:`~nitsche_dolfinx.meshing.two_bodies`) or reads it (:func:`read_msh`), and checks that
   dolfinx can make a mesh of it: the cells of one type in physical groups, the
   dimensions consistent;
3. every rank learns what rank 0 found, or its error (:func:`from_root`), before any
   collective work: a bad file fails on every rank, in one line, never a hang;
4. the model is distributed over the ranks, with the contact-aware partition
   (:func:`~nitsche_dolfinx.meshing.partition.contact_bisection`) when the mesh has a contact
   boundary.
"""

from __future__ import annotations

import contextlib
import os
import pickle
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from mpi4py import MPI

from ..common import compat
from .partition import contact_bisection

__all__ = [
    "ModelFacts",
    "check_file",
    "distribute",
    "from_root",
    "gmsh_session",
    "inspect_model",
    "read_msh",
]


@contextlib.contextmanager
def gmsh_session():
    """gmsh, initialised quietly for the ``with`` block and finalised after it, SIGINT's
    handler kept: the one way the package starts gmsh
    (:func:`~nitsche_dolfinx.common.compat.start_gmsh`,
    :func:`~nitsche_dolfinx.common.compat.sigint_kept`).

    Yields:
        The ``gmsh`` module.
    """
    with compat.sigint_kept():
        import gmsh  # an optional dependency, needed by the rank that builds a model

        compat.start_gmsh(gmsh)
        try:
            yield gmsh
        finally:
            gmsh.finalize()


def from_root(comm, work: Callable[[], object]):
    """``work()`` on rank 0 and its result on every rank; if it raises, every rank raises
    its error (the rank that reads a file tells the others what is wrong with it).

    Collective. The result must be small and picklable; an error that does not survive
    pickling reaches the other ranks as a ValueError with its message.
    """
    result = error = None
    if comm.rank == 0:
        try:
            result = work()
        except Exception as caught:  # re-raised on every rank below
            error = caught
    if comm.size > 1:
        shared = comm.bcast((result, _portable(error)), root=0)
        if comm.rank != 0:  # rank 0 keeps its own error, with its traceback
            result, error = shared
    if error is not None:
        raise error
    return result


def _portable(error):
    """``error``, or a ValueError with its message if it cannot go through pickle."""
    if error is None:
        return None
    try:
        pickle.loads(pickle.dumps(error))
    except Exception:  # noqa: BLE001 - any exception class may refuse pickling
        return ValueError(str(error))
    return error


@dataclass(frozen=True)
class ModelFacts:
    """What rank 0 found in a gmsh model, told to every rank."""

    #: The dimension of the cells.
    tdim: int
    #: The name of their type (e.g. ``"second-order triangles"``).
    cells: str
    #: The vertices of a cell (the partitioner's cells have these only).
    num_vertices: int
    #: The highest coordinate axis on which a node is not at 0, plus one (3: some z != 0).
    span: int
    #: The physical groups of dimension tdim - 1 that hold elements (the facet tags).
    facet_groups: tuple[int, ...]

    @property
    def has_facet_tags(self) -> bool:
        """Whether the model has facet tags (:attr:`facet_groups`)."""
        return len(self.facet_groups) > 0


def distribute(
    build: Callable[[], None],
    comm=MPI.COMM_WORLD,
    gdim: int | None = None,
    contact: Sequence[int] = (),
    what: str = "the gmsh model",
    facet_tags_required: bool = False,
):
    """Build a gmsh model on rank 0 and distribute it over ``comm`` as a dolfinx mesh.

    Args:
        build: Makes the current gmsh model (on rank 0, gmsh started); raises ValueError
            on bad arguments or input.
        comm: The communicator to distribute the mesh over.
        gdim: The geometric dimension; the cells' dimension when None (a different one
            is refused).
        contact: The facet tags (physical groups of dimension tdim - 1) of the contact
            boundary: with any, the cells are partitioned by
            :func:`~nitsche_dolfinx.meshing.partition.contact_bisection` over all of them.
        what: How the messages name the model (``"mesh file 'x.msh'"``).
        facet_tags_required: Refuse a model without physical groups of dimension
            tdim - 1.

    Returns:
        ``(mesh, cell_tags, facet_tags)``, ``facet_tags`` None without physical groups of
        dimension tdim - 1.

    Raises:
        ValueError: The build failed, or dolfinx cannot make a mesh of the model (on
            every rank, before any collective work).
    """
    root = comm.rank == 0
    with gmsh_session() if root else contextlib.nullcontext() as gmsh:

        def inspected():
            build()
            return inspect_model(gmsh.model, what)

        facts = from_root(comm, inspected)
        _check_dimension(facts, gdim, what)
        if facet_tags_required and not facts.has_facet_tags:
            raise ValueError(
                f"{what} has no physical groups on its boundary (of dimension "
                f"{facts.tdim - 1}): the facet tags"
            )
        missing = sorted(set(contact) - set(facts.facet_groups))
        if missing:
            raise ValueError(
                f"{what} has no physical group {missing[0]} of dimension {facts.tdim - 1} "
                "(a contact surface)"
            )
        gdim = facts.tdim if gdim is None else gdim
        partitioner = None
        if comm.size > 1 and contact:
            x, nodes = np.zeros((0, 3)), []
            if root:
                x, nodes = _partition_data(gmsh.model, facts.tdim - 1, contact)
            partitioner = contact_bisection(x, nodes, facts.num_vertices)
        model = gmsh.model if root else None
        mesh, cell_tags, facet_tags = compat.gmsh_model_to_mesh(model, comm, 0, gdim, partitioner)
    return mesh, cell_tags, (facet_tags if facts.has_facet_tags else None)


def inspect_model(model, what: str) -> ModelFacts:
    """The :class:`ModelFacts` of a gmsh model, or a ValueError naming what dolfinx cannot
    make a mesh of: no elements, no physical groups, elements of the highest dimension
    outside them (a mesh of mixed dimensions), cells of several types or of a type
    dolfinx does not read (:data:`nitsche_dolfinx.common.compat.GMSH_CELL_TYPES`)."""
    meshed = [(dim, tag) for dim, tag in model.getEntities() if _has_elements(model, dim, tag)]
    if not meshed:
        raise ValueError(f"{what} holds no mesh (no elements)")
    tdim = max(dim for dim, _ in meshed)
    groups = model.getPhysicalGroups()
    if not groups:
        raise ValueError(
            f"{what} has no physical groups: dolfinx reads the cells of the physical groups "
            f"of dimension {tdim} (and the facet tags of those of dimension {tdim - 1})"
        )
    grouped = {(d, int(e)) for d, g in groups for e in model.getEntitiesForPhysicalGroup(d, g)}
    outside = [tag for dim, tag in meshed if dim == tdim and (dim, tag) not in grouped]
    if outside:
        raise ValueError(
            f"{what} has {tdim}D elements in no physical group (entity {outside[0]}): dolfinx "
            f"makes the mesh of the physical groups' elements alone"
        )
    cell_types = _element_types(model, grouped, tdim)
    if len(cell_types) > 1 or not set(cell_types) <= set(compat.GMSH_CELL_TYPES):
        found = ", ".join(_type_name(model, t) for t in sorted(cell_types))
        raise ValueError(
            f"{what} has cells of type {found}: dolfinx reads one type of lines, "
            "triangles, quadrilaterals, tetrahedra or hexahedra, of order 1 or 2"
        )
    facet_types = _element_types(model, grouped, tdim - 1)
    if len(facet_types) > 1:
        found = ", ".join(_type_name(model, t) for t in sorted(facet_types))
        raise ValueError(f"{what} has facets of several types in physical groups: {found}")
    (cell,) = cell_types
    _, coordinates, _ = model.mesh.getNodes()
    away = np.any(np.asarray(coordinates).reshape(-1, 3) != 0.0, axis=0)
    return ModelFacts(
        tdim=tdim,
        cells=compat.GMSH_CELL_TYPES[cell],
        num_vertices=int(model.mesh.getElementProperties(cell)[5]),
        span=int(np.nonzero(away)[0].max() + 1) if away.any() else 1,
        facet_groups=tuple(
            int(g) for d, g in groups if d == tdim - 1 and _element_types(model, grouped, d, g)
        ),
    )


def _has_elements(model, dim: int, tag: int) -> bool:
    return len(model.mesh.getElementTypes(dim, tag)) > 0


def _element_types(model, grouped: set, dim: int, group: int | None = None) -> list[int]:
    """The element types of the entities of dimension ``dim`` in physical groups (in the
    physical group ``group`` alone if given)."""
    if group is not None:
        grouped = {(dim, int(e)) for e in model.getEntitiesForPhysicalGroup(dim, group)}
    types = set()
    for entity_dim, tag in grouped:
        if entity_dim == dim:
            types.update(int(t) for t in model.mesh.getElementTypes(dim, tag))
    return sorted(types)


def _type_name(model, element_type: int) -> str:
    return str(model.mesh.getElementProperties(element_type)[0])


def _check_dimension(facts: ModelFacts, gdim: int | None, what: str) -> None:
    """The cells fill the space: their dimension is gdim, no node lies off their space."""
    if gdim is not None and gdim != facts.tdim:
        raise ValueError(
            f"{what} holds {facts.tdim}D cells ({facts.cells}), not gdim={gdim!r} (the "
            "geometric dimension of a mesh is its cells')"
        )
    if facts.span > facts.tdim:
        raise ValueError(
            f"{what} holds {facts.tdim}D cells ({facts.cells}) in {facts.span}D space: the "
            f"cells of a body's mesh fill its space (no physical group of its "
            f"{facts.span}D elements?)"
        )


def _partition_data(model, fdim: int, contact: Sequence[int]):
    """The nodes by input index (gmsh's tags from 1) and those of each contact surface."""
    tags, coordinates, _ = model.mesh.getNodes()
    x = np.asarray(coordinates).reshape(-1, 3)[np.argsort(tags)]
    nodes = [
        np.asarray(model.mesh.getNodesForPhysicalGroup(fdim, tag)[1]).reshape(-1, 3)
        for tag in contact
    ]
    return x, nodes


def check_file(path: str) -> None:
    """Refuse a path that is no readable, non-empty file (naming it)."""
    if os.path.isdir(path):
        raise ValueError(f"mesh file {path!r} is a folder, not a mesh file")
    if not os.path.isfile(path):
        raise ValueError(f"mesh file {path!r} does not exist")
    if os.path.getsize(path) == 0:
        raise ValueError(f"mesh file {path!r} is empty")
    if not os.access(path, os.R_OK):
        raise ValueError(f"mesh file {path!r} cannot be read: permission denied")


def read_msh(
    path: str,
    comm=MPI.COMM_WORLD,
    gdim: int | None = None,
    facet_tags_required: bool = True,
    contact: Sequence[int] = (),
    with_cell_tags: bool = False,
):
    """A gmsh ``.msh`` file, read on rank 0 and distributed: ``(mesh, facet_tags)``, or
    ``(mesh, cell_tags, facet_tags)`` ``with_cell_tags``.

    The physical groups of the highest dimension make the cells, those of one dimension
    less the facet tags (their tag is the physical group's number): None without any,
    unless ``facet_tags_required``. See :func:`distribute` for ``gdim`` and ``contact``.

    Raises:
        ValueError: One line naming the file and what is wrong with it, on every rank.
    """
    what = f"mesh file {path!r}"

    def merge():
        import gmsh  # optional dependency: the rank that reads the file alone

        check_file(path)
        gmsh.model.add("nitsche_dolfinx_read")
        try:
            gmsh.merge(str(path))
        except Exception as error:  # gmsh raises a bare Exception
            reason = " ".join(str(error).split()) or type(error).__name__
            raise ValueError(f"{what} cannot be read: {reason}") from None
        if len(gmsh.model.mesh.getNodes()[0]) and _node_tags_have_gaps(gmsh.model):
            gmsh.model.mesh.renumberNodes()  # dolfinx takes the nodes as tags 1 to N

    mesh, cell_tags, facet_tags = distribute(
        merge, comm, gdim, contact, what, facet_tags_required=facet_tags_required
    )
    return (mesh, cell_tags, facet_tags) if with_cell_tags else (mesh, facet_tags)


def _node_tags_have_gaps(model) -> bool:
    tags = np.asarray(model.mesh.getNodes()[0])
    return int(tags.max()) != len(tags) or len(np.unique(tags)) != len(tags)
