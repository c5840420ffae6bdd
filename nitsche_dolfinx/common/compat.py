"""Every dolfinx, UFL, numpy and gmsh API difference between dolfinx 0.5.2 and 0.11, in one
place.

The rest of the package calls these shims and never looks at a version number.
Each shim detects the feature it needs (``hasattr`` or ``try``/``except``) so
that a dolfinx release in between, or a backport, takes the right branch by
itself.

Design constraints that dolfinx 0.5 imposes on the meshes:

- A cell partitioner gives each cell its owner and the ranks that share one of its
  vertices (0.5 finds shared vertices through ghost cells): :func:`cell_partitioner`.
- ``model_to_mesh`` takes no partitioner (:func:`gmsh_model_to_mesh` passes it on) and
  ``read_from_msh`` fails (the package merges a ``.msh`` file into a gmsh model itself).
- Cells are lines, triangles, quadrilaterals, tetrahedra or hexahedra, of one type per
  mesh: :data:`GMSH_CELL_TYPES`.

and on expressions: an ``fem.Expression`` with an Argument (a test function) gives wrong
values in 0.5 and corrupts the heap (measured), so the contact's quadrature
operators tabulate the basis with basix and evaluate only expressions without one
(:mod:`~nitsche_dolfinx.contact.quadrature`).
"""

from __future__ import annotations

import contextlib
import functools
import importlib
import inspect
import itertools
import logging
import os
import signal
import sys
import threading

import cffi
import dolfinx.cpp
import dolfinx.geometry
import dolfinx.io
import dolfinx.mesh
import dolfinx.plot
import numpy as np
import ufl
from dolfinx import cpp, fem, la
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc

__all__ = [
    "add_matrix_entries",
    "apply_lifting",
    "cell_name",
    "cell_partitioner",
    "cells_containing",
    "collapse",
    "create_matrix",
    "create_vector",
    "expression",
    "dofmap_array",
    "form_on_facets",
    "function_space",
    "has_mumps",
    "element_degree",
    "evaluate",
    "geometry_degree",
    "geometry_dofmap",
    "GMSH_CELL_TYPES",
    "gmsh_model_to_mesh",
    "interpolation_points",
    "mesh_keeping_cells",
    "mixed_function_space",
    "node_coordinates",
    "own_symbols",
    "petsc_vector",
    "set_bc",
    "divergence_tolerance",
    "sigint_kept",
    "start_gmsh",
    "trapezoid",
    "vtk_mesh",
    "write_meshtags",
    "stable_form_signatures",
]


# -- numpy -----------------------------------------------------------------------------

#: ``numpy.trapz`` was removed in numpy 2 in favour of ``numpy.trapezoid``.
trapezoid = getattr(np, "trapezoid", None) or np.trapz


# -- form signatures -------------------------------------------------------------------

#: Counts left before the next power of ten below which :func:`stable_form_signatures`
#: moves UFL's counter of constants to it: more than the constants one problem and its
#: run create (about 20).
CONSTANT_COUNT_HEADROOM = 1000


def stable_form_signatures(mesh) -> None:
    """Make the forms built next on ``mesh`` have the signatures of the same forms built
    before, whatever their constants' values and counts, so that FFCx finds them in its
    cache instead of compiling them again (a parameter sweep compiles once).

    Two things otherwise change a signature:

    - UFL orders the operands of sums and products by the ``repr`` of their terminals,
      and a constant's ends with its count: counts of different lengths compare as
      strings (``'100' < '99'``), and the same form may order its terms otherwise. The
      counter of constants is moved to the next power of ten when fewer than
      :data:`CONSTANT_COUNT_HEADROOM` counts are left before it (UFL 2022 keeps it in
      ``Constant._globalcount``, later versions in an ``itertools.count``, ``_counter``).
    - FFCx 0.5 gives the mesh's coordinate element the variant "equispaced" when it
      first compiles a form on the mesh (never on a cache hit), which changes the hash
      of the mesh's UFL domain: a form built before that keeps the old one in its
      domain numbering, and gets another signature. The variant is set here, as FFCx
      sets it (basix elements, from dolfinx 0.7, have theirs).
    """
    domain = mesh.ufl_domain()
    element = getattr(domain, "_ufl_coordinate_element", None)
    sub_element = getattr(element, "_sub_element", None)
    if sub_element is not None and getattr(sub_element, "_variant", "") is None:
        scalar = ufl.FiniteElement(
            element.family(),
            element.cell(),
            element.degree(),
            element.quadrature_scheme(),
            variant="equispaced",
        )
        domain._ufl_coordinate_element = ufl.VectorElement(scalar)
    constant = ufl.Constant
    if isinstance(constant.__dict__.get("_globalcount"), int):  # UFL 2022
        current = constant._globalcount
    else:
        counter = constant.__dict__.get("_counter")
        current = 0 if counter is None else next(counter)
    power = 10
    while power <= current:
        power *= 10
    while power - current < CONSTANT_COUNT_HEADROOM:  # too close: start at that power
        current, power = power, power * 10
    if isinstance(constant.__dict__.get("_globalcount"), int):
        constant._globalcount = current
    else:
        constant._counter = itertools.count(current)


