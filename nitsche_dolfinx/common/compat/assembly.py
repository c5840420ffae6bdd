"""The version differences of PETSc objects and assembly: the PETSc vector of a Function,
vectors and matrices of a space or a form, matrix entries added without a flush, a compiled
form over other facets, Dirichlet lifting, the signatures of forms kept stable for FFCx's
cache, and the solvers' options (MUMPS, SNES's divergence tolerance).
"""

from __future__ import annotations

import functools
import inspect
import itertools

import cffi
import numpy as np
import ufl
from dolfinx import cpp, fem, la
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc

__all__ = [
    "CONSTANT_COUNT_HEADROOM",
    "add_matrix_entries",
    "apply_lifting",
    "create_matrix",
    "create_vector",
    "divergence_tolerance",
    "form_on_facets",
    "has_mumps",
    "petsc_vector",
    "set_bc",
    "stable_form_signatures",
]


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
