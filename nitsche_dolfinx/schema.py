"""The keys of a TOML configuration: for each table, each key's kind, default and meaning.

:data:`SCHEMA` is the one source of both the type checks of
:func:`nitsche_dolfinx.config.validate` and the text of ``nitsche-dolfinx schema``
(:func:`describe`). The values' ranges are checked where they are used: by the parameter
objects of :mod:`nitsche_dolfinx.parameters` and by :mod:`nitsche_dolfinx.config`.
"""

from __future__ import annotations

import textwrap
from dataclasses import dataclass, field

from .linear_solvers import LINEAR_SOLVERS
from .mesh_generators import GENERATOR_KEYS, MESH_GENERATORS
from .parameters import CONTACT_METHODS, GAMMA0_SCALINGS, MASS_MATRICES
from .schemes import SCHEMES
from .valueforms import PROFILES

__all__ = [
    "FACET_SELECTORS",
    "KINDS",
    "OBSTACLE_TYPES",
    "PROBE_QUANTITIES",
    "SCHEMA",
    "Key",
    "Table",
    "describe",
]


class _Required:
    def __repr__(self):
        return "required"


#: The default of a key that must be given.
REQUIRED = _Required()


@dataclass(frozen=True)
class Key:
    """One key: its kind (a key of :data:`KINDS`), its default (:data:`REQUIRED`, None for
    "not set", or a value), what it means, and the choices of a string key."""

    kind: str
    default: object
    meaning: str
    choices: tuple = ()
    shown_default: str | None = None  # the default in words, when not a plain value

    @property
    def required(self) -> bool:
        return self.default is REQUIRED

    def default_text(self) -> str:
        """The default as TOML writes it (or in words)."""
        if self.shown_default is not None:
            return self.shown_default
        return (
            "required"
            if self.required
            else "none"
            if self.default is None
            else toml_text(self.default)
        )


def toml_text(value) -> str:
    """``value`` as TOML writes it."""
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, list):
        return "[" + ", ".join(toml_text(x) for x in value) + "]"
    return repr(value)


@dataclass(frozen=True)
class Table:
    """A table (``[name]``) or an array of tables (``[[name]]``) and its keys."""

    meaning: str
    keys: dict[str, Key] = field(default_factory=dict)
    array: bool = False
    required: bool = False
    free: bool = False  # any key (the [petsc] options)

    def header(self, name: str) -> str:
        return f"[[{name}]]" if self.array else f"[{name}]"


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


#: kind -> (how it is named in messages, the check of a value's type).
KINDS = {
    "string": ("a string", lambda v: isinstance(v, str)),
    "integer": ("an integer", lambda v: isinstance(v, int) and not isinstance(v, bool)),
    "number": ("a number", _is_number),
    "boolean": ("true or false", lambda v: isinstance(v, bool)),
    "vector": (
        "a number or a list of numbers",
        lambda v: _is_number(v) or (isinstance(v, list) and all(_is_number(x) for x in v)),
    ),
    "tag pair": (
        "a list of two integer tags",
        lambda v: isinstance(v, list) and len(v) == 2 and all(KINDS["integer"][1](x) for x in v),
    ),
    "strings": (
        "a list of strings",
        lambda v: isinstance(v, list) and all(isinstance(x, str) for x in v),
    ),
    # checked in depth by nitsche_dolfinx.valueforms
    "value in time": (
        "a vector, a table [[t, value...], ...] or a profile {profile = ...}",
        lambda v: _is_number(v) or isinstance(v, (list, dict)),
    ),
    "value in x": (
        "a vector or {constant, gradient, hessian}",
        lambda v: _is_number(v) or isinstance(v, (list, dict)),
    ),
    # its keys: FACET_SELECTORS
    "selector": ("an inline table { key = value, ... }", lambda v: isinstance(v, dict)),
}

#: Obstacle types -> the keys each takes (besides type and tag) and what it is.
OBSTACLE_TYPES = {
    "plane": (("point", "normal"), "the half-space bounded by the plane through point"),
    "circle": (("center", "radius", "side"), "a circle (2D)"),
    "sphere": (("center", "radius", "side"), "a sphere (3D)"),
    "cylinder": (("point", "axis", "radius", "side"), "a circular cylinder (3D)"),
}
#: Probe quantities: whether they take a component (and a point).
PROBE_QUANTITIES = {"displacement": True, "velocity": True, "contact_pressure": False}