# -- function spaces -------------------------------------------------------------------


def function_space(mesh, family: str, degree: int, shape: tuple[int, ...] = ()):
    """A Lagrange-type function space with values of the given shape.

    Args:
        mesh: The dolfinx mesh.
        family: Element family, e.g. ``"Lagrange"`` or ``"DG"``.
        degree: Polynomial degree.
        shape: Value shape: ``()`` for a scalar field, ``(gdim,)`` for a vector field.

    Returns:
        The function space (``fem.functionspace`` from dolfinx 0.7, the
        ``FunctionSpace``/``VectorFunctionSpace`` constructors before).
    """
    shape = tuple(shape)
    if hasattr(fem, "functionspace"):
        return fem.functionspace(mesh, (family, degree, shape) if shape else (family, degree))
    if shape:
        return fem.VectorFunctionSpace(mesh, (family, degree), dim=shape[0])
    return fem.FunctionSpace(mesh, (family, degree))


def mixed_function_space(mesh, parts: list[tuple[str, int, tuple[int, ...]]]):
    """A mixed function space of Lagrange-type parts ``[(family, degree, shape), ...]``.

    ``basix.ufl.mixed_element`` and ``fem.functionspace`` from dolfinx 0.7;
    ``ufl.MixedElement`` of ``ufl.VectorElement``/``ufl.FiniteElement`` before.
    """
    try:
        import basix.ufl
    except ImportError:  # UFL 2022: the elements are UFL's own
        cell = mesh.ufl_cell()
        elements = [
            ufl.VectorElement(family, cell, degree, dim=shape[0])
            if shape
            else ufl.FiniteElement(family, cell, degree)
            for family, degree, shape in parts
        ]
        return fem.FunctionSpace(mesh, ufl.MixedElement(elements))
    cell = mesh.basix_cell() if hasattr(mesh, "basix_cell") else cell_name(mesh)
    elements = [
        basix.ufl.element(family, cell, degree, shape=tuple(shape))
        for family, degree, shape in parts
    ]
    return fem.functionspace(mesh, basix.ufl.mixed_element(elements))


def collapse(subspace):
    """``(collapsed space, the parent's index of each of its dofs)`` of a subspace.

    The map is an array up to 0.10 and a list holding that array in 0.11.
    """
    collapsed, dofs = subspace.collapse()
    return collapsed, np.asarray(dofs).reshape(-1)


def dofmap_array(V) -> np.ndarray:
    """The cell-to-dof map of ``V`` as a 2D array (num_cells, dofs_per_cell)."""
    dofs = V.dofmap.list
    if hasattr(dofs, "array") and not isinstance(dofs, np.ndarray):  # AdjacencyList (<= 0.7)
        return dofs.array.reshape(-1, V.dofmap.dof_layout.num_dofs)
    return np.asarray(dofs)


def geometry_dofmap(mesh) -> np.ndarray:
    """The cell-to-geometry-node map of ``mesh`` as a 2D array (num_cells, nodes_per_cell)."""
    dofs = _first_of(mesh.geometry, "dofmaps", "dofmap")
    if hasattr(dofs, "array") and not isinstance(dofs, np.ndarray):  # AdjacencyList (<= 0.7)
        num_cells = len(dofs.offsets) - 1
        return dofs.array.reshape(num_cells, -1)
    return np.asarray(dofs)


def element_degree(V) -> int:
    """Polynomial degree of the element of ``V`` (a method of the UFL element up to 0.7, a
    property of the basix one after)."""
    degree = V.ufl_element().degree
    return int(degree() if callable(degree) else degree)


