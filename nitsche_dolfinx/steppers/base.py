"""What every stepper shares (:class:`~nitsche_dolfinx.steppers.implicit.NitscheStepper`,
:class:`~nitsche_dolfinx.steppers.explicit.ExplicitStepper`,
:class:`~nitsche_dolfinx.steppers.mixed.MixedStepper`): the :class:`Stepper` protocol that
:class:`~nitsche_dolfinx.simulation.Simulation` drives and the base class
:class:`StepperBase` (the state u, v, a and its copy, the description and the state a
checkpoint keeps, the opening of a restore), the initial state (u0, v0 and the consistent
a0, docs/method.md section 3), the energy control of a step (docs/method.md section 8), the
velocity of massless nodes and the loads' vector.
"""

from __future__ import annotations

import math
from typing import Any, Protocol

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc

from ..common import compat
from ..common.parameters import ParameterError
from ..model.problem import ContactProblem
from ..physics.damping import DiagonalDamping
from ..physics.problem_values import as_array
from ..solvers.linear_solvers import LinearSolver
from ..solvers.solver import SNESSolver, SolverError
from .timelevels import TimeLevels

__all__ = [
    "ENERGY_CONTROL",
    "LoadVector",
    "Stepper",
    "StepperBase",
    "UncontrolledStep",
    "check_initial_gap",
    "check_pairs_apart",
    "checkpoint_description",
    "energy_controlled",
    "initial_acceleration",
    "interpolate_initial",
    "massless_velocity",
    "owned_vector",
]


#: The least share of the kinetic plus elastic energy that E_Theta - potential must keep at
#: a new level (docs/method.md section 8). Measured: at least 0.9999 in the healthy runs
#: of the package (ring, friction block, every scheme); a P2 box whose gamma0 is beyond
#: the stability limit falls to 0.67, then 0.07, while E grows without bound.
ENERGY_CONTROL = 0.5


class UncontrolledStep(SolverError):
    """A step whose Newton solve converged to a state that E_Theta no longer controls
    (E_Theta - potential < :data:`ENERGY_CONTROL` (kinetic + elastic)), or whose
    diagnostics are not finite: the discrete problem has left its stability range.

    ``cut_may_help`` is False for lost energy control: it is a matter of gamma0 and the
    mesh, not of the step size.
    """

    def __init__(self, values: dict[str, float], iterations: int, hint: str):
        self.values = values
        self.inverted = _inverted(values)
        self.cut_may_help = self.inverted or not _finite_values(values)
        self._hint_text = hint
        super().__init__(0, iterations, float("nan"))
        if self.inverted:
            self.reason_name = "INVERTED"
        else:
            self.reason_name = "NOT_FINITE" if self.cut_may_help else "ENERGY_NOT_CONTROLLED"

    def _message(self) -> str:
        where = "" if self.step is None else f"at step {self.step} (t = {self.t:.6g}): "
        values = self.values
        if self.inverted:
            return (
                f"{where}an element is turned inside out (det F = {values['det_F_min']:.3g} "
                "<= 0): a smaller dt or gamma0 may keep it, but a law that gives way under "
                "strong compression (St Venant-Kirchhoff) does not; the neo-Hookean law resists "
                "it (docs/method.md section 15)"
            )
        if not _finite_values(values):
            return f"{where}the converged state is not finite (E = {values['energy']:.6g})"
        kinetic_elastic = values["kinetic"] + values["elastic"]
        controlled = values["energy_theta"] - values["potential"]
        return (
            f"{where}E_Theta no longer controls the energy: E_Theta - potential = "
            f"{controlled:.6g} for kinetic + elastic = {kinetic_elastic:.6g} (E = "
            f"{values['energy']:.6g}); {self._hint_text}"
        )


def _finite_values(values: dict[str, float]) -> bool:
    """Whether the diagnostics are finite (the penetration is -inf without contact)."""
    return all(math.isfinite(value) for key, value in values.items() if key != "penetration_max")


def _inverted(values: dict[str, float]) -> bool:
    """Whether an element is turned inside out (det F <= 0; finite strains only)."""
    return values.get("det_F_min", 1.0) <= 0.0