_FROM_EXTENT = "1e-8 times the largest |coordinate| of the mesh"

#: The facet selectors of [[facet_tag]] (inline tables), those of nitsche_dolfinx.meshes
#: (OnPlane, NormalWithin, InBox) with their arguments as keys.
FACET_SELECTORS = {
    "on_plane": Table(
        "every vertex on the plane through point (a line in 2D, a point in 1D): "
        "|(x - point) . normal| <= tolerance",
        {
            "point": Key("vector", REQUIRED, "a point of the plane"),
            "normal": Key("vector", REQUIRED, "a normal of the plane (not zero)"),
            "tolerance": Key("number", None, "the distance allowed", shown_default=_FROM_EXTENT),
        },
    ),
    "normal_within": Table(
        "the outward normal (of the straight facet through the vertices) within angle "
        "degrees of direction",
        {
            "direction": Key("vector", REQUIRED, "the direction (not zero)"),
            "angle": Key("number", 1.0, "the largest angle, in degrees, in [0, 180]"),
        },
    ),
    "in_box": Table(
        "every vertex in the box lower <= x <= upper, widened by tolerance",
        {
            "lower": Key("vector", REQUIRED, "the lower corner"),
            "upper": Key("vector", REQUIRED, "the upper corner (upper >= lower)"),
            "tolerance": Key("number", None, "the widening", shown_default=_FROM_EXTENT),
        },
    ),
}


def _choices(names) -> str:
    return " | ".join(names)


_MESH_KEYS = {
    "file": Key(
        "string", None, "a gmsh .msh or XDMF mesh, relative to the TOML file (give file or "
        "generator); its facet tags: the physical groups of its boundary, and [[facet_tag]]"
    ),
    "generator": Key(
        "string", None, "a mesh of the library (see the generators below)",
        tuple(MESH_GENERATORS),
    ),
    "gdim": Key("integer", None, "geometric dimension of a .msh file", shown_default="the file's"),
    **{
        name: Key(kind, None, meaning, shown_default="the generator's")
        for name, (kind, meaning, _, _) in GENERATOR_KEYS.items()
    },
    "degree": Key("integer", 1, "Lagrange degree of the displacement: 1 or 2"),
    "mass": Key("string", "consistent", "mass matrix (lumped and redistributed: P1)",
                MASS_MATRICES),
    "quadrature_degree": Key(
        "integer", None, "quadrature degree of every integral",
        shown_default="2 degree (+ 2 on curved cells)",
    ),
}  # fmt: skip

