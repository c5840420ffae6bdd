"""What a run reads on a part of the body, reduced over MPI: the mean of an expression over a
boundary part or any measure (:class:`BoundaryAverage`, a history column), a field on the
contact boundary by a lumped L2 projection (:class:`BoundaryField`, for output), the value
of a Function at a point (:class:`PointValue`), and a scalar form over the whole mesh
(:func:`assemble_global`).

A local ``assemble_scalar`` is only this rank's share: every value here is an
``allreduce`` over the mesh's communicator.
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from petsc4py import PETSc

from ..common import compat
from ..common.collective import sum_over_ranks

__all__ = ["BoundaryAverage", "BoundaryField", "PointValue", "assemble_global"]


def assemble_global(form, comm) -> float:
    """The value of a compiled scalar form over the whole mesh."""
    return float(sum_over_ranks(comm, [fem.assemble_scalar(form)])[0])


class BoundaryAverage:
    """Mean value of a scalar expression over a tagged boundary part (or over any
    measure: with ``dx``, the mean over the body).

    On a 1D mesh, where a boundary part is one point, this is the point value:
    the bar demo reads u(t, 0) and lambda_h(t, 0) this way.
    """

    def __init__(self, mesh, expression, ds):
        self.comm = mesh.comm
        self._integral = fem.form(expression * ds)
        self._measure = assemble_global(fem.form(fem.Constant(mesh, 1.0) * ds), self.comm)
        if self._measure == 0.0:
            raise ValueError("the boundary part has zero measure: is its tag in the mesh?")

    def __call__(self) -> float:
        return assemble_global(self._integral, self.comm) / self._measure


class BoundaryField:
    """A field on the contact boundary, for output: the lumped L2 projection of
    ``int_Gamma f . mu`` onto the P1 dofs of Gamma, zero elsewhere.

    The source is a linear form ``L(mu)`` in the P1 test function ``mu``, given as a
    function ``source(mu)`` (for friction: the traction or slip velocity of the last
    step, which the time scheme writes); the value at a boundary node is
    ``L(phi_i) / int_Gamma phi_i``. P1 keeps the lumped mass positive on every cell
    type (P2 vertex functions integrate to zero on triangles).

    Args:
        mesh: The mesh.
        shape: Value shape, ``()`` or ``(gdim,)``.
        ds: Measure of the boundary part (a sum of tagged measures is fine).
        source: ``source(mu) -> form`` linear in the test function mu.
        name: Name of the field in the output.
    """

    def __init__(self, mesh, shape, ds, source, name: str):
        V = compat.function_space(mesh, "Lagrange", 1, shape)
        self.function = fem.Function(V, name=name)
        mu = ufl.TestFunction(V)
        ones = ufl.as_vector([1.0] * shape[0]) if shape else fem.Constant(mesh, 1.0)
        lumped = compat.create_vector(V)
        fem_petsc.assemble_vector(lumped, fem.form(ufl.inner(ones, mu) * ds))
        lumped.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        self._lumped = lumped.array.copy()  # owned entries
        lumped.destroy()
        self._on_boundary = self._lumped > 0
        self._form = fem.form(source(mu))
        self._rhs = compat.create_vector(V)

    def update(self) -> None:
        """Re-evaluate the source into :attr:`function`."""
        rhs = self._rhs
        with rhs.localForm() as local:
            local.set(0.0)
        fem_petsc.assemble_vector(rhs, self._form)
        rhs.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        values = np.zeros_like(self._lumped)
        values[self._on_boundary] = rhs.array[self._on_boundary] / self._lumped[self._on_boundary]
        self.function.x.array[: values.size] = values
        self.function.x.scatter_forward()


class PointValue:
    """The value of a Function (or of one of its components) at a point of the body in
    its reference configuration, for a history column: the same number on every rank.

    The point's cell is found once; at each call, the rank that owns it (the lowest such
    rank when the point lies between cells) evaluates the Function and sends the value to
    the others. ``simulation.add_probe("u_top", PointValue(simulation.u, [0, 40], 1))``.

    Args:
        function: The Function (``simulation.u``, ``simulation.v``, ...).
        point: The point, with the mesh's coordinates (1 to 3 of them).
        component: The component of a vector Function (0 for x, ...); None for a scalar
            Function.

    Raises:
        ValueError: The point is in no cell of the mesh, or the component does not fit.
    """

    def __init__(self, function: fem.Function, point, component: int | None = None):
        mesh = function.function_space.mesh
        self.comm = mesh.comm
        self.function = function
        size = int(np.prod(function.ufl_shape)) if function.ufl_shape else 1
        if component is None and size != 1:
            raise ValueError(f"{function.name} has {size} components: give the component")
        if component is not None and not 0 <= int(component) < size:
            raise ValueError(f"component={component!r}: {function.name} has {size} components")
        self.component = 0 if component is None else int(component)
        self.point = np.zeros((1, 3))
        coordinates = np.asarray(point, dtype=float).reshape(-1)
        self.point[0, : coordinates.size] = coordinates
        cells = compat.cells_containing(mesh, self.point)
        owned = mesh.topology.index_map(mesh.topology.dim).size_local
        cells = [c for c in cells if c < owned]
        self.cell = cells[0] if cells else -1
        ranks = self.comm.allgather(self.cell >= 0)
        if not any(ranks):
            raise ValueError(f"the point {coordinates.tolist()} is in no cell of the mesh")
        self.root = ranks.index(True)

    def __call__(self) -> float:
        value = None
        if self.comm.rank == self.root:
            values = self.function.eval(self.point, np.array([self.cell], dtype=np.int32))
            value = float(np.asarray(values).reshape(-1)[self.component])
        return self.comm.bcast(value, root=self.root) if self.comm.size > 1 else value