def energy_controlled(values: dict[str, float]) -> bool:
    """Whether the diagnostics of a level are finite and E_Theta - potential keeps at least
    :data:`ENERGY_CONTROL` of kinetic + elastic (docs/method.md section 8)."""
    if not _finite_values(values) or _inverted(values):
        return False
    kinetic_elastic = values["kinetic"] + values["elastic"]
    return values["energy_theta"] - values["potential"] >= ENERGY_CONTROL * kinetic_elastic


class Stepper(Protocol):
    """What :class:`~nitsche_dolfinx.simulation.Simulation` needs of a stepper.

    Attributes: ``problem``, ``scheme``, ``comm``; the clock of
    :class:`~nitsche_dolfinx.steppers.timelevels.TimeLevels` (``dt``, ``t``, ``step_index``,
    ``next_time()``, ``finished``, ...); the state ``u``, ``v``, ``a`` (Functions on
    ``problem.V``), and ``newton_iterations`` and ``step_seconds`` of the last step.
    """

    def step(self, t_new: float | None = None, cuts: int = 0) -> int:
        """Advance one step to ``t_new`` (default: the next nominal level), a step halved
        ``cuts`` times; return the Newton iterations. On a SolverError the state is
        that of before the step."""

    def state(self, columns=None) -> dict[str, float]:
        """The diagnostics of the current time level, identical on every rank; those that
        are optional only when ``columns`` name them (None: all)."""

    def output_fields(self) -> dict:
        """``{name: (source, value shape)}`` for the field output: a source is a Function, a
        UFL expression or an object with ``evaluate(target)`` (see
        :class:`~nitsche_dolfinx.output.writers.SolutionWriter`)."""

    def checkpoint_functions(self) -> dict[str, fem.Function]:
        """Everything the next step depends on, by name."""

    def describe(self) -> dict[str, Any]:
        """What a checkpoint must share with the stepper that reloads it."""

    def restore(self, t: float, step_index: int, saved: dict[str, Any]) -> None:
        """Move to a time level whose functions were just loaded (``saved``: the
        checkpoint's description)."""


def massless_velocity(massless, u, u1, v1, a1, dt) -> None:
    """At massless dofs (redistributed mass) the scheme's velocity update means nothing:
    the node follows its constraint. Report the step's mean velocity there instead."""
    if massless.size:
        v1[massless] = (u1[massless] - u[massless]) / dt
        a1[massless] = 0.0


def interpolate_initial(target: fem.Function, value, gdim: int) -> None:
    """Set ``target`` to an initial value: None (zero), a Function, a UFL vector of the
    position, a function of the coordinates returning (gdim, N) or (N,) values, or a
    constant vector."""
    if value is None:
        target.x.array[:] = 0.0
    elif isinstance(value, fem.Function):
        target.interpolate(value)
    elif isinstance(value, ufl.core.expr.Expr):  # of the position x
        if value.ufl_shape == ():
            value = ufl.as_vector([value])
        if value.ufl_shape != (gdim,):
            raise ValueError(f"initial {target.name} must have shape ({gdim},), got a UFL "
                             f"value of {value.ufl_shape}")  # fmt: skip
        target.interpolate(compat.expression(value, target.function_space))
    elif callable(value):
        target.interpolate(lambda x: np.asarray(value(x), dtype=float).reshape(gdim, -1))
    else:
        array = as_array(value, (gdim,), f"initial {target.name}")
        target.interpolate(lambda x: np.tile(array[:, None], (1, x.shape[1])))
    target.x.scatter_forward()
    finite = target.function_space.mesh.comm.allreduce(
        bool(np.all(np.isfinite(target.x.array))), op=MPI.LAND
    )
    if not finite:  # the value as given may be a function: not quoted
        what = f"initial {target.name}"
        raise ParameterError(what, None, "the initial values must be finite (nan or inf at a "
                             "node)", label=what)  # fmt: skip