def geometry_degree(mesh) -> int:
    """Polynomial degree of the mesh geometry (2 for a second-order gmsh mesh)."""
    return int(_first_of(mesh.geometry, "cmaps", "cmap").degree)


def _first_of(geometry, plural: str, singular: str):
    """The first of a geometry's dofmaps/cmaps (>= 0.10 has several), or its single one."""
    if hasattr(geometry, plural):
        items = getattr(geometry, plural)
        return items(0) if callable(items) else items[0]
    return getattr(geometry, singular)


def cell_name(mesh) -> str:
    """Name of the cell type: ``"interval"``, ``"triangle"``, ``"tetrahedron"``, ..."""
    return mesh.topology.cell_type.name


# -- PETSc vectors and assembly ------------------------------------------------------


def cells_containing(mesh, point: np.ndarray) -> list[int]:
    """The local cells (owned and ghosts) that contain ``point`` (shape (1, 3)).

    dolfinx 0.8 renamed ``BoundingBoxTree(mesh, dim)`` to ``bb_tree(mesh, dim)`` and
    ``compute_collisions`` (of points) to ``compute_collisions_points``.
    """
    tdim = mesh.topology.dim
    if hasattr(dolfinx.geometry, "bb_tree"):
        tree = dolfinx.geometry.bb_tree(mesh, tdim)
        candidates = dolfinx.geometry.compute_collisions_points(tree, point)
    else:
        tree = dolfinx.geometry.BoundingBoxTree(mesh, tdim)
        candidates = dolfinx.geometry.compute_collisions(tree, point)
    cells = dolfinx.geometry.compute_colliding_cells(mesh, candidates, point)
    return [int(cell) for cell in cells.links(0)]


def petsc_vector(u: fem.Function) -> PETSc.Vec:
    """The PETSc vector that shares memory with a Function's dof array."""
    x = u.x
    if hasattr(x, "petsc_vec"):  # >= 0.8
        return x.petsc_vec
    return u.vector


def create_vector(V) -> PETSc.Vec:
    """A ghosted PETSc vector with the layout of the function space ``V``."""
    if hasattr(la, "create_petsc_vector"):  # <= 0.9
        return la.create_petsc_vector(V.dofmap.index_map, V.dofmap.index_map_bs)
    return fem_petsc.create_vector(V)  # >= 0.10: takes function spaces


def create_matrix(a, matrix_type: str | None = None) -> PETSc.Mat:
    """A PETSc matrix with the sparsity of the compiled bilinear form ``a``, of the PETSc
    type ``matrix_type`` (None: dolfinx's default, AIJ). The keyword is ``mat_type`` up
    to 0.9 and ``kind`` from 0.10, so the type is passed positionally."""
    if matrix_type is None:
        return fem_petsc.create_matrix(a)
    return fem_petsc.create_matrix(a, matrix_type)


def add_matrix_entries(A: PETSc.Mat, a) -> None:
    """Add this rank's cell and facet contributions of the compiled bilinear form ``a`` to
    ``A``, without Dirichlet conditions and without assembling ``A`` (the caller does,
    once for several matrices). dolfinx's ``assemble_matrix`` also flushes ``A`` (a
    synchronisation of all ranks) before it returns, on every supported version: a
    surface that lies on one rank then keeps the others waiting, matrix by matrix. The
    compiled form is the Form itself up to 0.8 and its ``_cpp_object`` from 0.9."""
    form = getattr(a, "_cpp_object", a)
    constants = cpp.fem.pack_constants(form)
    coefficients = cpp.fem.pack_coefficients(form)
    cpp.fem.petsc.assemble_matrix(A, form, constants, coefficients, [])


@functools.cache
def _ffi():
    """One cffi FFI for the casts of :func:`form_on_facets` (it caches the types it parses)."""
    return cffi.FFI()


