"""Energies, momentum and contact diagnostics of docs/method.md section 4, reduced over MPI
every step.

    E^h       = 1/2 ||sqrt(rho) u'||^2 + 1/2 a(u, u) - L(u)
    E_Theta^h = E^h - Theta/2 ( ||gamma_h^1/2 sigma_n(u)||^2 - ||gamma_h^-1/2 [P_gamma(u)]_+||^2 )

A local ``assemble_scalar`` is only this rank's share: every value here is an
``allreduce`` over the mesh's communicator.
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from petsc4py import PETSc
from ufl.algorithms.map_integrands import map_integrands

from ..common import compat
from ..common.collective import max_over_ranks, sum_over_ranks
from .history import (
    angular_momentum_columns,
    body_columns,
    centre_of_mass_columns,
    momentum_columns,
)

__all__ = [
    "ON_REQUEST",
    "BoundaryAverage",
    "BoundaryField",
    "Diagnostics",
    "MassMoments",
    "Penetration",
    "PointValue",
    "assemble_global",
    "assembled_matrix",
]


#: The diagnostics computed only when a history column names them (or all are asked for).
ON_REQUEST = ("penetration_max", "det_F_min")


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


def _diagonal_matrix(diagonal):
    """A PETSc AIJ matrix with the given diagonal."""
    matrix = PETSc.Mat().createAIJ(
        (diagonal.getSizes(), diagonal.getSizes()), nnz=1, comm=diagonal.getComm()
    )
    matrix.setDiagonal(diagonal)
    return matrix


def assembled_matrix(form) -> PETSc.Mat:
    """The matrix of a bilinear form, in blocks of the space's block size (BAIJ: for 3D
    vectors, products about three times faster than AIJ)."""
    compiled = fem.form(form)
    matrix = compat.create_matrix(compiled, "baij")
    fem_petsc.assemble_matrix(matrix, compiled)
    matrix.assemble()
    return matrix


def _total(forms: list):
    """The sum of a list of forms, or None for an empty list."""
    return sum(forms[1:], forms[0]) if forms else None


def _update_partners(model, u: fem.Function) -> None:
    """The partner of ``u`` across every contact pair: the pairs' terms of the diagnostics
    read no other."""
    for pair in model.pairs:
        pair.update([u])


class ScalarForms:
    """Several scalar forms assembled in one pass over the mesh: each integrand times one
    component of the test function of a vector DG0 space, the sums of the vector by
    component over every rank. The forms' common quantities (the contact projection, the
    stresses on Gamma_C) are evaluated once per quadrature point instead of once per form.

    Args:
        mesh: The mesh.
        forms: The UFL scalar forms, by name (None: zero, not assembled).
    """

    def __init__(self, mesh, forms: dict):
        self.comm = mesh.comm
        self.names = list(forms)
        self._assembled = [name for name in self.names if forms[name] is not None]
        self._form = self._vector = None
        if not self._assembled:
            return
        space = compat.function_space(mesh, "DG", 0, (len(self._assembled),))
        w = ufl.TestFunction(space)
        total = None
        for k, name in enumerate(self._assembled):
            term = map_integrands(lambda integrand, k=k: integrand * w[k], forms[name])
            total = term if total is None else total + term
        self._form = fem.form(total)
        self._vector = compat.create_vector(space)

    def values(self) -> dict[str, float]:
        """Each form's value, identical on every rank."""
        values = dict.fromkeys(self.names, 0.0)
        if self._form is None:
            return values
        with self._vector.localForm() as local:
            local.set(0.0)
        fem_petsc.assemble_vector(self._vector, self._form)
        with self._vector.localForm() as local:
            # every integral is computed on one rank, at its cell's entry (owned or ghost):
            # the local entries, ghosts included, sum to this rank's share
            sums = local.array.reshape(-1, len(self._assembled)).sum(axis=0)
        values.update(zip(self._assembled, sum_over_ranks(self.comm, sums).tolist()))
        return values