#: For each table: what it is and its keys.
SCHEMA: dict[str, Table] = {
    "mesh": Table("the mesh, read or generated, and its finite elements", _MESH_KEYS,
                  required=True),
    "facet_tag": Table(
        "boundary facets tagged by selectors, before the terms are added (a mesh without "
        "physical groups, or new parts of one): those that every selector given chooses",
        {
            "tag": Key("integer", REQUIRED, "the facet tag, from 1 to 2^31 - 1; a facet "
                       "keeps the last tag that chooses it, else its tag in the mesh (several "
                       "tables of one tag: the union of their facets)"),
            **{
                name: Key("selector", None, f"{table.meaning} (keys: below)",
                          shown_default="none")
                for name, table in FACET_SELECTORS.items()
            },
        },
        array=True,
    ),
    "material": Table(
        "linear elasticity: E and nu, or lmbda and mu (plane strain in 2D)",
        {
            "E": Key("number", None, "Young's modulus"),
            "nu": Key("number", None, "Poisson's ratio, in (-1, 1/2)"),
            "lmbda": Key("number", None, "first Lame coefficient"),
            "mu": Key("number", None, "shear modulus"),
            "rho": Key("number", 1.0, "density"),
        },
        required=True,
    ),
    "nitsche": Table(
        "the contact terms (docs/method.md sections 2 and 10)",
        {
            "method": Key("string", "nitsche", "contact method (mixed: a Lagrange multiplier, "
                          "one obstacle, scheme cn)", CONTACT_METHODS),
            "gamma0": Key("number", 1e-3, "Nitsche parameter: gamma_h = gamma0 h (penalty: "
                          "eps = gamma0 h)"),
            "gamma0_scaling": Key("string", "absolute", "absolute: gamma0 in 1/stress; E: "
                                  "gamma_h = gamma0 h / E", GAMMA0_SCALINGS),
            "theta": Key("number", 1.0, "the variant Theta: 1 symmetric, 0 non-symmetric, "
                         "-1 skew-symmetric"),
            "friction": Key("number", None, "Coulomb coefficient mu_f >= 0",
                            shown_default="frictionless"),
        },
    ),
    "scheme": Table(
        "the time scheme and the time steps",
        {
            "name": Key("string", "hybrid", "time scheme", tuple(SCHEMES)),
            "dt": Key("number", REQUIRED, "time step tau"),
            "t_end": Key("number", REQUIRED, "final time T (a shorter last step reaches it)"),
            "theta": Key("number", 1.0, "theta of the theta scheme, in [1/2, 1]"),
            "beta": Key("number", 0.25, "beta of the Newmark scheme"),
            "gamma": Key("number", 0.5, "gamma of the Newmark scheme"),
            "max_step_cuts": Key("integer", 5, "a failing step is halved down to dt / 2^N"),
        },
        required=True,
    ),
    "solver": Table(
        "the Newton solver of a step (PETSc options: [petsc])",
        {
            "linear_solver": Key("string", "auto", "linear solver preset (auto: chosen from "
                                 "the problem)", tuple(LINEAR_SOLVERS)),
            "reuse_jacobian": Key("boolean", True, "assemble the bulk Jacobian once"),
            "preconditioner_lag": Key("integer", 0, "keep a factorisation as GMRES "
                                      "preconditioner up to this many iterations (0: never)"),
            "guard_friction": Key("boolean", True, "solve friction by the guarded Newton"),
        },
    ),
    "obstacle": Table(
        "a rigid obstacle in contact with the facets tag",
        {
            "type": Key("string", "plane", "what it is", tuple(OBSTACLE_TYPES)),
            "tag": Key("integer", REQUIRED, "facet tag of Gamma_C"),
            "point": Key("vector", None, "plane: a point of it; cylinder: a point of its axis"),
            "normal": Key("vector", None, "plane: its normal, towards the body"),
            "center": Key("vector", None, "circle, sphere: the centre"),
            "axis": Key("vector", None, "cylinder: the direction of its axis"),
            "radius": Key("number", None, "circle, sphere, cylinder: the radius"),
            "side": Key("string", "outside", "circle, sphere, cylinder: where the body is "
                        "(inside: a cavity)", ("outside", "inside")),
        },
        array=True,
    ),
    "contact_pair": Table(
        "contact between two surfaces of the mesh (docs/method.md section 11)",
        {
            "tags": Key("tag pair", REQUIRED, "the two facet tags"),
            "variant": Key("string", "unbiased", "biased: the first tag is the slave",
                           ("unbiased", "biased")),
            "direction": Key("vector", None, "pair along it, from the first to the second",
                             shown_default="closest points"),
        },
        array=True,
    ),
    "dirichlet": Table(
        "a prescribed displacement, or one of its components (a symmetry plane or a roller)",
        {
            "tag": Key("integer", REQUIRED, "facet tag"),
            "value": Key("value in time", REQUIRED, "the displacement (with component: a "
                         "scalar, the value of that component)"),
            "component": Key("integer", None, "prescribe only this component (0: x, 1: y, "
                             "2: z), the others free", shown_default="all"),
        },
        array=True,
    ),
    "traction": Table(
        "a surface load g_N",
        {
            "tag": Key("integer", REQUIRED, "facet tag"),
            "value": Key("value in time", REQUIRED, "the traction"),
        },
        array=True,
    ),
    "body_force": Table(
        "a volume force f (gravity: rho g)",
        {"value": Key("value in time", REQUIRED, "the force per unit volume")},
    ),
    "initial": Table(
        "the initial values",
        {
            "displacement": Key("value in x", None, "u0", shown_default="0"),
            "velocity": Key("value in x", None, "v0 (or per body: [[body]])", shown_default="0"),
        },
    ),
    "body": Table(
        "a body of a two-body mesh (its cells tagged tag)",
        {
            "tag": Key("integer", REQUIRED, "cell tag"),
            "velocity": Key("vector", REQUIRED, "its initial velocity"),
        },
        array=True,
    ),
    "probe": Table(
        "a history column: a quantity at a point, or its mean over facets, cells or the "
        "whole mesh",
        {
            "name": Key("string", REQUIRED, "the column's name"),
            "quantity": Key("string", REQUIRED, "what is averaged (contact_pressure: "
                            "lambda_h of the first obstacle)", tuple(PROBE_QUANTITIES)),
            "component": Key("integer", 0, "component of a vector quantity"),
            "point": Key("vector", None, "the value at this point of the body (reference "
                         "configuration; displacement, velocity)"),
            "facets": Key("integer", None, "mean over the facets of this tag"),
            "cells": Key("integer", None, "mean over the cells of this tag",
                         shown_default="the whole mesh"),
        },
        array=True,
    ),
    "output": Table(
        "what the run writes (relative paths: from the TOML file's folder)",
        {
            "dir": Key("string", None, "output folder", shown_default="out/<TOML name>"),
            "every": Key("integer", None, "write the fields every N steps (0: never)",
                         shown_default="about 50 outputs"),
            "checkpoint_every": Key("integer", 0, "save the state every N steps (0: only when "
                                    "the run stops early)"),
            "columns": Key("strings", None, "the columns of history.csv, any of the run's: "
                           "those of the demos, dt, step_cuts, momentum_x, ... and "
                           "centre_of_mass_x, ... (1D: momentum, centre_of_mass), "
                           "contact_force_k and contact_area_k (the k-th obstacle; a contact "
                           "pair counts two), friction_dissipation, energy_balance_residual, "
                           "the probes' names",
                           shown_default="those of the 2D/3D demos, then the probes"),
        },
    ),
    "petsc": Table("PETSc options of the step's solver, flat: snes_rtol = 1e-8", free=True),
}  # fmt: skip