def form_on_facets(a, form: ufl.Form, facets: np.ndarray, ids: np.ndarray):
    """The compiled form ``a`` of the UFL form ``form``, whose integrals are all exterior
    facet integrals, over other facets: ``facets`` (local indices, sorted), those with
    subdomain id ``ids``. The compiled kernels of ``a`` are used again: no UFL signature
    and no look-up in FFCx's cache, which take milliseconds. The C++ form is made as
    ``dolfinx.fem.form`` makes it: from the Form itself with the facets as tags up to
    0.8, from its ``_cpp_object`` with (cell, local facet) pairs from 0.9 (with the
    facet dimension as an argument in 0.9, and the kernels as a list from 0.10)."""
    constants = [constant._cpp_object for constant in form.constants()]
    exterior = fem.IntegralType.exterior_facet
    if not hasattr(a, "_cpp_object"):  # <= 0.8
        mesh = form.ufl_domain().ufl_cargo()
        dim = mesh.topology.dim - 1
        tags = cpp.mesh.MeshTags_int32(mesh, dim, facets.astype(np.int32), ids.astype(np.int32))
        domains = {kind: None for kind in fem.IntegralType.__members__.values()}
        domains[exterior] = tags
        return type(a)(a.ufcx_form, a.function_spaces, a.coefficients, constants,
                       domains, mesh, _ffi(), a.code)  # fmt: skip
    compiled = a._cpp_object
    topology, dim = compiled.mesh.topology, compiled.mesh.topology.dim - 1
    domains = []
    for tag in sorted({int(integral.subdomain_id()) for integral in form.integrals()}):
        chosen = facets[ids == tag].astype(np.int32)
        try:  # >= 0.10
            pairs = cpp.fem.compute_integration_domains(exterior, topology, chosen)
        except TypeError:
            pairs = cpp.fem.compute_integration_domains(exterior, topology, chosen, dim)
        domains.append((tag, np.asarray(pairs)))
    kernels = a.module.ffi.cast("uintptr_t", a.module.ffi.addressof(a.ufcx_form))
    spaces, coefficients = compiled.function_spaces, compiled.coefficients
    try:  # >= 0.10
        made = type(compiled)([int(kernels)], spaces, coefficients, constants,
                              {exterior: domains}, [], compiled.mesh)  # fmt: skip
    except TypeError:
        made = type(compiled)(kernels, spaces, coefficients, constants,
                              {exterior: domains}, {}, compiled.mesh)  # fmt: skip
    return fem.Form(made, a.ufcx_form, a.code, a.module)


def apply_lifting(b: PETSc.Vec, a, bcs, x0=None, alpha: float = 1.0) -> None:
    """b -= alpha A (g - x0) on the rows coupled to Dirichlet dofs.

    The scale argument is ``scale`` up to 0.8 and ``alpha`` from 0.9, so it is
    passed positionally; ``x0`` is a list up to 0.9 and may be ``None`` after.
    """
    x0_list = [] if x0 is None else [x0]
    fem_petsc.apply_lifting(b, [a], bcs=[bcs], x0=x0_list, **{_LIFTING_SCALE: alpha})


def set_bc(b: PETSc.Vec, bcs, x0=None, alpha: float = 1.0) -> None:
    """b[bc dofs] = alpha (g - x0); the scale is positional for the same reason."""
    fem_petsc.set_bc(b, bcs, x0, alpha)


def _scale_keyword(function) -> str:
    parameters = inspect.signature(function).parameters
    return "alpha" if "alpha" in parameters else "scale"


_LIFTING_SCALE = _scale_keyword(fem_petsc.apply_lifting)


def has_mumps(comm) -> bool:
    """Whether PETSc can factorise with MUMPS (on every rank), found out by trying."""
    A = PETSc.Mat().createAIJ([1, 1], nnz=1, comm=PETSc.COMM_SELF)
    A.setValue(0, 0, 1.0)
    A.assemble()
    pc = PETSc.PC().create(PETSc.COMM_SELF)
    try:
        pc.setOperators(A)
        pc.setType("lu")
        pc.setFactorSolverType("mumps")
        pc.setUp()
        found = True
    except PETSc.Error:
        found = False
    finally:
        pc.destroy()
        A.destroy()
    return bool(comm.allreduce(found, op=MPI.LAND))


def divergence_tolerance(snes: PETSc.SNES, dtol: float) -> dict[str, float]:
    """Set SNES's divergence tolerance: SNES stops when ||F|| > dtol ||F_0||.

    petsc4py >= 3.20 has a setter, called here; before, only the options database knows
    it: the option is returned, for the caller to put in the database for SNES's
    ``setFromOptions`` (under the solver's prefix). The value -1 meant "no test" up to
    PETSc 3.21 and "default" after, so to switch the test off pass a huge number instead.

    Returns:
        ``{}`` with the setter, else ``{"snes_divergence_tolerance": dtol}``.
    """
    if hasattr(snes, "setDivergenceTolerance"):
        snes.setDivergenceTolerance(dtol)
        return {}
    return {"snes_divergence_tolerance": dtol}