class Penetration:
    """The largest penetration u_n - g over every Gamma_C of a model, at the dofs.

    Args:
        model: The :class:`~nitsche_dolfinx.model.problem.ContactProblem`.
        u: Displacement at the current time level.
    """

    def __init__(self, model, u: fem.Function):
        self.comm = model.mesh.comm
        self.model, self.u = model, u
        # u_n - g at the dofs of Gamma_C, interpolated into a scalar space
        self._fields = []
        if model.contacts:
            P = compat.function_space(model.mesh, "Lagrange", model.degree)
            fdim = model.mesh.topology.dim - 1
            cell_dofs = compat.dofmap_array(P)
            for contact, tag in zip(model.contacts, model.contact_tags):
                field = fem.Function(P)
                expression = compat.expression(contact.penetration(u), P)
                dofs = fem.locate_dofs_topological(P, fdim, model.facets(tag))
                # interpolated only on the cells that hold these dofs (also those of a
                # facet on another rank), not on the whole mesh
                cells = np.flatnonzero(np.isin(cell_dofs, dofs).any(axis=1)).astype(np.int32)
                self._fields.append((field, expression, dofs, cells))

    def max(self) -> float:
        """max over Gamma_C of u_n - g (> 0 means penetration); -inf without contact."""
        local = -np.inf
        _update_partners(self.model, self.u)
        for field, expression, dofs, cells in self._fields:
            field.interpolate(expression, cells)
            if len(dofs):
                local = max(local, float(field.x.array[dofs].max()))
        return float(max_over_ranks(self.comm, [local])[0])


class SmallestDeterminant:
    """The smallest det F = det(I + grad u) over the mesh, at the nodes of a discontinuous
    space that holds det F exactly on affine cells (degree gdim (k - 1) for P_k).

    Args:
        model: The :class:`~nitsche_dolfinx.model.problem.ContactProblem`.
        u: Displacement at the current time level.
    """

    def __init__(self, model, u: fem.Function):
        self.comm = model.mesh.comm
        degree = model.gdim * (model.degree - 1) + compat.geometry_degree(model.mesh) - 1
        space = compat.function_space(model.mesh, "DG", degree)
        self._field = fem.Function(space)
        F = ufl.Identity(model.gdim) + ufl.grad(u)
        self._expression = compat.expression(ufl.det(F), space)

    def min(self) -> float:
        """min det F over every rank."""
        self._field.interpolate(self._expression)
        array = self._field.x.array
        local = float(array.min()) if array.size else np.inf
        return -float(max_over_ranks(self.comm, [-local])[0])


