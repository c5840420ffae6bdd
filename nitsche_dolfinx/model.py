"""The model: linear elastodynamics with contact, as terms added to a weak form.

A :class:`ContactProblem` holds the mesh, the material and the terms of the
weak form: Dirichlet conditions, loads, one contact per rigid obstacle and two per
contact pair (its halves). It
offers them to the time schemes through the
:class:`~nitsche_dolfinx.schemes.Model` interface (``inertia``, ``operator``,
``hybrid_operator``, ``load``); :class:`~nitsche_dolfinx.simulation.Simulation`
marches it in time.

Example (the 1D bar of docs/method.md section 5)::

    mesh, tags = bar_mesh(100)
    problem = ContactProblem(mesh, tags, Material(E=1.0, nu=0.0, rho=1.0),
                             gamma0=1e-6, nitsche_theta=1.0)
    problem.add_dirichlet(BAR_CLAMPED, 0.0)
    problem.add_obstacle(PlaneObstacle([0.0], [1.0]), BAR_CONTACT)
    problem.set_initial_conditions(displacement=lambda x: 0.5 - x[0] / 2)
"""

from __future__ import annotations

import dolfinx.mesh
import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI

from . import compat
from .bodies import Body, make_body
from .contact import NitscheContact, PenaltyContact
from .damping import RayleighDamping
from .dirichlet import DirichletCondition
from .expressions import has_text, vector_expression
from .finite_contact import FiniteContact, FinitePairContact
from .hyperelastic import averaged_stress, cauchy_stress, first_piola, strain_energy, von_mises_of
from .mass import MassMatrix
from .material import Material, MaterialConstants, sigma, von_mises
from .meshes import cell_diameter
from .pairs import CONTACT_PAIR_VARIANTS, PairContact, pair_halves
from .parameters import (
    Discretisation,
    NitscheParameters,
    require,
    require_choice,
)
from .problem_values import ProblemValue, as_array, check_finite_texts
from .regions import CellwiseMaterial

__all__ = ["ContactProblem"]