_FORMS = """\
Values in time ([[dirichlet]], [[traction]], [body_force] value): a vector, [0.0, -1.0];
  a table [[t0, v...], [t1, v...], ...], linear in between, held outside; or a profile:
{profiles}
Values in x ([initial]): a vector, or {{ constant = c, gradient = G, hessian = H }}:
  u_i(x) = c_i + G_ij x_j + 1/2 H_ijk x_j x_k (each optional).
No value is evaluated as code."""


def describe(width: int = 100) -> str:
    """Every table and key with its kind, default and meaning (``nitsche-dolfinx schema``)."""
    lines = []

    def add(head: str, text: str, indent: int) -> None:
        wrapped = textwrap.wrap(text, max(40, width - indent))
        lines.append(head.ljust(indent) + wrapped[0])
        lines.extend(" " * indent + rest for rest in wrapped[1:])

    def add_keys(table: Table) -> None:
        for key, spec in table.keys.items():
            choices = f" ({' | '.join(spec.choices)})" if spec.choices else ""
            default = "required" if spec.required else f"default: {spec.default_text()}"
            add(f"  {key:18s} {spec.kind:14s}", f"{spec.meaning}{choices}; {default}", 36)
        lines.append("")

    for name, table in SCHEMA.items():
        header = table.header(name)
        add(f"{header}  ", f"{table.meaning}{' (required)' * table.required}", len(header) + 2)
        add_keys(table)
    lines.append("Facet selectors ([[facet_tag]] NAME = { key = value, ... }), their keys:")
    for name, table in FACET_SELECTORS.items():
        add(f"{name} = {{ ... }}  ", table.meaning, len(name) + 12)
        add_keys(table)
    lines.append("Mesh generators ([mesh] generator = NAME), their keys with defaults, their tags:")
    for name, generator in MESH_GENERATORS.items():
        keys = ", ".join(f"{key} = {toml_text(value)}" for key, value in generator.keys.items())
        add(f"  {name:16s}", f"{generator.meaning}; {keys}; {generator.tags}", 19)
    lines.append("")
    lines.append("Obstacle types ([[obstacle]] type = NAME) and their keys:")
    for name, (keys, what) in OBSTACLE_TYPES.items():
        add(f"  {name:16s}", f"{what}: {', '.join(keys)}", 19)
    lines.append("")
    profiles = "\n".join(
        f"  {{ profile = {toml_text(name)}, {', '.join(keys)} }}"
        for name, (_, keys) in PROFILES.items()
    )
    lines.append(_FORMS.format(profiles=profiles))
    return "\n".join(lines)