class MassMoments:
    """The mass of the body and its moments, from its mass matrix M (consistent, or the
    lumped or redistributed diagonal): the kinetic energy 1/2 v . M v, the total linear
    momentum (the rows of M v summed by component), the centre of mass (those of
    M (x + u), over the mass; x the positions of the nodes, which the displacement space
    interpolates exactly when it holds the geometry) and the angular momentum about the
    origin, sum_i (x_i + u_i) x (M v)_i over the nodes, and sum_i x_i x (M v)_i, the one
    linear elasticity keeps (docs/method.md section 4); the first three also over the
    nodes of each body of the model (``ContactProblem.add_body``), whose rows are its own
    mass matrix's.

    Args:
        model: The :class:`~nitsche_dolfinx.model.problem.ContactProblem`.
    """

    def __init__(self, model):
        self.comm = model.mesh.comm
        self.model = model
        trial, test = ufl.TrialFunction(model.V), ufl.TestFunction(model.V)
        diagonal = model.mass_diagonal()
        if diagonal is None:
            self.matrix = assembled_matrix(model.inertia(trial, test))
        else:  # lumped or redistributed mass: a diagonal matrix
            self.matrix = _diagonal_matrix(diagonal)
            self.matrix.assemble()
        self._work = self.matrix.createVecLeft()
        self._displaced = self.matrix.createVecLeft()  # M u
        self.bs = model.V.dofmap.index_map_bs
        self.momentum_names = momentum_columns(self.bs)
        self.centre_names = centre_of_mass_columns(self.bs)
        self.angular_names = angular_momentum_columns(self.bs)
        self.reference_names = angular_momentum_columns(self.bs, reference=True)
        positions = fem.Function(model.V)
        positions.interpolate(lambda x: x[: self.bs])
        #: The nodes' positions (owned rows) and the rows of M x (of the undeformed body).
        self._positions = self._rows(positions.x.array).copy()
        self._first_moment_rows = self._rows(self._product(positions, self._work)).copy()
        self._first_moment = sum_over_ranks(self.comm, self._first_moment_rows.sum(axis=0))
        positions.x.array[:] = 1.0
        self._mass_rows = self._rows(self._product(positions, self._work))[:, 0].copy()
        self.mass = float(sum_over_ranks(self.comm, [self._mass_rows.sum()])[0])
        self._body_masses: list[float] = []  # of model.bodies, once asked for

    def _rows(self, array) -> np.ndarray:
        """The owned part of a dof array, one row per node."""
        owned = self._work.getLocalSize()
        return np.asarray(array)[:owned].reshape(-1, self.bs)

    def _product(self, function, out) -> np.ndarray:
        """M f into ``out``; its owned entries."""
        self.matrix.mult(compat.petsc_vector(function), out)
        return out.array

    def sums(self, function) -> np.ndarray:
        """M f summed by component over all ranks (M f stays in the work vector)."""
        return sum_over_ranks(self.comm, self._rows(self._product(function, self._work)).sum(0))

    def inertia_norm(self, v, dt: float) -> float:
        """||M v|| / dt over all ranks: the force that would stop the velocity ``v`` in a
        step ``dt``."""
        self._product(v, self._work)
        return self._work.norm() / dt

    def momentum(self, v) -> np.ndarray:
        """The total linear momentum, by component: the rows of M v summed."""
        return self.sums(v)

    def kinetic(self, v) -> float:
        """1/2 v . M v."""
        self.matrix.mult(compat.petsc_vector(v), self._work)
        return 0.5 * self._work.dot(compat.petsc_vector(v))

    def centre_of_mass(self, u) -> np.ndarray:
        """The centre of mass of the body deformed by ``u``, by component."""
        return (self._first_moment + self.sums(u)) / self.mass

    def _angular(self, positions: np.ndarray, momenta: np.ndarray) -> np.ndarray:
        """sum_i x_i x p_i over the rows (2D: its z component; 1D: none)."""
        if self.bs == 1:
            return np.zeros(0)
        if self.bs == 2:
            return np.array(
                [np.sum(positions[:, 0] * momenta[:, 1] - positions[:, 1] * momenta[:, 0])]
            )
        return np.cross(positions, momenta).sum(axis=0)

    def values(self, u, v) -> dict[str, float]:
        """The momentum, centre-of-mass and angular momentum columns at the state (u, v),
        of the whole mesh and of each body, with one reduction over the ranks."""
        momenta = self._rows(self._product(v, self._work))
        displaced = self._rows(self._product(u, self._displaced))
        current = self._positions + self._rows(u.x.array)
        parts = [momenta, displaced, current]
        local = [momenta.sum(0), displaced.sum(0), self._angular(current, momenta)]
        local.append(self._angular(self._positions, momenta))
        bodies = self.model.bodies
        for body in bodies:
            momenta_b, displaced_b, current_b = (part[body.nodes] for part in parts)
            moment = self._first_moment_rows[body.nodes].sum(0) + displaced_b.sum(0)
            local += [momenta_b.sum(0), moment, self._angular(current_b, momenta_b)]
        if len(self._body_masses) != len(bodies):
            self._body_masses = sum_over_ranks(
                self.comm, [self._mass_rows[body.nodes].sum() for body in bodies]
            ).tolist()
        ends = np.cumsum([part.size for part in local])[:-1]
        sums = iter(np.split(sum_over_ranks(self.comm, np.concatenate(local)), ends))
        momentum, centre = next(sums), (self._first_moment + next(sums)) / self.mass
        values = {
            **dict(zip(self.momentum_names, momentum.tolist())),
            **dict(zip(self.centre_names, centre.tolist())),
            **dict(zip(self.angular_names, next(sums).tolist())),
            **dict(zip(self.reference_names, next(sums).tolist())),
        }
        for body, mass in zip(bodies, self._body_masses):
            each = [next(sums), next(sums) / mass, next(sums)]
            values.update(zip(body_columns(body.tag, self.bs), np.concatenate(each).tolist()))
        return values


