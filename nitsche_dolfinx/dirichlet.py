"""Values prescribed in time, and the Dirichlet conditions on the dofs of a problem.

A :class:`TimeDependentValue` holds a load or a Dirichlet value, a constant or a function
of t, in a ``fem.Constant`` that follows the time. A :class:`DirichletCondition` prescribes
the displacement, or one of its components, on tagged facets
(:meth:`ContactProblem.add_dirichlet <nitsche_dolfinx.model.ContactProblem.add_dirichlet>`);
:class:`DirichletDofs` finds its dofs and makes the dolfinx conditions the steppers impose.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from dolfinx import fem

from .keys import LARGEST

__all__ = ["DirichletCondition", "DirichletDofs", "TimeDependentValue", "as_array"]


class TimeDependentValue:
    """A constant or a function of t, held in a ``fem.Constant`` that follows the time."""

    def __init__(self, mesh, value, shape: tuple[int, ...], what: str):
        self._function = value if callable(value) else None
        initial = value(0.0) if callable(value) else value
        self.constant = fem.Constant(mesh, as_array(initial, shape, what))
        self.shape = shape
        self.what = what

    @property
    def time_dependent(self) -> bool:
        """Whether the value is a function of t."""
        return self._function is not None

    def value_at(self, t: float) -> np.ndarray:
        if self._function is None:
            return np.asarray(self.constant.value)
        return as_array(self._function(t), self.shape, self.what)

    def set_time(self, t: float) -> None:
        if self._function is not None:
            self.constant.value = self.value_at(t)


def as_array(value, shape, what) -> np.ndarray:
    """``value`` as an array of ``shape`` (a number for ``(1,)``), of finite numbers of
    magnitude at most :data:`~nitsche_dolfinx.keys.LARGEST`; ValueError naming ``what``."""
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be numbers, got {value!r}") from None
    if array.shape != shape:
        if array.size != 1 or shape != (1,):
            raise ValueError(f"{what} must have shape {shape}, got {array.tolist()!r}")
        array = array.reshape(shape)
    if not (np.all(np.isfinite(array)) and np.all(np.abs(array) <= LARGEST)):
        raise ValueError(
            f"{what} must be finite, of magnitude at most {LARGEST:g}, got {array.tolist()!r}"
        )
    return array


@dataclass(frozen=True)
class DirichletCondition:
    """The displacement prescribed on the facets ``tag``: all its components, or only
    ``component`` (a symmetry plane or a roller when the value is zero).

    ``value`` holds a vector (or a scalar for one component) or a function of t.
    """

    tag: int
    value: TimeDependentValue
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

    def __bool__(self) -> bool:
        return bool(self.conditions)

    @property
    def dofs(self) -> np.ndarray:
        """Local (unblocked, with ghosts) indices of every Dirichlet dof."""
        return np.concatenate([dofs for _, dofs, _ in self.conditions] or [[]]).astype(np.int64)

    def set_values(self, target: np.ndarray, t: float) -> None:
        """Write the prescribed values at time t into the dof array ``target``."""
        for _, dofs, condition in self.conditions:
            values = condition.value.value_at(t)  # one per component, dofs node by node
            target[dofs] = np.tile(values, len(dofs) // len(values))

    def values(self, t: float) -> np.ndarray:
        """The values prescribed at time t at the dofs :attr:`prescribed`."""
        parts = [
            np.tile(condition.value.value_at(t), len(dofs) // len(condition.components))
            for _, dofs, condition in self.conditions
        ]
        return np.concatenate(parts or [np.zeros(0)])[self._last]

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
