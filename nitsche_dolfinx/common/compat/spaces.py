"""The version differences of function spaces and meshes' maps: making spaces (plain and
mixed), their dof maps and the geometry's, element and geometry degrees, the cells that hold
a point, and compiled expressions interpolated into a space or evaluated on cells.
"""

from __future__ import annotations

import inspect

import dolfinx.geometry
import numpy as np
import ufl
from dolfinx import fem

__all__ = [
    "cell_name",
    "cells_containing",
    "collapse",
    "dofmap_array",
    "element_degree",
    "evaluate",
    "expression",
    "function_space",
    "geometry_degree",
    "geometry_dofmap",
    "interpolation_points",
    "mixed_function_space",
    "node_coordinates",
]


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