# -- expressions -----------------------------------------------------------------------


def node_coordinates(V) -> np.ndarray:
    """The coordinates of the nodes of a Lagrange space, one row per block of its dof
    array (owned, then ghosts): each coordinate interpolated into the space, which works
    for every space on every dolfinx (``tabulate_dof_coordinates`` refuses 1D vector
    spaces in 0.5)."""
    field = fem.Function(V)
    components = field.ufl_shape[0] if field.ufl_shape else 0
    bs = V.dofmap.index_map_bs
    columns = []
    for d in range(V.mesh.geometry.dim):
        field.interpolate(lambda x, d=d: np.tile(x[d], (components, 1)) if components else x[d])
        field.x.scatter_forward()
        columns.append(field.x.array.reshape(-1, bs)[:, 0].copy())
    return np.column_stack(columns)


def interpolation_points(V) -> np.ndarray:
    """Reference points at which ``V``'s element interpolates (property from 0.7, method before)."""
    points = V.element.interpolation_points
    return points() if callable(points) else points


def expression(ufl_expression, V) -> fem.Expression:
    """A compiled expression to interpolate into ``V`` with ``Function.interpolate``."""
    return fem.Expression(ufl_expression, interpolation_points(V))


def evaluate(expression: fem.Expression, mesh, cells: np.ndarray, points: int) -> np.ndarray:
    """The values of ``expression`` at its ``points`` reference points in each of ``cells``,
    shaped (cells, points, values): ``eval(cells)`` up to 0.7, ``eval(mesh, cells)`` from
    0.8."""
    cells = np.asarray(cells, dtype=np.int32)
    if "mesh" in inspect.signature(expression.eval).parameters:
        values = expression.eval(mesh, cells)
    else:
        values = expression.eval(cells)
    return np.asarray(values).reshape(cells.size, points, -1)


# -- gmsh and XDMF ---------------------------------------------------------------------


def gmsh_model_to_mesh(model, comm, rank: int, gdim: int, partitioner=None):
    """Convert a gmsh model into ``(mesh, cell_tags, facet_tags)``, the cells sent to
    the ranks by ``partitioner`` if given (no ghost cells), else by dolfinx's default.

    ``dolfinx.io.gmshio.model_to_mesh`` returns a tuple up to 0.9;
    ``dolfinx.io.gmsh.model_to_mesh`` returns a named tuple from 0.10. In 0.5 it takes
    no partitioner: its call of ``create_mesh`` is given one for the time of the call.
    """
    module = getattr(dolfinx.io, "gmsh", None)
    if module is None or not hasattr(module, "model_to_mesh"):
        with sigint_kept():
            module = _import_gmshio()
    if partitioner is None:
        result = module.model_to_mesh(model, comm, rank, gdim=gdim)
    elif "partitioner" in inspect.signature(module.model_to_mesh).parameters:
        result = module.model_to_mesh(model, comm, rank, gdim=gdim, partitioner=partitioner)
    else:  # 0.5
        create_mesh = module.create_mesh

        def partitioned(comm, cells, x, domain):
            return create_mesh(comm, cells, x, domain, dolfinx.mesh.GhostMode.none, partitioner)

        module.create_mesh = partitioned
        try:
            result = module.model_to_mesh(model, comm, rank, gdim=gdim)
        finally:
            module.create_mesh = create_mesh
    if hasattr(result, "mesh"):
        return result.mesh, result.cell_tags, result.facet_tags
    return result[0], result[1], result[2]


#: The gmsh element types that every supported dolfinx reads as cells, with the names
#: the messages give them: complete Lagrange lines, triangles, quadrilaterals, tetrahedra
#: and hexahedra of order 1 and 2 (dolfinx 0.5 reads no prisms, pyramids, nor serendipity
#: elements; the package's geometries are of order 1 or 2).
GMSH_CELL_TYPES = {
    1: "lines", 2: "triangles", 3: "quadrilaterals", 4: "tetrahedra", 5: "hexahedra",
    8: "second-order lines", 9: "second-order triangles", 10: "second-order quadrilaterals",
    11: "second-order tetrahedra", 12: "second-order hexahedra",
}  # fmt: skip


