"""The reactions of the supports, and the work that loads and supports do, step by step
(docs/method.md section 13).

At a Dirichlet dof the step's equation is not solved: what it leaves there, the residual
F_i of ``M a + (internal and contact forces) - L`` at the solution, is the force the
support exerts on the body, its reaction R_i. The reaction of a Dirichlet tag is the sum
of R_i over the tag's dofs, per component (a dof two conditions prescribe counts with the
last one, whose value it takes).

Over a step the loads do the work L . (u^{n+1} - u^n) and the supports R . (u^{n+1} - u^n)
(on their own dofs), with the forces the scheme's energy identity sees: the hybrid
scheme's at t^{n+1/2} (its equation's), the trapezoid of the two levels' for the others
(Crank-Nicolson and Newmark (1/4, 1/2) are the trapezoidal rule on the forces).
"""

from __future__ import annotations

import numpy as np
from dolfinx import fem

from ..common.collective import sum_over_ranks
from .parts import StepEnds, StepPart

__all__ = ["ExternalWork", "reaction_columns"]


def reaction_columns(tags, gdim: int) -> tuple[str, ...]:
    """The history columns of the reactions of the Dirichlet ``tags``: ``reaction_<tag>`` in
    1D, else ``reaction_<tag>_x``, ``reaction_<tag>_y`` (, ``reaction_<tag>_z``)."""
    names = []
    for tag in tags:
        names += [f"reaction_{tag}"] if gdim == 1 else [f"reaction_{tag}_{c}" for c in "xyz"[:gdim]]
    return tuple(names)


class ExternalWork(StepPart):
    """The reactions per Dirichlet tag and the work of the loads and the supports since
    t = 0 (see the module docstring): a part of the steps
    (:class:`~nitsche_dolfinx.steppers.parts.StepPart`).

    Args:
        problem: The :class:`~nitsche_dolfinx.model.problem.ContactProblem`.
        dirichlet: Its :class:`~nitsche_dolfinx.physics.dirichlet.DirichletDofs`.
        midpoint: Whether the scheme's forces are those of the step's middle (the hybrid
            scheme); else the trapezoid of the two levels'.

    Attributes:
        loads, supports: The work of the loads and of the supports since t = 0.
        reaction: A Function holding the reaction at the Dirichlet dofs of the current level
            (zero elsewhere): a checkpoint keeps it, for the trapezoid of the next step.
    """

    def __init__(self, problem, dirichlet, midpoint: bool, loads):
        V = problem.V
        self._loads = loads
        self.comm, self.gdim, self.midpoint = problem.mesh.comm, problem.gdim, midpoint
        bs = V.dofmap.index_map_bs
        self._owned = V.dofmap.index_map.size_local * bs
        prescribed, tags = dirichlet.prescribed, dirichlet.prescribed_tags
        mine = prescribed < self._owned
        #: The owned Dirichlet dofs, and the column of each (tag and component).
        self.dofs = prescribed[mine]
        self.tags = sorted({condition.tag for condition in problem.dirichlet})
        #: The names of the reaction columns.
        self.names = reaction_columns(self.tags, self.gdim)
        per_tag = 1 if self.gdim == 1 else self.gdim
        place = {tag: k for k, tag in enumerate(self.tags)}
        self._column = np.array(
            [place[tag] * per_tag + (dof % bs if per_tag > 1 else 0)
             for dof, tag in zip(self.dofs, tags[mine])], dtype=np.int64,
        )  # fmt: skip
        self.reaction = fem.Function(V, name="reaction")
        self.loads, self.supports = 0.0, 0.0
        #: The loads' vector (owned dofs) of the current level.
        self.level_loads = None
        self._sums = np.zeros(len(self.names))

    def start(self, reaction: np.ndarray, loads: np.ndarray | None) -> None:
        """The reactions (at :attr:`dofs`) and the loads' vector (owned dofs) of the first
        level, or of a loaded one."""
        self._set_reaction(reaction)
        self.level_loads = loads

    @property
    def work(self) -> float:
        """The work of the loads and the supports since t = 0."""
        return self.loads + self.supports

    def step(self, ends: StepEnds) -> None:
        """Add the step's work (u^n and u^{n+1}, and the reactions and loads of its
        equation, of ``ends``)."""
        delta = ends.u1 - ends.u
        self.add_step(delta, ends.reactions(), ends.loads())

    def add_step(self, delta: np.ndarray, reaction: np.ndarray, loads: np.ndarray | None) -> None:
        """Add a step's work: ``delta`` = u^{n+1} - u^n (local dofs), ``reaction`` and
        ``loads`` those of its equation (the hybrid scheme's at t^{n+1/2}, the others' at
        t^{n+1})."""
        if self.midpoint:
            mean_reaction, mean_loads = reaction, loads
        else:
            mean_reaction = (self.reaction.x.array[self.dofs] + reaction) / 2
            mean_loads = None if loads is None else (self.level_loads + loads) / 2
        local = [float(mean_reaction @ delta[self.dofs]) if self.tags else 0.0, 0.0]
        if mean_loads is not None:
            local[1] = mean_loads @ delta[: self._owned]
        supports, loads_work = sum_over_ranks(self.comm, local)
        self.supports += float(supports)
        self.loads += float(loads_work)
        self._set_reaction(reaction)
        self.level_loads = loads

    def _set_reaction(self, reaction: np.ndarray) -> None:
        if not self.tags:  # no support: nothing to keep (and no communication a step)
            return
        self.reaction.x.array[:] = 0.0
        self.reaction.x.array[self.dofs] = reaction
        self.reaction.x.scatter_forward()
        local = np.bincount(self._column, weights=reaction, minlength=len(self.names))
        self._sums = sum_over_ranks(self.comm, local)

    def force_norm(self) -> float:
        """The Euclidean norm of the current level's loads and reactions together: the size
        of the forces a step's equation balances (collective)."""
        local = float(self.reaction.x.array[self.dofs] @ self.reaction.x.array[self.dofs])
        if self.level_loads is not None:
            local += float(self.level_loads @ self.level_loads)
        return float(np.sqrt(sum_over_ranks(self.comm, [local])[0]))

    def columns(self) -> dict[str, float]:
        """The reaction columns of the current level."""
        return {name: float(value) for name, value in zip(self.names, self._sums)}

    def saved(self) -> dict[str, float]:
        """The sums a checkpoint keeps (the reactions: :attr:`reaction`)."""
        return {"loads_work": self.loads, "supports_work": self.supports}

    def restore(self, saved: dict) -> None:
        """The sums of a loaded checkpoint, its reactions (loaded into :attr:`reaction`) and
        the loads' vector of its level (the problem at its time)."""
        self._restore(saved, self._loads())

    def _restore(self, saved: dict, loads: np.ndarray | None) -> None:
        self.loads = float(saved.get("loads_work", 0.0))
        self.supports = float(saved.get("supports_work", 0.0))
        self.start(self.reaction.x.array[self.dofs].copy(), loads)

    def running(self) -> tuple:
        return self.saved(), self.reaction.x.array.copy(), self.level_loads

    def put_back(self, running: tuple) -> None:
        saved, reaction, loads = running
        self.reaction.x.array[:] = reaction
        self._restore(saved, loads)

    def functions(self) -> dict:
        """The reactions of the level (for the next step's trapezoid), with supports."""
        return {"reaction": self.reaction} if len(self.tags) else {}
