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

__all__ = ["ExternalWork", "reaction_columns"]


def reaction_columns(tags, gdim: int) -> tuple[str, ...]:
    """The history columns of the reactions of the Dirichlet ``tags``: ``reaction_<tag>`` in
    1D, else ``reaction_<tag>_x``, ``reaction_<tag>_y`` (, ``reaction_<tag>_z``)."""
    names = []
    for tag in tags:
        names += [f"reaction_{tag}"] if gdim == 1 else [f"reaction_{tag}_{c}" for c in "xyz"[:gdim]]
    return tuple(names)


class ExternalWork:
    """The reactions per Dirichlet tag and the work of the loads and the supports since
    t = 0 (see the module docstring).

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

    def __init__(self, problem, dirichlet, midpoint: bool):
        V = problem.V
        self.comm, self.gdim, self.midpoint = problem.mesh.comm, problem.gdim, midpoint
        bs = V.dofmap.index_map_bs
        self._owned = V.dofmap.index_map.size_local * bs
        prescribed, tags = dirichlet.prescribed, dirichlet.prescribed_tags
        mine = prescribed < self._owned
        #: The owned Dirichlet dofs, and the column of each (tag and component).
        self.dofs = prescribed[mine]
        self.tags = sorted({condition.tag for condition in problem.dirichlet})
        self.columns = reaction_columns(self.tags, self.gdim)
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
        self._sums = np.zeros(len(self.columns))

    def start(self, reaction: np.ndarray, loads: np.ndarray | None) -> None:
        """The reactions (at :attr:`dofs`) and the loads' vector (owned dofs) of the first
        level, or of a loaded one."""
        self._set_reaction(reaction)
        self.level_loads = loads

    def step(self, delta: np.ndarray, reaction: np.ndarray, loads: np.ndarray | None) -> None:
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
        local = np.bincount(self._column, weights=reaction, minlength=len(self.columns))
        self._sums = sum_over_ranks(self.comm, local)

    def force_norm(self) -> float:
        """The Euclidean norm of the current level's loads and reactions together: the size
        of the forces a step's equation balances (collective)."""
        local = float(self.reaction.x.array[self.dofs] @ self.reaction.x.array[self.dofs])
        if self.level_loads is not None:
            local += float(self.level_loads @ self.level_loads)
        return float(np.sqrt(sum_over_ranks(self.comm, [local])[0]))

    def values(self) -> dict[str, float]:
        """The reaction columns of the current level."""
        return {name: float(value) for name, value in zip(self.columns, self._sums)}

    def saved(self) -> dict[str, float]:
        """The sums a checkpoint keeps (the reactions: :attr:`reaction`)."""
        return {"loads_work": self.loads, "supports_work": self.supports}

    def restore(self, saved: dict, loads: np.ndarray | None) -> None:
        """The sums of a loaded checkpoint, its reactions (loaded into :attr:`reaction`) and
        the loads' vector of its level."""
        self.loads = float(saved.get("loads_work", 0.0))
        self.supports = float(saved.get("supports_work", 0.0))
        self.start(self.reaction.x.array[self.dofs].copy(), loads)


class BalanceSums:
    """The energy balance of a stepper (docs/method.md section 13), a base of both steppers:
    the running sums of the work of moving obstacles and the contact dissipation
    (``_obstacles``, an :class:`~nitsche_dolfinx.steppers.obstacle_work.ObstacleWork` or None), of
    the
    loads' and supports' work (``_external``, an :class:`ExternalWork` or None), of the
    friction (``_friction_total``) and damping (``damping_dissipation``) dissipation, and
    the internal energy at t = 0 (``_internal_energy0``)."""

    _obstacles = None
    _external = None
    #: Whether every dissipation is summed (no obstacle whose contact dissipation is left
    #: out): ``energy_balance`` is reported only then.
    _dissipation_known = True
    _friction_total = 0.0
    damping_dissipation = 0.0
    _internal_energy0 = 0.0

    def _internal_energy(self) -> float:
        """E_Theta without the loads' potential at the current level: what the work of the
        loads changes."""
        values = self.diagnostics.of_level(self.step_index)
        return values["energy_theta"] - values["potential"]

    def _work_columns(self) -> dict[str, float]:
        """The work of the loads, supports and moving obstacles since t = 0 (``work``), and
        ``energy_balance``: the change of the internal energy, plus what friction, damping
        and the contact terms dissipated, less that work (zero to the solver's tolerance for
        the hybrid scheme, Crank-Nicolson and Newmark (1/4, 1/2) with Theta = 1)."""
        work, dissipated = 0.0, self._friction_total + self.damping_dissipation
        if self._obstacles is not None:
            work += self._obstacles.work
            dissipated += self._obstacles.dissipation
        if self._external is not None:
            work += self._external.loads + self._external.supports
        if not self._dissipation_known:
            return {"work": work}
        change = self._internal_energy() - self._internal_energy0
        return {"work": work, "energy_balance": change + dissipated - work}

    def _keeps_accounts(self, problem) -> bool:
        """Whether the contact terms' dissipation is summed: with an obstacle, when the
        problem's energy is not kept by itself (supports, data or obstacles that move,
        damping). An autonomous problem's E_Theta is its own balance, and the two
        assemblies on Gamma_C a step would cost it some 6% of a free step (the talk's
        ball), and Verlet as much as a step."""
        obstacles = any(contact not in problem.pairs for contact in problem.contacts)
        needed = bool(problem.dirichlet) or not problem.autonomous
        needed = needed or problem.damping is not None
        self._dissipation_known = not obstacles or needed
        return obstacles and needed

    def _balance_columns(self) -> dict[str, float]:
        """The columns of the energy balance at the current level."""
        values = {} if self._obstacles is None else self._obstacles.values()
        if self._external is not None:
            values.update(self._external.values())
        return {**values, **self._work_columns()}

    def _running_sums(self) -> tuple:
        """The running sums (to put back after a refused step)."""
        external = None
        if self._external is not None:
            external = (self._external.saved(), self._external.reaction.x.array.copy(),
                        self._external.level_loads)  # fmt: skip
        obstacles = None if self._obstacles is None else self._obstacles.saved()
        return obstacles, external

    def _restore_sums(self, sums: tuple) -> None:
        obstacles, external = sums
        if obstacles is not None:
            self._obstacles.restore(obstacles)
        if external is not None:
            saved, reaction, loads = external
            self._external.reaction.x.array[:] = reaction
            self._external.restore(saved, loads)

    def _saved_sums(self) -> dict[str, float]:
        """The sums, for a checkpoint."""
        sums = {"friction_total": self._friction_total,
                "internal_energy0": self._internal_energy0}  # fmt: skip
        if self._obstacles is not None:
            sums.update(self._obstacles.saved())
        if self._external is not None:
            sums.update(self._external.saved())
        return sums

    def _load_sums(self, saved: dict, loads) -> None:
        """The sums of a loaded checkpoint (its reactions already in ``_external``'s Function)
        and the loads' vector ``loads`` of its level."""
        if self._obstacles is not None:
            self._obstacles.restore(saved)
        self._friction_total = float(saved.get("friction_total", 0.0))
        self._internal_energy0 = float(saved.get("internal_energy0", self._internal_energy0))
        if self._external is not None:
            self._external.restore(saved, loads)

    def _balance_functions(self) -> dict:
        """The Functions a checkpoint keeps for the balance: the reactions of the level
        (for the next step's trapezoid)."""
        if self._external is None or not len(self._external.tags):
            return {}
        return {"reaction": self._external.reaction}