def check_initial_gap(penetration: float, mesh) -> None:
    """Refuse a body that starts inside an obstacle: ``penetration`` is the largest
    u_n - g on Gamma_C at t = 0, allowed up to round-off of the mesh's extent."""
    x = mesh.geometry.x
    extent = mesh.comm.allreduce(float(np.abs(x).max(initial=0.0)), op=MPI.MAX)
    if penetration > 1e-8 * max(extent, 1e-300):
        raise ParameterError(
            "initial_displacement",
            penetration,
            "it must start outside (u_n <= g on Gamma_C)",
            label=f"initial displacement: the body starts {penetration:.3g} inside an obstacle",
        )


def check_pairs_apart(problem: ContactProblem, u: fem.Function) -> None:
    """Refuse contact pairs pressed together at t = 0 (a positive contact force): the
    initial acceleration leaves out the reaction on the master side."""
    if not problem.pairs:
        return
    problem.update_partners()
    force = sum(pair.force(u) for pair in problem.pairs)
    value = problem.mesh.comm.allreduce(fem.assemble_scalar(fem.form(force)), op=MPI.SUM)
    if value > 0:
        raise ParameterError(
            "initial_displacement",
            value,
            "the bodies of a contact pair must start apart",
            label=f"initial state: the bodies of a contact pair press on each other "
            f"(contact force {value:.3g})",
        )


def initial_acceleration(
    problem: ContactProblem, a: fem.Function, stiffness, dirichlet, petsc_options=None,
    linear_solver: LinearSolver | None = None, velocity: fem.Function | None = None,
) -> np.ndarray:  # fmt: skip
    """Solve M a0 = L(0) - ``stiffness`` - C v0 for ``a`` (docs/method.md sections 3 and
    14), with a0 = 0 at the Dirichlet dofs (``dirichlet``, a :class:`DirichletDofs`) and at
    the massless dofs of a redistributed mass, by the linear solver of the steps.

    ``stiffness(test)`` is the operator at u0 tested with ``test``; ``velocity`` v0, for the
    damping force C v0 (with damping). Returns the equation's residual M a0 + ``stiffness``
    + C v0 - L(0) (owned dofs): at the Dirichlet dofs, the supports' reactions at t = 0
    (docs/method.md section 13)."""
    V = problem.V
    test = ufl.TestFunction(V)
    F0 = problem.inertia(a, test) + stiffness(test) - problem.load(test)
    damped = problem.damping is not None and velocity is not None
    if damped:
        F0 = F0 + problem.damping_force(velocity, test)
    zero = fem.Function(V)
    bcs = dirichlet.boundary_conditions(zero)
    diagonal = problem.mass_diagonal()
    if damped and diagonal is not None:  # alpha D v0 (docs/method.md section 14)
        diagonal = DiagonalDamping(diagonal, problem.damping.alpha, lambda: velocity.x.array)
    if diagonal is not None:  # massless nodes (redistributed mass): no acceleration of their own
        bcs.append(fem.dirichletbc(zero, problem.massless_dofs(nodes=True)))
    a.x.array[:] = 0.0
    solver = SNESSolver(
        F0,
        a,
        bcs,
        petsc_options=petsc_options,
        mass_diagonal=diagonal,
        linear_solver=linear_solver,
    )
    if problem.has_loads:  # a body in equilibrium at rest: F(0) is round-off of these
        loads = compat.create_vector(V)
        with loads.localForm() as local:
            local.set(0.0)
        fem_petsc.assemble_vector(loads, fem.form(problem.load(test)))
        loads.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        solver.force_scale = loads.norm()
        loads.destroy()
    solver.solve()
    x, b = compat.petsc_vector(a).copy(), compat.create_vector(V)
    solver.system.assemble_residual(x, b, conditions=False)
    residual = b.array_r.copy()
    for vector in (x, b):
        vector.destroy()
    solver.destroy()
    return residual