class Diagnostics:
    """Energies, contact force, contact area and penetration of a displacement/velocity
    pair; the momentum and the centre of mass (:class:`MassMoments`); the contact totals of
    each contact term (:func:`~nitsche_dolfinx.output.history.contact_columns`).

    :meth:`energies` computes the energies and the contact totals (what a step's energy
    control needs); :meth:`complete` adds the rest, but for the largest penetration, which
    interpolates u_n - g at the nodes of Gamma_C (the dearest of them, per step), only
    when a history column names it (:data:`ON_REQUEST`).

    Args:
        model: The :class:`~nitsche_dolfinx.model.problem.ContactProblem`.
        u: Displacement at the current time level.
        v: Velocity at the current time level.
        potential: The loads' potential -L(t)(u) at the current state, when a stepper
            computes it itself (the explicit steps' load is lumped as their mass); None:
            assembled from L.
        elastic: The elastic energy 1/2 u . K u at the current state, when a stepper has
            K u at hand (the explicit steps); None: from a stiffness matrix of its own.
    """

    def __init__(self, model, u: fem.Function, v: fem.Function, potential=None, elastic=None):
        self.comm = model.mesh.comm
        self.model = model
        self.u, self.v = u, v
        # the quadratic energies as matrices assembled once: a matrix-vector product per step
        trial, test = ufl.TrialFunction(model.V), ufl.TestFunction(model.V)
        self.moments = MassMoments(model)
        self._elastic = elastic
        finite = getattr(model, "finite", False)  # int W(C(u)), not a quadratic form
        self._stiffness = None  # K, for 1/2 u . K u (linear elasticity)
        if elastic is None and not finite:
            self._stiffness = assembled_matrix(model.bulk_stiffness(trial, test))
            self._work = self._stiffness.createVecLeft()
        # without loads the potential is zero: no form to assemble each step
        loaded = model.has_loads and potential is None
        self._potential = potential if model.has_loads else None
        forms = {
            "potential": -model.load(u) if loaded else None,
            "energy_correction": _total([c.energy_correction(u) for c in model.contacts]),
            "contact_force": _total([c.force(u) for c in model.contacts]),
            "contact_area": _total([c.area(u) for c in model.contacts]),
        }
        if elastic is None and finite:
            forms["elastic"] = model.stored_energy(u)
        self._forms = ScalarForms(model.mesh, forms)
        each = {}
        if len(model.contacts) > 1:  # one contact: its totals are the sums
            for k, contact in enumerate(model.contacts, start=1):
                each[f"contact_force_{k}"] = contact.force(u)
                each[f"contact_area_{k}"] = contact.area(u)
        self._each_forms = ScalarForms(model.mesh, each) if each else None
        self.penetration = Penetration(model, u)
        self._determinant = None  # SmallestDeterminant, compiled when first asked for
        self._level: tuple[int, dict[str, float]] | None = None  # (its index, its values)

    def of_level(self, level: int, columns=()) -> dict[str, float]:
        """The diagnostics of the time level ``level`` (the optional ones that ``columns``
        name; None: all), each computed once per level: the state is that level's."""
        cached = self._level
        if cached is None or cached[0] != level:
            self._level = (level, self.compute(columns))
        else:
            self.complete(cached[1], columns)
        return self._level[1]

    def follow_pairs(self, level: int) -> float:
        """Pair the surfaces of the contact pairs again where they have slid, at the state
        of the time level ``level`` (:meth:`~nitsche_dolfinx.model.problem.ContactProblem.
        follow_pairs`); the change of E_Theta the new pairing makes there (0 if none),
        whose diagnostics are then the level's (docs/method.md section 11)."""
        if not any(pair.follow for pair in self.model.pairs):
            return 0.0
        before = self.of_level(level)["energy_theta"]
        if not self.model.follow_pairs(self.u):
            return 0.0
        after = self.energies()
        self.remember(level, after)
        return after["energy_theta"] - before

    def remember(self, level: int, values: dict[str, float] | None) -> None:
        """Take ``values`` as the diagnostics of ``level`` (None: forget them)."""
        self._level = None if values is None else (level, values)

    def smallest_determinant(self) -> float:
        """The smallest det F over the mesh at the current state (:class:`SmallestDeterminant`,
        compiled when first asked for)."""
        if self._determinant is None:
            self._determinant = SmallestDeterminant(self.model, self.u)
        return self._determinant.min()

    @property
    def stiffness_matrix(self):
        """The bulk stiffness K as a PETSc matrix (None when the stepper gives the elastic
        energy itself)."""
        return self._stiffness if self._elastic is None else None

    def _quadratic(self, matrix, function) -> float:
        """1/2 x^T A x over all ranks."""
        x = compat.petsc_vector(function)
        matrix.mult(x, self._work)
        return 0.5 * self._work.dot(x)

    def compute(self, columns=None) -> dict[str, float]:
        """Every diagnostic at the current state, identical on every rank (the largest
        penetration only if ``columns`` name it; None: also)."""
        return self.complete(self.energies(), columns)

    def energies(self) -> dict[str, float]:
        """The energies and the contact totals at the current state, identical on every
        rank."""
        _update_partners(self.model, self.u)
        values = self._forms.values()
        if self._potential is not None:
            values["potential"] = self._potential()
        kinetic = self.moments.kinetic(self.v)
        if "elastic" in values:
            elastic = values["elastic"]
        elif self._elastic:
            elastic = self._elastic()
        else:
            elastic = self._quadratic(self._stiffness, self.u)
        energy = kinetic + elastic + values["potential"]
        return {
            "energy": energy,
            "energy_theta": energy + values["energy_correction"],
            "kinetic": kinetic,
            "elastic": elastic,
            "potential": values["potential"],
            "contact_force": values["contact_force"],
            "contact_area": values["contact_area"],
        }

    def complete(self, values: dict[str, float], columns=None) -> dict[str, float]:
        """Add to the :meth:`energies` ``values`` of the current state the diagnostics they
        lack: the largest penetration if ``columns`` name it (None: also), the momentum, the
        centre of mass and the totals of each contact term; returns ``values``."""
        wanted = columns is None or "penetration_max" in columns
        if wanted and "penetration_max" not in values:
            values["penetration_max"] = self.penetration.max()
        finite = getattr(self.model, "finite", False)
        wanted = finite and (columns is None or "det_F_min" in columns)
        if wanted and "det_F_min" not in values:
            values["det_F_min"] = self.smallest_determinant()
        if self.moments.momentum_names[0] in values:
            return values  # (completed before)
        values.update(self.moments.values(self.u, self.v))
        if len(self.model.contacts) == 1:  # its totals are the sums
            values["contact_force_1"] = values["contact_force"]
            values["contact_area_1"] = values["contact_area"]
        elif self._each_forms is not None:
            values.update(self._each_forms.values())
        return values


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