def start_gmsh(gmsh) -> None:
    """Initialise gmsh without its terminal output and without reading the user's gmsh
    configuration files (the meshes are the same on every machine); gmsh from 4.9 is
    told to leave SIGINT alone (``interruptible``, see :func:`sigint_kept`)."""
    if "interruptible" in inspect.signature(gmsh.initialize).parameters:
        gmsh.initialize(readConfigFiles=False, interruptible=False)
    else:
        gmsh.initialize(readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)


@contextlib.contextmanager
def sigint_kept():
    """Put back, after the block, the SIGINT handler of its start (in the main thread).

    gmsh takes SIGINT: 4.8 sets it to the default action when it is imported (as
    dolfinx's ``gmshio`` does) and puts back the handler of that time when finalised;
    4.9 on set it when initialised, and 4.13 never puts it back. Ctrl-C would then kill
    Python instead of raising KeyboardInterrupt, and the run's own handler
    (:mod:`nitsche_dolfinx.common.signals`) could be lost.
    """
    main = threading.current_thread() is threading.main_thread()
    handler = signal.getsignal(signal.SIGINT) if main else None
    try:
        yield
    finally:
        if main and handler is not None:
            signal.signal(signal.SIGINT, handler)


def cell_partitioner(owners, num_vertices: int):
    """A cell partitioner for ``dolfinx.mesh.create_mesh`` (and :func:`gmsh_model_to_mesh`)
    that sends each cell to the rank ``owners(vertices, parts)`` gives it (``vertices``:
    the cells' vertices, shape (cells, num_vertices); ``parts``: the number of ranks).

    dolfinx 0.5 calls it with ``(comm, parts, tdim, cells as an AdjacencyList, ghost
    mode)`` and finds the vertices shared between ranks through ghost cells (dropped
    afterwards with ``GhostMode.none``): each cell also goes to the other ranks that own a
    cell with one of its vertices. dolfinx 0.9 on calls it with ``(comm, parts, cell
    types, cells as a list of arrays, one per cell type)`` and wants the owner alone.
    """

    def partition(comm, parts, *args):
        cells = next(a for a in args if hasattr(a, "array") or _arrays(a))
        legacy = hasattr(cells, "array")
        if legacy:
            cells = cells.array
        else:
            cells = np.concatenate([np.asarray(c).ravel() for c in cells])
        vertices = np.asarray(cells, dtype=np.int64).reshape(-1, num_vertices)
        ranks = np.asarray(owners(vertices, parts), dtype=np.int32)
        if legacy:
            return _with_sharing_ranks(vertices, ranks, parts)
        offsets = np.arange(len(vertices) + 1, dtype=np.int32)
        return dolfinx.cpp.graph.AdjacencyList_int32(ranks, offsets)

    return partition


def _arrays(value) -> bool:
    """Whether ``value`` is a non-empty list of arrays."""
    listed = isinstance(value, (list, tuple)) and len(value) > 0
    return listed and all(hasattr(v, "shape") for v in value)


def _with_sharing_ranks(vertices: np.ndarray, owners: np.ndarray, parts: int):
    """The destinations of cells given to ``owners`` for dolfinx 0.5 (see
    :func:`cell_partitioner`): each cell's owner, then the other ranks owning a cell that
    has one of its vertices."""
    holds = np.zeros((vertices.max(initial=-1) + 1, parts), dtype=bool)
    holds[vertices, owners[:, None]] = True
    sharing = holds[vertices].any(axis=1)  # (cells, parts)
    sharing[np.arange(len(owners)), owners] = False
    cells, ranks = np.nonzero(sharing)  # by cell, then by rank
    others = np.bincount(cells, minlength=len(owners))
    offsets = np.concatenate(([0], np.cumsum(1 + others))).astype(np.int32)
    destinations = np.empty(offsets[-1], dtype=np.int32)
    destinations[offsets[:-1]] = owners
    first = np.concatenate(([0], np.cumsum(others)[:-1]))  # of each cell's, in ``cells``
    destinations[offsets[cells] + 1 + np.arange(len(cells)) - first[cells]] = ranks
    return dolfinx.cpp.graph.AdjacencyList_int32(destinations, offsets)


def _import_gmshio():
    try:
        from dolfinx.io import gmshio  # 0.6 - 0.9
    except ImportError:  # 0.5: gmshio is a submodule that must be imported explicitly
        gmshio = importlib.import_module("dolfinx.io.gmshio")
    return gmshio