def checkpoint_description(stepper) -> dict[str, Any]:
    """The description a checkpoint of any stepper shares with the run that reloads it."""
    problem = stepper.problem
    V = problem.V
    friction = problem.friction
    description = {
        "friction": 0.0 if friction is None else float(np.asarray(friction.value)),
        "dofs": int(V.dofmap.index_map.size_global * V.dofmap.index_map_bs),
        "dt": stepper.dt,
        "scheme": stepper.scheme.describe(),
        "method": problem.method,
        "mass": problem.mass,
        "degree": problem.degree,
        "gamma0": float(np.asarray(problem.gamma0.value)),
        "gamma0_scaling": problem.gamma0_scaling,
        "nitsche_theta": float(np.asarray(problem.nitsche_theta.value)),
        "functions": sorted(stepper.checkpoint_functions()),
    }
    if problem.damping is not None:  # (absent without damping: older checkpoints fit)
        description["damping"] = list(problem.damping.values)
    return description


def owned_vector(form: fem.Form, V) -> np.ndarray:
    """The vector of the linear ``form`` on ``V``, assembled and summed over the ranks: its
    owned entries."""
    vector = compat.create_vector(V)
    with vector.localForm() as local:
        local.set(0.0)
    fem_petsc.assemble_vector(vector, form)
    vector.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    values = vector.array_r.copy()
    vector.destroy()
    return values


class LoadVector:
    """The vector of a load ``form`` at the problem's time (owned dofs), assembled once when
    the problem's loads do not depend on t (:attr:`ContactProblem.loads_in_time`)."""

    def __init__(self, problem: ContactProblem, form: fem.Form):
        self.problem, self.form = problem, form
        self._values = None

    def __call__(self) -> np.ndarray:
        if self._values is None or self.problem.loads_in_time:
            self._values = owned_vector(self.form, self.problem.V)
        return self._values


class StepperBase(TimeLevels):
    """What every stepper of the package holds alike: the problem, its scheme and the clock
    (:class:`~nitsche_dolfinx.steppers.timelevels.TimeLevels`), the state u, v, a and its
    copy to put back after a refused step, the description and the state a checkpoint
    keeps, the opening of :meth:`restore`, and the columns of the clock and the solve."""

    def _start(self, problem: ContactProblem, scheme, time_stepping) -> None:
        """The problem, the scheme, the clock from ``time_stepping`` (None: started later)
        and the state u, v, a (zero) on the problem's space."""
        self.problem, self.scheme = problem, scheme
        if time_stepping is not None:
            self._start_levels(time_stepping)
        self.comm = problem.mesh.comm
        V = problem.V
        self.u = fem.Function(V, name="displacement")
        self.v = fem.Function(V, name="velocity")
        self.a = fem.Function(V, name="acceleration")
        self.newton_iterations, self.step_seconds = 0, 0.0
        self._previous = [np.empty_like(f.x.array) for f in (self.u, self.v, self.a)]

    def _keep_state(self) -> None:
        """Copy u^n, v^n, a^n, to put back should the step be refused."""
        for previous, function in zip(self._previous, (self.u, self.v, self.a)):
            previous[:] = function.x.array

    def _put_back_state(self) -> None:
        """u, v, a of the last level again (:meth:`_keep_state`)."""
        for previous, function in zip(self._previous, (self.u, self.v, self.a)):
            function.x.array[:] = previous

    def _state_functions(self) -> dict[str, fem.Function]:
        """The state by name: u, v and a."""
        return {"displacement": self.u, "velocity": self.v, "acceleration": self.a}

    def checkpoint_functions(self) -> dict[str, fem.Function]:
        """Everything the next step depends on, by name: the state."""
        return self._state_functions()

    def describe(self) -> dict[str, Any]:
        """What a checkpoint shares with the stepper that reloads it
        (:func:`checkpoint_description`)."""
        return checkpoint_description(self)

    def restore(self, t: float, step_index: int, saved: dict[str, Any]) -> None:
        """Move to a time level whose functions were just loaded (``saved``: the
        checkpoint's description and levels): the clock, the last step's Newton
        iterations and the data at ``t``."""
        self._restore_levels(t, step_index, saved)
        self.newton_iterations = int(saved.get("newton_iterations", 0))
        self.step_seconds = 0.0
        self.problem.set_time(t)

    def _clock_columns(self) -> dict[str, float]:
        """The history columns of the last step's solve and size."""
        return {
            "newton_iterations": self.newton_iterations,
            "step_seconds": self.step_seconds,
            "dt": self.last_dt,
            "step_cuts": self.step_cuts,
        }
