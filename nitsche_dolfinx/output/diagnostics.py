"""Energies and contact diagnostics of docs/method.md section 4, reduced over MPI every step:
the energies, the contact force and area, the largest penetration and the smallest det F
(the momentum and the centre of mass: :mod:`~nitsche_dolfinx.output.mass_moments`).

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
from ufl.algorithms.map_integrands import map_integrands

from ..common import compat
from ..common.collective import max_over_ranks, sum_over_ranks
from .mass_moments import MassMoments, assembled_matrix

__all__ = ["ON_REQUEST", "Diagnostics", "Penetration"]


#: The diagnostics computed only when a history column names them (or all are asked for).
ON_REQUEST = ("penetration_max", "det_F_min")


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
