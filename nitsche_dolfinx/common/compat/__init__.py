"""Every dolfinx, UFL, numpy and gmsh API difference between dolfinx 0.5.2 and 0.11, in one
package.

The rest of the package calls these shims as ``compat.<name>`` and never looks at a
version number. They live by topic in :mod:`.spaces` (function spaces, dof maps, expressions),
:mod:`.assembly` (PETSc objects, forms, solvers' options), :mod:`.meshes` (gmsh, partitions,
XDMF) and :mod:`.libraries` (numpy, pyvista, compiler logs), and are all imported here.
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

from .assembly import (
    CONSTANT_COUNT_HEADROOM,
    add_matrix_entries,
    apply_lifting,
    create_matrix,
    create_vector,
    divergence_tolerance,
    form_on_facets,
    has_mumps,
    petsc_vector,
    set_bc,
    stable_form_signatures,
)
from .libraries import own_symbols, quiet_form_compilation, trapezoid, vtk_mesh
from .meshes import (
    GMSH_CELL_TYPES,
    cell_partitioner,
    gmsh_model_to_mesh,
    mesh_keeping_cells,
    sigint_kept,
    start_gmsh,
    write_meshtags,
)
from .spaces import (
    cell_name,
    cells_containing,
    collapse,
    dofmap_array,
    element_degree,
    evaluate,
    expression,
    function_space,
    geometry_degree,
    geometry_dofmap,
    interpolation_points,
    mixed_function_space,
    node_coordinates,
)

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
    "quiet_form_compilation",
    "stable_form_signatures",
    "CONSTANT_COUNT_HEADROOM",
]
