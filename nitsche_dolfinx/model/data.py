"""The data of a :class:`~nitsche_dolfinx.model.problem.ContactProblem`: Dirichlet
conditions, loads (body forces and tractions), initial values, and the load L(t)(v) the
time schemes assemble, at the time of the problem's data.
"""

from __future__ import annotations

import dolfinx.mesh
import numpy as np
import ufl
from dolfinx import fem

from ..common import compat
from ..common.parameters import require
from ..physics.dirichlet import DirichletCondition
from ..physics.expressions import has_text, vector_expression
from ..physics.problem_values import ProblemValue, check_finite_texts

__all__ = ["ProblemData"]


class ProblemData:
    """The loads, conditions and initial values of
    :class:`~nitsche_dolfinx.model.problem.ContactProblem` (one of its parts: it reads the
    problem's ``mesh``, ``gdim``, ``dx``, ``ds``, ``facets`` and ``moving_contacts``).
    """

    def _init_data(self) -> None:
        """No condition, load nor initial value yet."""
        self.dirichlet: list[DirichletCondition] = []
        self._body_forces: list[ProblemValue] = []
        self._tractions: list[tuple[int, ProblemValue]] = []
        self.initial_displacement = None
        self.initial_velocity = None
        self._node_coordinates = None  # of V's nodes, when a check of the data needs them

    def _value(self, value, shape: tuple[int, ...], what: str) -> ProblemValue:
        """A value of the problem's data
        (:class:`~nitsche_dolfinx.physics.problem_values.ProblemValue`):
        a constant, a function of t, a UFL expression of :attr:`x` and :attr:`t`, or a list
        of numbers and texts of the expression language
        (:mod:`~nitsche_dolfinx.physics.expressions`:
        x, y, z, t, + - * / ^, sin, cos, exp, ..., 'a if condition else b')."""
        return ProblemValue(self.mesh, self.t, value, shape, what)

    def add_dirichlet(self, tag: int, value=0.0, component: int | None = None) -> None:
        """Prescribe the displacement on the facets ``tag``: a vector (or scalar in 1D),
        a function of t returning one, or a value in space and time (as for
        :meth:`add_body_force`; interpolated at the facets' nodes).

        With ``component=k``, only the component k of the displacement (0 for x, 1 for
        y, 2 for z), the others left free: ``value`` is then a scalar or a function of t
        returning one. ``add_dirichlet(tag, 0.0, component=0)`` is a symmetry plane x =
        const, or a roller on it.
        """
        facets = self.facets(tag)
        if component is None or self.gdim == 1:
            require(
                component in (None, 0),
                "component",
                component,
                "the displacement of a 1D mesh has one component, 0",
            )
            value = self._value(value, (self.gdim,), "Dirichlet value")
            value.check_finite(lambda: self._nodes(facets), self.mesh.comm)
            self.dirichlet.append(DirichletCondition(tag, value))
            return
        require(
            isinstance(component, (int, np.integer))
            and not isinstance(component, bool)
            and 0 <= component < self.gdim,
            "component",
            component,
            f"the displacement has the components 0 to {self.gdim - 1}",
        )
        value = self._value(value, (1,), "Dirichlet value of a component")
        value.check_finite(lambda: self._nodes(facets), self.mesh.comm)
        self.dirichlet.append(DirichletCondition(tag, value, int(component)))

    def add_body_force(self, value) -> None:
        """Add a volume force f: a vector, a function of t returning one, or a value in space
        and time (a UFL vector of :attr:`x` and :attr:`t`, or a list of numbers and
        expression texts such as ``[0, "-9.81 * (1 + x)"]``: :meth:`_value`)."""
        force = self._value(value, (self.gdim,), "body force")
        force.check_finite(lambda: self._midpoints(self.mesh.topology.dim), self.mesh.comm)
        self._body_forces.append(force)

    def add_traction(self, tag: int, value) -> None:
        """Add a Neumann traction g_N on the facets ``tag``: a vector, a function of t, or a
        value in space and time (as for :meth:`add_body_force`)."""
        facets = self.facets(tag)
        traction = self._value(value, (self.gdim,), "traction")
        fdim = self.mesh.topology.dim - 1
        traction.check_finite(lambda: self._midpoints(fdim, facets), self.mesh.comm)
        self._tractions.append((tag, traction))

    def set_initial_conditions(self, displacement=None, velocity=None) -> None:
        """Initial displacement u0 and velocity v0 (zero when omitted).

        Each is a constant vector, a function of the coordinates ``x`` (shape (3, N))
        returning the values (shape (gdim, N), or (N,) in 1D), a Function on the
        displacement space, a UFL vector of :attr:`x`, or a list of numbers and expression
        texts of x, y, z (:mod:`~nitsche_dolfinx.physics.expressions`; no t), e.g.
        ``["0.1 * sin(pi * x)", 0]``.
        """
        self.initial_displacement = self._field(displacement, "initial displacement",
                                                "displacement")  # fmt: skip
        self.initial_velocity = self._field(velocity, "initial velocity", "velocity")

    def _field(self, value, what: str, name: str):
        """An initial field as :func:`~nitsche_dolfinx.steppers.base.interpolate_initial` takes
        it: expression texts made UFL of x (refused with t, or not finite at a node)."""
        if not has_text(value):
            return value
        texts = [value] if isinstance(value, str) else list(value)
        field = vector_expression(texts, self.mesh, None, name=what)
        check_finite_texts(texts, self.gdim, lambda: self._nodes(), self.mesh.comm, None,
                           name, value, what)  # fmt: skip
        return field

    def _nodes(self, facets=None) -> np.ndarray:
        """The coordinates (shape (gdim, N)) of the nodes of the displacement space on this
        rank, or of those of ``facets``: where Dirichlet values and initial fields are
        interpolated."""
        if self._node_coordinates is None:
            self._node_coordinates = compat.node_coordinates(self.V)
        nodes = self._node_coordinates
        if facets is not None:
            fdim = self.mesh.topology.dim - 1
            nodes = nodes[fem.locate_dofs_topological(self.V, fdim, facets)]
        return nodes.T

    def _midpoints(self, dim: int, entities=None) -> np.ndarray:
        """The midpoints (shape (3, N)) of this rank's cells (``dim`` the mesh's) or of the
        ``entities`` of dimension ``dim``: points where the loads are integrated, checked
        before a run."""
        if entities is None:
            entities = np.arange(self.mesh.topology.index_map(dim).size_local, dtype=np.int32)
        if len(entities) == 0:
            return np.zeros((3, 0))
        return dolfinx.mesh.compute_midpoints(self.mesh, dim, np.asarray(entities, np.int32)).T

    @property
    def has_loads(self) -> bool:
        """Whether a body force or a traction was added (else L = 0)."""
        return bool(self._body_forces or self._tractions)

    @property
    def autonomous(self) -> bool:
        """Whether no load, no Dirichlet value and no obstacle depends on t (the energy is
        then kept, or dissipated, by the contact)."""
        values = [*self._body_forces, *(t for _, t in self._tractions),
                  *(c.value for c in self.dirichlet)]  # fmt: skip
        moving = bool(self.moving_contacts)
        return not moving and not any(value.time_dependent for value in values)

    @property
    def loads_in_time(self) -> bool:
        """Whether a body force or a traction depends on t."""
        return any(v.time_dependent for v in [*self._body_forces, *(t for _, t in self._tractions)])

    @property
    def has_tractions(self) -> bool:
        """Whether a traction was added."""
        return bool(self._tractions)

    def load(self, v):
        """L(t)(v) = int f . v + int g_N . v, with the loads at the current time."""
        zero = fem.Constant(self.mesh, np.zeros(self.gdim))
        form = ufl.inner(zero, v) * self.dx
        for force in self._body_forces:
            form = form + ufl.inner(force.ufl, v) * self.dx
        return self._with_tractions(form, v)

    def body_force(self) -> np.ndarray:
        """The sum of the body forces at the current time (zero without any), when they are
        constant in space (:attr:`body_force_in_space`)."""
        total = np.zeros(self.gdim)
        for force in self._body_forces:
            total += force.value_at(float(self.t.value))
        return total

    @property
    def body_force_in_space(self):
        """The sum of the body forces as a UFL vector when one of them may vary in space
        (None otherwise: :meth:`body_force`)."""
        if not any(force.space_dependent for force in self._body_forces):
            return None
        return sum((force.ufl for force in self._body_forces[1:]), self._body_forces[0].ufl)

    def traction_load(self, v):
        """The tractions' part of L(t)(v): int g_N . v over their boundaries."""
        zero = fem.Constant(self.mesh, np.zeros(self.gdim))
        return self._with_tractions(ufl.inner(zero, v) * self.ds, v)

    def _with_tractions(self, form, v):
        """``form`` + int g_N . v over each traction's boundary, at the current time."""
        for tag, traction in self._tractions:
            form = form + ufl.inner(traction.ufl, v) * self.ds(tag)
        return form

    def set_time(self, t: float) -> None:
        """Move the data to time ``t``: :attr:`t` and the functions of t."""
        self.t.value = t
        for force in self._body_forces:
            force.set_time(t)
        for _, traction in self._tractions:
            traction.set_time(t)
