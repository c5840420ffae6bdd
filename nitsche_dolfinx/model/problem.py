"""The model: linear elastodynamics with contact, as terms added to a weak form.

A :class:`ContactProblem` holds the mesh, the material and the terms of the
weak form: Dirichlet conditions, loads, one contact per rigid obstacle and two per
contact pair (its halves). It
offers them to the time schemes through the
:class:`~nitsche_dolfinx.steppers.schemes.Model` interface (``inertia``, ``operator``,
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

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI

from ..common import compat
from ..common.parameters import Discretisation, NitscheParameters, require
from ..contact.nitsche import NitscheContact
from ..meshing.bodies import Body, make_body
from ..meshing.meshes import cell_diameter
from ..physics.damping import RayleighDamping
from ..physics.mass import MassMatrix
from ..physics.material import Material, MaterialConstants
from ..physics.regions import CellwiseMaterial
from .contacts import ProblemContacts
from .data import ProblemData
from .terms import ProblemTerms

__all__ = ["ContactProblem"]


class ContactProblem(ProblemTerms, ProblemContacts, ProblemData):
    """Linear elastodynamics with Nitsche contact: against rigid obstacles
    (:meth:`add_obstacle`) and between bodies (:meth:`add_contact_pair`).

    Args:
        mesh: The dolfinx mesh (1D, 2D or 3D).
        facet_tags: Facet tags naming the boundary parts used by the terms.
        material: The elastic material and its density, or a dict {cell tag: Material}
            for a material per region (``cell_tags`` then tags every cell; the
            parameters become fields constant in each cell, still runtime values:
            :class:`~nitsche_dolfinx.physics.regions.CellwiseMaterial`).
        degree: Degree of the Lagrange displacement space (1 or 2).
        gamma0: Nitsche parameter: gamma_h = gamma0 h_T (small gamma0 = stiff contact), or
            gamma0 h_T / E with ``gamma0_scaling="E"``. Default (None): gamma0 E = 1e-3
            whatever the units (:data:`~nitsche_dolfinx.common.parameters.DEFAULT_GAMMA0_E`):
            gamma0 = 1e-3 / E, E the largest Young modulus of the materials, or 1e-3 with
            ``gamma0_scaling="E"`` (docs/method.md section 10).
        nitsche_theta: Nitsche variant Theta: 1 symmetric, 0 non-symmetric, -1 skew-symmetric.
        friction: Coulomb coefficient mu_f >= 0, or None (the default) for frictionless
            contact. With a coefficient, the frictional Nitsche term of docs/method.md section 2 is
            added (:meth:`~nitsche_dolfinx.contact.nitsche.NitscheContact.friction_term`) with the
            tangential velocity of the time scheme; mu_f is the ``fem.Constant``
            attribute ``friction`` and mu_f = 0 is the frictionless problem.
        method: Contact method: ``"nitsche"`` (the default), ``"penalty"``
            (:class:`~nitsche_dolfinx.contact.nitsche.PenaltyContact`, eps = gamma0 h_T) or
            ``"mixed"``: a Lagrange multiplier for the pressure, one obstacle,
            Crank-Nicolson only (:class:`~nitsche_dolfinx.steppers.mixed.MixedStepper`).
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
            :data:`~nitsche_dolfinx.common.parameters.GAMMA0_E_RANGE`.

    ``cell_tags``: the mesh's cell tags, for a material per region.

    The parameters are checked by :class:`~nitsche_dolfinx.common.parameters.NitscheParameters`
    and :class:`~nitsche_dolfinx.common.parameters.Discretisation`.
    ``gamma0`` and ``nitsche_theta`` are ``fem.Constant`` attributes: change
    their ``.value`` between runs without recompiling any form. The material enters
    the forms as constants too (:attr:`material_constants`): a problem built with
    another material reuses the compiled forms.

    Its parts: the terms of the weak form (:class:`~nitsche_dolfinx.model.terms.ProblemTerms`),
    the obstacles and contact pairs (:class:`~nitsche_dolfinx.model.contacts.ProblemContacts`),
    the loads, conditions and initial values (:class:`~nitsche_dolfinx.model.data.ProblemData`).
    """

    # The methods of the parts, named here too: the API reference lists a class's own
    # members (the same functions and properties, nothing is overridden).

    # the terms of the weak form (model/terms.py)
    stress = ProblemTerms.stress
    bulk_stiffness = ProblemTerms.bulk_stiffness
    stored_energy = ProblemTerms.stored_energy
    von_mises = ProblemTerms.von_mises
    inertia = ProblemTerms.inertia
    mass_diagonal = ProblemTerms.mass_diagonal
    massless_dofs = ProblemTerms.massless_dofs
    operator = ProblemTerms.operator
    hybrid_operator = ProblemTerms.hybrid_operator
    symmetric_jacobian = ProblemTerms.symmetric_jacobian
    set_damping = ProblemTerms.set_damping
    damping_force = ProblemTerms.damping_force

    # the obstacles and contact pairs (model/contacts.py)
    add_obstacle = ProblemContacts.add_obstacle
    add_contact_pair = ProblemContacts.add_contact_pair
    pairs = ProblemContacts.pairs
    track_partners = ProblemContacts.track_partners
    follow_pairs = ProblemContacts.follow_pairs
    pairing_state = ProblemContacts.pairing_state
    restore_pairs = ProblemContacts.restore_pairs
    update_partners = ProblemContacts.update_partners
    frictional = ProblemContacts.frictional
    frictional_contacts = ProblemContacts.frictional_contacts
    moving_contacts = ProblemContacts.moving_contacts
    move_obstacles = ProblemContacts.move_obstacles
    solver_hint = ProblemContacts.solver_hint
    stability_hint = ProblemContacts.stability_hint

    # the loads, conditions and initial values (model/data.py)
    add_dirichlet = ProblemData.add_dirichlet
    add_body_force = ProblemData.add_body_force
    add_traction = ProblemData.add_traction
    set_initial_conditions = ProblemData.set_initial_conditions
    load = ProblemData.load
    traction_load = ProblemData.traction_load
    body_force = ProblemData.body_force
    body_force_in_space = ProblemData.body_force_in_space
    has_loads = ProblemData.has_loads
    has_tractions = ProblemData.has_tractions
    loads_in_time = ProblemData.loads_in_time
    autonomous = ProblemData.autonomous
    set_time = ProblemData.set_time

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
        self._init_material(material, regions, nitsche)
        self.degree = discretisation.degree
        self.method = nitsche.method
        self.mass = discretisation.mass
        self.gdim = mesh.geometry.dim
        self.V = compat.function_space(mesh, "Lagrange", self.degree, (self.gdim,))
        self.mass_matrix = MassMatrix(
            self.mass, self.V, self.material_constants.rho, self._contact_facets
        )
        self._init_nitsche(nitsche.gamma0, nitsche_theta, friction, nitsche.gamma0_scaling)
        if quadrature_degree is None:
            quadrature_degree = 2 * self.degree + 2 * (compat.geometry_degree(mesh) - 1)
        self.quadrature_degree = int(quadrature_degree)
        metadata = {"quadrature_degree": self.quadrature_degree}
        self.dx = ufl.Measure("dx", domain=mesh, metadata=metadata)
        self.ds = ufl.Measure("ds", domain=mesh, subdomain_data=facet_tags, metadata=metadata)
        self.contacts: list[NitscheContact] = []
        self.contact_tags: list[int] = []
        #: The bodies whose moments the history reports (:meth:`add_body`).
        self.bodies: list[Body] = []
        self._init_data()
        #: Rayleigh damping (:meth:`set_damping`), None without it (no term in the forms).
        self.damping: RayleighDamping | None = None
        #: The time t of the problem's data in UFL, a ``fem.Constant`` that the steppers move
        #: (:meth:`set_time`).
        self.t = fem.Constant(mesh, 0.0)
        #: The position x in UFL (``ufl.SpatialCoordinate``), for data in space.
        self.x = ufl.SpatialCoordinate(mesh)

    def _init_material(self, material, regions: bool, nitsche: NitscheParameters) -> None:
        """The material, or a material per cell tag (``regions``), as runtime constants."""
        #: The material (None with several: :attr:`materials`, :meth:`largest`).
        self.material = None if regions else material
        #: The material's parameters as runtime constants: the forms of another
        #: material are the same compiled forms (docs/method.md section 10); with a
        #: material per cell tag, fields constant in each cell (docs/method.md section 13).
        self.material_constants = (
            CellwiseMaterial(self.mesh, self.cell_tags, material)
            if regions
            else MaterialConstants(material, lambda value: fem.Constant(self.mesh, float(value)))
        )
        #: The strain energy W(C, constants) of a hyperelastic material (finite strains,
        #: docs/method.md section 15), None for linear elasticity.
        self.law = None if regions else material.strain_energy
        if self.law is not None:
            _check_finite(self.mesh, nitsche, material.law)
        for each in self.materials if regions else []:
            require(
                not each.finite, "law", each.law,
                "a hyperelastic material is one material for the whole mesh so far",
            )  # fmt: skip

    def _init_nitsche(self, gamma0, nitsche_theta, friction, gamma0_scaling: str) -> None:
        """The Nitsche parameters as runtime constants, and gamma_h."""
        mesh = self.mesh
        self.gamma0 = fem.Constant(mesh, float(gamma0))
        self.nitsche_theta = fem.Constant(mesh, float(nitsche_theta))
        self.friction = None if friction is None else fem.Constant(mesh, float(friction))
        self.h = cell_diameter(mesh)
        self.gamma0_scaling = gamma0_scaling
        if self.gamma0_scaling == "E":
            self.gamma_h = self.gamma0 * self.h / self.material_constants.E
        else:
            self.gamma_h = self.gamma0 * self.h

    @property
    def finite(self) -> bool:
        """Whether the material is hyperelastic (finite strains, docs/method.md section 15)."""
        return self.law is not None

    def largest(self, parameter: str) -> float:
        """The largest value of a :class:`~nitsche_dolfinx.physics.material.Material` property
        (``"E"``, ``"rho"``, ``"lmbda"``, ...) over the problem's materials."""
        return max(getattr(material, parameter) for material in self.materials)

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

    def add_body(self, tag: int, cell_tags=None) -> Body:
        """Declare the cells tagged ``tag`` a body: the history gets its linear momentum, its
        centre of mass and its angular momentum about the origin (``momentum_<tag>_x``, ...,
        :func:`~nitsche_dolfinx.output.history.body_columns`), from the rows of the mass matrix at
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