def write_meshtags(xdmf, tags, mesh) -> None:
    """Write mesh tags to an open XDMFFile (the geometry argument appeared in 0.6)."""
    try:
        xdmf.write_meshtags(tags, mesh.geometry)
    except TypeError:  # 0.5: the geometry is taken from the tags' mesh
        xdmf.write_meshtags(tags)


def mesh_keeping_cells(comm, cells: np.ndarray, x: np.ndarray, cell: str, degree: int, sharing):
    """A mesh with a Lagrange geometry of ``degree``, each of its cells kept on the rank that
    gives it: ``cells`` are this rank's cells as rows of global node indices (in the node
    order of the Lagrange element), ``x`` its consecutive share of the nodes (num_nodes,
    gdim), by global index.

    The partition is a function that sends every cell to its own rank. dolfinx 0.5 (whose
    ``create_mesh`` takes a ghost mode) finds the nodes shared between ranks through the
    ghost cells of that partition, and drops these cells afterwards for ``GhostMode.none``:
    there each cell also goes, as a ghost, to the other ranks that hold one of its nodes,
    given by ``sharing()`` (collective) as ``(offsets, ranks)``, the cell's own rank first.
    dolfinx 0.9 and 0.11 find the shared nodes by their global indices: the rank alone is
    given.
    """
    gdim = x.shape[1]
    ghost_mode = "ghost_mode" in inspect.signature(dolfinx.mesh.create_mesh).parameters
    if ghost_mode:  # 0.5
        offsets, ranks = sharing()
        element = ufl.VectorElement("Lagrange", ufl.Cell(cell, geometric_dimension=gdim), degree)
    else:
        import basix.ufl  # (from 0.7: absent with UFL 2022's elements)

        offsets = np.arange(len(cells) + 1)
        ranks = np.full(len(cells), comm.rank)
        element = basix.ufl.element("Lagrange", cell, degree, shape=(gdim,))
    destinations = dolfinx.cpp.graph.AdjacencyList_int32(
        np.asarray(ranks, dtype=np.int32), np.asarray(offsets, dtype=np.int32)
    )

    def partition(*args):
        return destinations

    cells = np.asarray(cells, dtype=np.int64).reshape(len(cells), -1)
    x = np.ascontiguousarray(x, dtype=np.float64)
    if ghost_mode:
        return dolfinx.mesh.create_mesh(
            comm, cells, x, ufl.Mesh(element), dolfinx.mesh.GhostMode.none, partition
        )
    return dolfinx.mesh.create_mesh(comm, cells, x=x, e=ufl.Mesh(element), partitioner=partition)


# -- plotting --------------------------------------------------------------------------


def vtk_mesh(V):
    """``(topology, cell types, points)`` of a function space for pyvista.

    ``dolfinx.plot.vtk_mesh`` from 0.7, ``create_vtk_mesh`` before.
    """
    function = getattr(dolfinx.plot, "vtk_mesh", None) or dolfinx.plot.create_vtk_mesh
    return function(V)


@contextlib.contextmanager
def own_symbols():
    """Let the libraries loaded in the block bind their own symbols first (RTLD_DEEPBIND).

    dolfinx 0.5 leaves RTLD_GLOBAL in the dlopen flags after its import, so that its
    C++ template instances (std::regex among them) come first for every library
    loaded later; VTK's pip wheels, built with another C++ ABI, then crash in
    std::regex (std::bad_alloc) when they draw a colour bar. Import pyvista (and
    render) inside this block.
    """
    flags = sys.getdlopenflags()
    sys.setdlopenflags(os.RTLD_NOW | getattr(os, "RTLD_DEEPBIND", 0))
    try:
        yield
    finally:
        sys.setdlopenflags(flags)


class _BuildLogFilter:
    """Drops the INFO lines of C compilers that setuptools logs on the root logger while
    FFCx/cffi compile a form (dolfinx 0.5: pages of ``INFO:root ... gcc ...``)."""

    @staticmethod
    def filter(record) -> bool:
        build = "distutils" in record.pathname or "setuptools" in record.pathname
        return not (build and record.levelno < 30)


def quiet_form_compilation() -> None:
    """Silence the compiler lines of form compilation, unless the environment variable
    ``NITSCHE_DOLFINX_VERBOSE`` is set (idempotent)."""
    root = logging.getLogger()
    if os.environ.get("NITSCHE_DOLFINX_VERBOSE") or any(
        isinstance(f, _BuildLogFilter) for f in root.filters
    ):
        return
    root.addFilter(_BuildLogFilter())
