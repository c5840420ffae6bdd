"""The Dirichlet conditions on the dofs of a problem.

A :class:`DirichletCondition` prescribes the displacement, or one of its components, on
tagged facets, with a :class:`~nitsche_dolfinx.physics.problem_values.ProblemValue` (constant, in
time, or in space and time)
(:meth:`ContactProblem.add_dirichlet <nitsche_dolfinx.model.problem.ContactProblem.add_dirichlet>`);
:class:`DirichletDofs` finds its dofs and makes the dolfinx conditions the steppers impose.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from dolfinx import fem

from ..meshing.facet_selectors import facet_cells
from .problem_values import ProblemValue

__all__ = ["DirichletCondition", "DirichletDofs"]


@dataclass(frozen=True)
class DirichletCondition:
    """The displacement prescribed on the facets ``tag``: all its components, or only
    ``component`` (a symmetry plane or a roller when the value is zero).

    ``value`` holds a vector (or a scalar for one component), a function of t, or a value
    in space and time.
    """

    tag: int
    value: ProblemValue
    component: int | None = None

    @property
    def components(self) -> tuple[int, ...]:
        """The components of the displacement it prescribes."""
        if self.component is None:
            return tuple(range(self.value.shape[0]))
        return (self.component,)


class DirichletDofs:
    """The dofs of a problem's Dirichlet conditions on its space ``V``, and the dolfinx
    conditions that impose there the values of a Function.

    A condition on all components holds whole nodes (blocks of the dof array); one on
    a component k the dofs k of its nodes, imposed through the subspace ``V.sub(k)``.
    """

    def __init__(self, problem):
        V = problem.V
        self.V, self.bs = V, V.dofmap.index_map_bs
        fdim = problem.mesh.topology.dim - 1
        #: per condition: (its nodes, its local unblocked dofs, the condition)
        self.conditions = []
        for condition in problem.dirichlet:
            nodes = fem.locate_dofs_topological(V, fdim, problem.facets(condition.tag))
            dofs = (nodes[:, None] * self.bs + np.array(condition.components)).ravel()
            self.conditions.append((nodes, dofs, condition))
        # each dof once, with the last condition that prescribes it (as set_values leaves it)
        every = self.dofs[::-1]
        #: Each Dirichlet dof once (sorted).
        self.prescribed, last = np.unique(every, return_index=True)
        self._last = len(every) - 1 - last  # its last place among the conditions' dofs
        tags = [np.full(len(dofs), c.tag) for _, dofs, c in self.conditions]
        #: The tag of the condition that prescribes each dof of :attr:`prescribed`.
        self.prescribed_tags = np.concatenate(tags or [[]]).astype(np.int64)[self._last]
        # the values in space: interpolated on a cell of each of their facets only (one
        # holds every dof of the facet), and once when they do not depend on t
        self._cells = [
            np.unique(facet_cells(problem.mesh, problem.facets(c.tag))).astype(np.int32)
            if c.value.space_dependent else None
            for _, _, c in self.conditions
        ]  # fmt: skip
        self._field = None  # where they are interpolated
        self._fixed_values: dict[int, np.ndarray] = {}  # those constant in time

    def __bool__(self) -> bool:
        return bool(self.conditions)

    @property
    def dofs(self) -> np.ndarray:
        """Local (unblocked, with ghosts) indices of every Dirichlet dof."""
        return np.concatenate([dofs for _, dofs, _ in self.conditions] or [[]]).astype(np.int64)

    def set_values(self, target: np.ndarray, t: float) -> None:
        """Write the prescribed values at time t into the dof array ``target``."""
        for index, (_, dofs, _) in enumerate(self.conditions):
            target[dofs] = self._condition_values(index, t)

    def values(self, t: float) -> np.ndarray:
        """The values prescribed at time t at the dofs :attr:`prescribed`."""
        parts = [self._condition_values(index, t) for index in range(len(self.conditions))]
        return np.concatenate(parts or [np.zeros(0)])[self._last]

    def _condition_values(self, index: int, t: float) -> np.ndarray:
        """The values of condition ``index`` at time t at its dofs (node by node): a value
        constant in space repeated, one in space interpolated on the cells of its facets."""
        _, dofs, condition = self.conditions[index]
        value = condition.value
        if not value.space_dependent:
            values = value.value_at(t)  # one per component
            return np.tile(values, len(dofs) // len(values))
        if index in self._fixed_values:
            return self._fixed_values[index]
        if self._field is None:
            self._field = fem.Function(self.V)
        value.interpolate(self._field, t, self._cells[index])
        values = self._field.x.array[dofs]  # a copy
        if not value.time_dependent:
            self._fixed_values[index] = values
        return values

    def boundary_conditions(self, function: fem.Function) -> list:
        """The dolfinx conditions that give the Dirichlet dofs the values of ``function``
        (on V)."""
        bcs = []
        for nodes, dofs, condition in self.conditions:
            if condition.component is None:
                bcs.append(fem.dirichletbc(function, nodes))
            else:  # unblocked dofs of V, which index the values of function alike
                dofs = dofs.astype(np.int32)
                bcs.append(fem.dirichletbc(function, [dofs, dofs], self.V.sub(condition.component)))
        return bcs