class ContactProblem:
    """Linear elastodynamics with Nitsche contact: against rigid obstacles
    (:meth:`add_obstacle`) and between bodies (:meth:`add_contact_pair`).

    Args:
        mesh: The dolfinx mesh (1D, 2D or 3D).
        facet_tags: Facet tags naming the boundary parts used by the terms.
        material: The elastic material and its density, or a dict {cell tag: Material}
            for a material per region (``cell_tags`` then tags every cell; the
            parameters become fields constant in each cell, still runtime values:
            :class:`~nitsche_dolfinx.regions.CellwiseMaterial`).
        degree: Degree of the Lagrange displacement space (1 or 2).
        gamma0: Nitsche parameter: gamma_h = gamma0 h_T (small gamma0 = stiff contact), or
            gamma0 h_T / E with ``gamma0_scaling="E"``. Default (None): gamma0 E = 1e-3
            whatever the units (:data:`~nitsche_dolfinx.parameters.DEFAULT_GAMMA0_E`):
            gamma0 = 1e-3 / E, E the largest Young modulus of the materials, or 1e-3 with
            ``gamma0_scaling="E"`` (docs/method.md section 10).
        nitsche_theta: Nitsche variant Theta: 1 symmetric, 0 non-symmetric, -1 skew-symmetric.
        friction: Coulomb coefficient mu_f >= 0, or None (the default) for frictionless
            contact. With a coefficient, the frictional Nitsche term of docs/method.md section 2 is
            added (:meth:`~nitsche_dolfinx.contact.NitscheContact.friction_term`) with the
            tangential velocity of the time scheme; mu_f is the ``fem.Constant``
            attribute ``friction`` and mu_f = 0 is the frictionless problem.
        method: Contact method: ``"nitsche"`` (the default), ``"penalty"``
            (:class:`~nitsche_dolfinx.contact.PenaltyContact`, eps = gamma0 h_T) or
            ``"mixed"``: a Lagrange multiplier for the pressure, one obstacle,
            Crank-Nicolson only (:class:`~nitsche_dolfinx.mixed.MixedStepper`).
        mass: ``"consistent"`` (the default), ``"lumped"`` (P1: vertex quadrature) or
            ``"redistributed"``: the modified mass of Khenous, Laborde & Renard, lumped,
            with the mass of the contact nodes moved to their neighbours (P1). The
            contact tags are those of the obstacles added before the first simulation.
        quadrature_degree: Quadrature degree of every integral, in the equations and in
            the energies alike (so that the discrete energy identities hold to round-off,
            also on curved cells). Default: 2 * degree on affine meshes, 2 * degree + 2 on
            second-order geometries.
        gamma0_scaling: ``"absolute"`` (the default, the paper's): gamma0 has the units of
            1/stress, and a value that suits E = 1000 is far too soft at E = 2e11;
            ``"E"``: gamma_h = gamma0 h_T / E, gamma0 without units, the same value for
            any material and units (about 1e-3 suits P1 and P2; docs/method.md
            section 10). gamma0 E (or gamma0) must lie in
            :data:`~nitsche_dolfinx.parameters.GAMMA0_E_RANGE`.

    ``cell_tags``: the mesh's cell tags, for a material per region.

    The parameters are checked by :class:`~nitsche_dolfinx.parameters.NitscheParameters`
    and :class:`~nitsche_dolfinx.parameters.Discretisation`.
    ``gamma0`` and ``nitsche_theta`` are ``fem.Constant`` attributes: change
    their ``.value`` between runs without recompiling any form. The material enters
    the forms as constants too (:attr:`material_constants`): a problem built with
    another material reuses the compiled forms.
    """

    def __init__(
        self,
        mesh,
        facet_tags,
        material: Material,
        degree: int = 1,
        gamma0: float | None = None,
        nitsche_theta: float = 1.0,
        friction: float | None = None,
        quadrature_degree: int | None = None,
        method: str = "nitsche",
        mass: str = "consistent",
        gamma0_scaling: str = "absolute",
        cell_tags=None,
    ):
        require(
            isinstance(material, (Material, dict)),
            "material",
            material,
            "must be a Material: Material(E=..., nu=..., rho=...) or Material.from_lame(...), "
            "or a dict {cell tag: Material}",
        )
        nitsche = NitscheParameters(gamma0, nitsche_theta, friction, method, gamma0_scaling)
        regions = isinstance(material, dict)
        #: Every material of the problem (one, or one per cell tag).
        self.materials = list(material.values()) if regions else [material]
        moduli = [each.E for each in self.materials if isinstance(each, Material)]
        nitsche = nitsche.resolved(max(moduli, default=1.0))  # the default gamma0: of E
        for each in self.materials:
            if isinstance(each, Material):
                nitsche.check_scale(each.E)
        discretisation = Discretisation(degree, mass, quadrature_degree)
        compat.stable_form_signatures(mesh)  # a sweep finds its compiled forms
        self.mesh = mesh
        self.facet_tags = facet_tags
        self.cell_tags = cell_tags
        #: The material (None with several: :attr:`materials`, :meth:`largest`).
        self.material = None if regions else material
        #: The material's parameters as runtime constants: the forms of another
        #: material are the same compiled forms (docs/method.md section 10); with a
        #: material per cell tag, fields constant in each cell (docs/method.md section 13).
        self.material_constants = (
            CellwiseMaterial(mesh, cell_tags, material)
            if regions
            else MaterialConstants(material, lambda value: fem.Constant(mesh, float(value)))
        )
        #: The strain energy W(C, constants) of a hyperelastic material (finite strains,
        #: docs/method.md section 15), None for linear elasticity.
        self.law = None if regions else material.strain_energy
        if self.law is not None:
            _check_finite(mesh, nitsche, material.law)
        for each in self.materials if regions else []:
            require(
                not each.finite, "law", each.law,
                "a hyperelastic material is one material for the whole mesh so far",
            )  # fmt: skip
        self.degree = discretisation.degree
        self.method = nitsche.method
        self.mass = discretisation.mass
        self.gdim = mesh.geometry.dim
        self.V = compat.function_space(mesh, "Lagrange", self.degree, (self.gdim,))
        self.mass_matrix = MassMatrix(
            self.mass, self.V, self.material_constants.rho, self._contact_facets
        )
        self.gamma0 = fem.Constant(mesh, float(nitsche.gamma0))
        self.nitsche_theta = fem.Constant(mesh, float(nitsche_theta))
        self.friction = None if friction is None else fem.Constant(mesh, float(friction))
        self.h = cell_diameter(mesh)
        self.gamma0_scaling = nitsche.gamma0_scaling
        if self.gamma0_scaling == "E":
            self.gamma_h = self.gamma0 * self.h / self.material_constants.E
        else:
            self.gamma_h = self.gamma0 * self.h
        if quadrature_degree is None:
            quadrature_degree = 2 * self.degree + 2 * (compat.geometry_degree(mesh) - 1)
        self.quadrature_degree = int(quadrature_degree)
        metadata = {"quadrature_degree": self.quadrature_degree}
        self.dx = ufl.Measure("dx", domain=mesh, metadata=metadata)
        self.ds = ufl.Measure("ds", domain=mesh, subdomain_data=facet_tags, metadata=metadata)
        self.contacts: list[NitscheContact] = []
        self.contact_tags: list[int] = []
        self.dirichlet: list[DirichletCondition] = []
        #: The bodies whose moments the history reports (:meth:`add_body`).
        self.bodies: list[Body] = []
        self._body_forces: list[ProblemValue] = []
        self._tractions: list[tuple[int, ProblemValue]] = []
        self.initial_displacement = None
        self.initial_velocity = None
        self._node_coordinates = None  # of V's nodes, when a check of the data needs them
        #: Rayleigh damping (:meth:`set_damping`), None without it (no term in the forms).
        self.damping: RayleighDamping | None = None
        #: The time t of the problem's data in UFL, a ``fem.Constant`` that the steppers move
        #: (:meth:`set_time`).
        self.t = fem.Constant(mesh, 0.0)
        #: The position x in UFL (``ufl.SpatialCoordinate``), for data in space.
        self.x = ufl.SpatialCoordinate(mesh)

    @property
    def finite(self) -> bool:
        """Whether the material is hyperelastic (finite strains, docs/method.md section 15)."""
        return self.law is not None

    def largest(self, parameter: str) -> float:
        """The largest value of a :class:`~nitsche_dolfinx.material.Material` property
        (``"E"``, ``"rho"``, ``"lmbda"``, ...) over the problem's materials."""
        return max(getattr(material, parameter) for material in self.materials)

    # -- building the model ------------------------------------------------------------

    def _value(self, value, shape: tuple[int, ...], what: str) -> ProblemValue:
        """A value of the problem's data (:class:`~nitsche_dolfinx.problem_values.ProblemValue`):
        a constant, a function of t, a UFL expression of :attr:`x` and :attr:`t`, or a list
        of numbers and texts of the expression language (:mod:`~nitsche_dolfinx.expressions`:
        x, y, z, t, + - * / ^, sin, cos, exp, ..., 'a if condition else b')."""
        return ProblemValue(self.mesh, self.t, value, shape, what)

    def facets(self, tag: int) -> np.ndarray:
        """Local indices of the facets tagged ``tag``; raises if no rank has any."""
        tags = self.facet_tags
        found = tags.indices[tags.values == tag].astype(np.int32) if tags is not None else []
        if self.mesh.comm.allreduce(len(found), op=MPI.SUM) == 0:
            present = sorted(
                set(
                    self.mesh.comm.allreduce(
                        [] if tags is None else np.unique(tags.values).tolist(), op=MPI.SUM
                    )
                )
            )
            raise ValueError(f"facet tag {tag!r} is not in the mesh (its facet tags are {present})")
        return np.asarray(found, dtype=np.int32)

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

    def add_body(self, tag: int, cell_tags=None) -> Body:
        """Declare the cells tagged ``tag`` a body: the history gets its linear momentum, its
        centre of mass and its angular momentum about the origin (``momentum_<tag>_x``, ...,
        :func:`~nitsche_dolfinx.history.body_columns`), from the rows of the mass matrix at
        its nodes (docs/method.md section 4). Bodies share no node. Declare them before
        the run (:meth:`~nitsche_dolfinx.simulation.Simulation.run`).

        Args:
            tag: The cell tag of the body.
            cell_tags: The mesh's cell tags (default: those the problem was given).

        Raises:
            ParameterError: No cell tags, none of this tag, the tag given twice, or a node
                shared with a body declared before.
        """
        cell_tags = self.cell_tags if cell_tags is None else cell_tags
        body = make_body(self.V, cell_tags, tag, self.bodies)
        self.bodies.append(body)
        return body

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

    def add_obstacle(self, obstacle, tag: int) -> NitscheContact:
        """Add unilateral contact of the facets ``tag`` (Gamma_C) with a rigid obstacle."""
        self.facets(tag)
        shape = getattr(obstacle, "shape", obstacle)  # a moving obstacle's at t = 0
        point = getattr(shape, "point", None)  # a plane: of the mesh's dimension
        if point is not None and len(point) != self.gdim:
            raise ValueError(
                f"obstacle point {list(point)} has {len(point)} coordinates, the mesh has "
                f"{self.gdim}"
            )
        if getattr(obstacle, "moving", False):
            require(
                self.method != "mixed", "method", self.method,
                "a moving obstacle takes Nitsche's or the penalty method",
            )  # fmt: skip
            require(
                self.friction is None, "friction", float(self.friction.value)
                if self.friction is not None else None,
                "a moving obstacle is frictionless so far (the slip would be relative to it)",
            )  # fmt: skip
            obstacle.bind(self.mesh)
        if self.finite:  # in the current configuration (docs/method.md section 15)
            require(
                not getattr(obstacle, "moving", False), "obstacle", obstacle,
                "a hyperelastic body meets obstacles that stand still so far",
            )  # fmt: skip
            contact = FiniteContact(
                obstacle, self.ds(tag), self.stress, self.gamma_h, self.nitsche_theta
            )
        else:
            law = PenaltyContact if self.method == "penalty" else NitscheContact
            contact = law(
                obstacle, self.ds(tag), self.stress, self.gamma_h, self.nitsche_theta,
                self.friction,
            )  # fmt: skip
        self.contacts.append(contact)
        self.contact_tags.append(tag)
        return contact

    def add_contact_pair(
        self, tag_a: int, tag_b: int, variant: str = "unbiased", direction=None,
        follow: bool | None = None,
    ) -> list:  # fmt: skip
        """Add contact between the facets ``tag_a`` and ``tag_b`` of two bodies (or of two
        parts of one body) of the mesh, by Nitsche's method (docs/method.md section 11).

        Each node of a slave surface is paired with its closest point on the other
        surface, in the reference configuration and, with ``follow``, again in the
        configuration of the last converged step whenever the surfaces have slid along
        each other by 3% of a facet (:data:`~nitsche_dolfinx.pairs.REPAIR_SLIP`). By
        default closest points are followed and a pairing along a ``direction`` is not:
        paired again along a line, the gap is not a distance, and each pairing changes
        E_Theta by the force times the slope of the surface times the slip
        (docs/method.md section 11).
        ``variant="unbiased"`` (the default): each surface is slave in turn with weight
        1/2, and the stresses of both bodies enter; ``"biased"``: ``tag_a`` is the slave,
        and only its stress enters.
        ``tag_a == tag_b``: self-contact, the surface paired with the nearest of its
        points that faces it away from its own neighbourhood, at every step (docs/method.md
        section 11). ``direction``: pair along this direction (from ``tag_a`` towards ``tag_b``)
        instead of with the closest point, with the contact normal n_c = direction: for
        a head-on collision, where it makes a pair of mirror-image bodies exactly one
        body on a rigid plane (docs/method.md section 11). Nitsche only; with the
        problem's ``friction``, Coulomb friction on the relative slip. With a hyperelastic
        material, the halves' terms are those of finite strain
        (:class:`~nitsche_dolfinx.finite_contact.FinitePairContact`, docs/method.md
        section 15).
        Returns the :class:`~nitsche_dolfinx.pairs.PairContact` halves.
        """
        require_choice(variant, CONTACT_PAIR_VARIANTS, "variant", "contact pair variant")
        require(
            self.method == "nitsche", "method", self.method,
            "contact between bodies is Nitsche contact (not penalty nor the mixed method)",
        )  # fmt: skip
        require(
            tag_a != tag_b or (direction is None and follow is not False), "direction",
            direction if follow is not False else follow,
            "self-contact (a surface paired with itself) pairs closest points, again at every "
            "step",
        )  # fmt: skip
        require(
            tag_a != tag_b or self.gdim > 1, "tag_b", tag_b,
            f"a surface paired with itself (tag {tag_a} twice) is self-contact, which needs a "
            "2D or 3D mesh (in 1D a surface is a point)",
        )  # fmt: skip
        unit = None
        if direction is not None:
            unit = as_array(direction, (self.gdim,), "contact pair direction")
            length = float(np.linalg.norm(unit))
            require(length > 0, "direction", unit.tolist(), "the direction must not be zero")
            unit = unit / length
        follow = unit is None if follow is None else bool(follow)
        kind = FinitePairContact if self.finite else PairContact  # docs/method.md section 15
        halves = pair_halves(self, tag_a, tag_b, variant, unit, follow, kind)
        for half in halves:
            self.contacts.append(half)
            self.contact_tags.append(half.ds.subdomain_id())
        return halves

    @property
    def pairs(self) -> list:
        """The halves of the contact pairs (:meth:`add_contact_pair`)."""
        return [contact for contact in self.contacts if isinstance(contact, PairContact)]

    def track_partners(self, *functions) -> None:
        """Give the Functions of a state their partners on every contact pair (the
        stepper's displacement, velocity, acceleration and unknown)."""
        for pair in self.pairs:
            pair.track(functions)

    def follow_pairs(self, u: fem.Function) -> bool:
        """Pair the surfaces of the contact pairs again in the configuration displaced by
        ``u`` (the last converged step's) if any has slid (docs/method.md section 11), all
        of them at once; True if they were (collective)."""
        pairings = [pair.pairing for pair in self.pairs if pair.follow]
        if not any([pairing.slid(u) for pairing in pairings]):
            return False
        for pairing in pairings:
            pairing.pair(u)
        self.update_partners()
        return True

    def pairing_state(self) -> dict:
        """The displacements the pairs were last paired in, by name (``pairing_1``, ...):
        what a restart needs to pair them as the run did (:meth:`restore_pairs`)."""
        halves = (pair for pair in self.pairs if pair.follow)
        return {f"pairing_{k}": pair.pairing.displacement for k, pair in enumerate(halves, 1)}

    def restore_pairs(self) -> None:
        """Pair the surfaces in the displacements of :meth:`pairing_state`, just loaded
        from a checkpoint (collective)."""
        for pair in self.pairs:
            if pair.follow:
                pair.pairing.pair(pair.pairing.displacement)
        self.update_partners()

    def update_partners(self) -> None:
        """Recompute the partners of the tracked Functions (before evaluating a form)."""
        for pair in self.pairs:
            pair.update()

    def solver_hint(self) -> str:
        """What may make a failing contact step converge, in words ('' without contact)."""
        if not self.contacts or self.method == "mixed":
            return ""
        return (
            f"{self._gamma0_in_words()}: a smaller gamma0 ({self._suggested_gamma0()} suits P1 "
            "and P2, see docs/method.md section 10) or a smaller dt may let Newton converge"
        )

    def stability_hint(self) -> str:
        """What may bring a run whose E_Theta lost control of the energy back (docs/method.md
        section 8)."""
        if not self.contacts:
            return "no contact term: check the loads and the initial values"
        return (
            f"{self._gamma0_in_words()} is beyond the stability limit of this mesh and degree: "
            f"use a smaller gamma0 ({self._suggested_gamma0()}, see docs/method.md section 10); "
            "a smaller dt does not help"
        )

    def _gamma0_in_words(self) -> str:
        gamma0 = float(np.asarray(self.gamma0.value))
        if self.gamma0_scaling == "absolute":
            return f"gamma0 * E = {gamma0 * self.largest('E'):.3g}"
        return f"gamma0 = {gamma0:.3g} (scaled by E)"

    def _suggested_gamma0(self) -> str:
        return "about 1e-3 / E" if self.gamma0_scaling == "absolute" else "about 1e-3"

    def set_damping(self, alpha: float = 0.0, beta: float = 0.0) -> RayleighDamping:
        """Rayleigh damping C = alpha M + beta K (docs/method.md section 14): M the
        problem's mass (consistent, lumped or redistributed), K the bulk stiffness a(u, v)
        (not the Nitsche terms). alpha >= 0 [1/time], beta >= 0 [time]; the modal damping
        ratio at the circular frequency omega is alpha / (2 omega) + beta omega / 2. The
        coefficients are the ``fem.Constant`` attributes ``damping.alpha`` and
        ``damping.beta`` (runtime values). Set before the simulation is built."""
        require(
            self.method != "mixed", "method", self.method,
            "damping is for Nitsche's and the penalty method (not the mixed one)",
        )  # fmt: skip
        require(
            not self.finite, "law", self.materials[0].law,
            "Rayleigh damping takes a linear stiffness: not with a hyperelastic material",
        )  # fmt: skip
        damping = RayleighDamping(self.mesh, alpha, beta)
        if self.damping is None:
            self.damping = damping
        else:  # the same constants: compiled forms stay valid
            self.damping.alpha.value, self.damping.beta.value = damping.values
        return self.damping

    def damping_force(self, velocity, v):
        """(C velocity, v) in UFL without a diagonal mass's part (which the solver adds), or
        None without damping (the forms then have no damping term at all)."""
        return None if self.damping is None else self.damping.force(self, velocity, v)

    def set_initial_conditions(self, displacement=None, velocity=None) -> None:
        """Initial displacement u0 and velocity v0 (zero when omitted).

        Each is a constant vector, a function of the coordinates ``x`` (shape (3, N))
        returning the values (shape (gdim, N), or (N,) in 1D), a Function on the
        displacement space, a UFL vector of :attr:`x`, or a list of numbers and expression
        texts of x, y, z (:mod:`~nitsche_dolfinx.expressions`; no t), e.g.
        ``["0.1 * sin(pi * x)", 0]``.
        """
        self.initial_displacement = self._field(displacement, "initial displacement",
                                                "displacement")  # fmt: skip
        self.initial_velocity = self._field(velocity, "initial velocity", "velocity")

    def _field(self, value, what: str, name: str):
        """An initial field as :func:`~nitsche_dolfinx.stepping.interpolate_initial` takes
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

    # -- the terms of the weak form, used by the time schemes --------------------------

    def stress(self, u):
        """sigma(u); at finite strains the first Piola-Kirchhoff stress P(u)."""
        if self.finite:
            return first_piola(self.law, self.material_constants, u)
        return sigma(u, self.material_constants)

    def bulk_stiffness(self, u, v):
        """a(u, v) = int sigma(u) : eps(v); at finite strains int P(u) : grad v."""
        if self.finite:
            return ufl.inner(self.stress(u), ufl.grad(v)) * self.dx
        return ufl.inner(self.stress(u), ufl.sym(ufl.grad(v))) * self.dx

    def stored_energy(self, u):
        """The elastic energy as a form: int W(C(u)) at finite strains, 1/2 a(u, u) else."""
        if self.finite:
            return strain_energy(self.law, self.material_constants, u) * self.dx
        return 0.5 * self.bulk_stiffness(u, u)

    def von_mises(self, u):
        """The von Mises stress (of the Cauchy stress at finite strains), in UFL."""
        if self.finite:
            return von_mises_of(cauchy_stress(self.law, self.material_constants, u))
        return von_mises(u, self.material_constants)

    def inertia(self, acceleration, v):
        """<rho u'', v> with the consistent mass; zero for a diagonal mass
        (:meth:`mass_diagonal`), which the solver adds as a matrix."""
        rho = self.material_constants.rho if self.mass == "consistent" else 0.0
        return rho * ufl.inner(acceleration, v) * self.dx

    def mass_diagonal(self, V=None):
        """The lumped or redistributed mass matrix as a PETSc vector (its diagonal), or None
        for the consistent mass; on ``V`` (another numbering of the displacement space)
        when given (:class:`~nitsche_dolfinx.mass.MassMatrix`)."""
        return self.mass_matrix.diagonal(V)

    def massless_dofs(self, nodes: bool = False) -> np.ndarray:
        """Local indices (with ghosts) of the dofs whose mass is zero (redistributed mass);
        with ``nodes``, of their nodes (the blocks of the dof array)."""
        return self.mass_matrix.massless_dofs(nodes)

    def _contact_facets(self) -> np.ndarray | None:
        """The local facets of every Gamma_C (None without contact)."""
        if not self.contact_tags:
            return None
        return np.concatenate([self.facets(tag) for tag in self.contact_tags])

    @property
    def frictional(self) -> bool:
        """Whether the contact terms carry Coulomb friction (a coefficient was given)."""
        return self.friction is not None

    @property
    def frictional_contacts(self) -> list[NitscheContact]:
        """The contacts with a Coulomb coefficient (all of them, or none)."""
        return [contact for contact in self.contacts if contact.frictional]

    @property
    def symmetric_jacobian(self) -> bool:
        """Whether the Jacobian of every time scheme is symmetric: without friction or a
        moving obstacle whose normal turns, with the symmetric variant Theta = 1 or with
        penalty (whose test term is v_n).
        The stepper reads it once, when it is built."""
        if self.frictional:  # contact pairs keep it: measured symmetric to 5e-17
            return False
        if self.finite:  # the averaged stress's derivative is not symmetric
            return False
        if any(contact.obstacle.turns for contact in self.moving_contacts):
            # the hybrid scheme tests with n_c at t^{n+1/2} what its force takes with n_c
            # at t^{n+1} (docs/method.md section 13): a normal that turns breaks the symmetry
            return False
        return self.method == "penalty" or float(np.asarray(self.nitsche_theta.value)) == 1.0

    def operator(self, u, v, velocity=None, reference=None):
        """B(u)(v) = A_Thgamma(u, v) + the Nitsche contact terms at one time level
        (with friction, ``velocity`` is u' at that level; ``reference``: the guarded
        friction law, see :class:`~nitsche_dolfinx.contact_terms.GuardedFriction`)."""
        form = self.bulk_stiffness(u, v)
        for contact in self.contacts:
            form = form + contact.residual(u, v, velocity, reference)
        return form

    def hybrid_operator(self, u_old, u_new, v, velocity=None, reference=None):
        """The hybrid scheme's operator: A_Thgamma at the midpoint and the switching term
        Phi; with friction, the step's mean velocity ``velocity`` = (u_new - u_old) / tau."""
        if self.finite:  # the energy-consistent stress (docs/method.md section 15)
            stress = averaged_stress(self.law, self.material_constants, u_old, u_new)
            form = ufl.inner(stress, ufl.grad(v)) * self.dx
        else:
            form = self.bulk_stiffness((u_old + u_new) / 2, v)
        for contact in self.contacts:
            form = form + contact.hybrid_residual(u_old, u_new, v, velocity, reference)
        return form

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

    @property
    def moving_contacts(self) -> list[NitscheContact]:
        """The contacts whose obstacle moves (:class:`~nitsche_dolfinx.motion.MovingObstacle`)."""
        return [contact for contact in self.contacts if contact.moving]

    def move_obstacles(self, t_old: float, t_new: float | None = None) -> None:
        """Put the moving obstacles at the times of a step from ``t_old`` to ``t_new``
        (``"old"``, ``"mid"`` and ``"new"``: docs/method.md section 13); without ``t_new``,
        at t_old, the current level."""
        for contact in self.moving_contacts:
            contact.obstacle.move(t_old, t_new)

    def set_time(self, t: float) -> None:
        """Move the data to time ``t``: :attr:`t` and the functions of t."""
        self.t.value = t
        for force in self._body_forces:
            force.set_time(t)
        for _, traction in self._tractions:
            traction.set_time(t)


def _check_finite(mesh, nitsche: NitscheParameters, law) -> None:
    """Refuse what a hyperelastic material (of ``law``) does not take (yet)."""
    require(
        mesh.geometry.dim > 1, "law", law,
        "a hyperelastic material needs a 2D (plane strain) or 3D mesh",
    )  # fmt: skip
    require(
        nitsche.method == "nitsche", "method", nitsche.method,
        "a hyperelastic material takes Nitsche's method (not penalty nor the mixed one)",
    )  # fmt: skip
    require(
        nitsche.friction is None, "friction", nitsche.friction,
        "a hyperelastic body's contact is frictionless so far",
    )  # fmt: skip
