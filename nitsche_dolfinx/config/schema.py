"""The keys of a TOML configuration: for each table, each key's kind, default and meaning.

:data:`SCHEMA` is the one source of both the type checks of
:func:`nitsche_dolfinx.config.reader.validate` and the text of ``nitsche-dolfinx schema``
(:func:`describe`). It is assembled from the registries that own their keys: the run
parameters (:data:`~nitsche_dolfinx.config.parameter_table.PARAMETERS`), the schemes
(:data:`~nitsche_dolfinx.steppers.schemes.SCHEMES`), the obstacles
(:data:`~nitsche_dolfinx.physics.obstacles.OBSTACLES`) and the mesh generators
(:data:`~nitsche_dolfinx.config.mesh_generators.MESH_GENERATORS`); the tables of terms
(loads, Dirichlet values, probes...) are described here. The values' ranges are
checked where they are used: by the parameter objects of
:mod:`nitsche_dolfinx.common.parameters`, the obstacles' classes, and
:mod:`nitsche_dolfinx.config.reader`.
"""

from __future__ import annotations

import textwrap
from dataclasses import dataclass, field

from ..common.keys import REQUIRED, Key, toml_text
from ..physics.motion import MOTION_KEYS
from ..physics.obstacles import OBSTACLES
from ..physics.valueforms import PROFILES
from ..post.reports import markdown_cell, markdown_table
from .mesh_generators import GENERATOR_KEYS, MESH_GENERATORS
from .parameter_table import by_name, toml_keys

__all__ = [
    "FACET_SELECTORS",
    "PROBE_QUANTITIES",
    "SCHEMA",
    "Table",
    "describe",
    "markdown",
]


@dataclass(frozen=True)
class Table:
    """A table (``[name]``) or an array of tables (``[[name]]``) and its keys."""

    meaning: str
    keys: dict[str, Key] = field(default_factory=dict)
    array: bool = False
    required: bool = False
    free: bool = False  # any key (the [petsc] options)

    def header(self, name: str) -> str:
        """The table's header in TOML: ``[name]``, or ``[[name]]`` for an array."""
        return f"[[{name}]]" if self.array else f"[{name}]"


#: Probe quantities: whether they take a component (and a point).
PROBE_QUANTITIES = {"displacement": True, "velocity": True, "contact_pressure": False}

_FROM_EXTENT = "1e-8 times the largest |coordinate| of the mesh"


def _non_negative(value) -> bool:
    return value >= 0


#: The facet selectors of [[facet_tag]] (inline tables), those of nitsche_dolfinx.meshing.meshes
#: (OnPlane, NormalWithin, InBox) with their arguments as keys.
FACET_SELECTORS = {
    "on_plane": Table(
        "every vertex on the plane through point (a line in 2D, a point in 1D): "
        "|(x - point) . normal| <= tolerance",
        {
            "point": Key("vector", REQUIRED, "a point of the plane"),
            "normal": Key("vector", REQUIRED, "a normal of the plane (not zero)"),
            "tolerance": Key(
                "number",
                None,
                "the distance allowed",
                shown_default=_FROM_EXTENT,
                check=_non_negative,
                requirement=">= 0",
            ),
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
            "tolerance": Key(
                "number",
                None,
                "the widening",
                shown_default=_FROM_EXTENT,
                check=_non_negative,
                requirement=">= 0",
            ),
        },
    ),
}


_MESH_KEYS = {
    "file": Key(
        "string", None, "a gmsh .msh or XDMF mesh, relative to the TOML file (give file or "
        "generator); its facet tags: the physical groups of its boundary, and [[facet_tag]]"
    ),
    "generator": Key(
        "string", None, "a mesh of the library (see the generators below)",
        tuple(MESH_GENERATORS),
    ),
    "gdim": Key("integer", None, "geometric dimension of a .msh file", shown_default="the file's",
                check=(1, 2, 3).__contains__, requirement="1, 2 or 3"),
    **GENERATOR_KEYS,
    **toml_keys("mesh"),
}  # fmt: skip


def _obstacle_keys() -> dict[str, Key]:
    """The keys of [[obstacle]]: its type and tag, and those of every type of
    :data:`~nitsche_dolfinx.physics.obstacles.OBSTACLES` (required by the types that take them)."""
    keys = {
        "type": Key("string", "plane", "what it is", tuple(OBSTACLES)),
        "tag": Key("integer", REQUIRED, "facet tag of Gamma_C"),
    }
    users: dict[str, list[str]] = {}
    for name, obstacle in OBSTACLES.items():
        for key in obstacle.keys:
            users.setdefault(key, []).append(name)
    for key, names in users.items():
        specs = [OBSTACLES[name].keys[key] for name in names]
        meanings = {spec.meaning: [n for n, s in zip(names, specs) if s.meaning == spec.meaning]
                    for spec in specs}  # fmt: skip
        meaning = "; ".join(f"{', '.join(kinds)}: {text}" for text, kinds in meanings.items())
        first = specs[0]
        default = None if first.required else first.default
        keys[key] = Key(first.kind, default, meaning, first.choices)
    return {**keys, **MOTION_KEYS}


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
                       "tables of one tag: the union of their facets)",
                       check=lambda tag: 1 <= tag < 2**31, requirement="from 1 to 2^31 - 1"),
            **{
                name: Key("selector", None, f"{table.meaning} (keys: below)",
                          shown_default="none")
                for name, table in FACET_SELECTORS.items()
            },
        },
        array=True,
    ),
    "material": Table(
        "the material: its law, and E and nu or lmbda and mu (plane strain in 2D)",
        toml_keys("material"),
        required=True,
    ),
    "nitsche": Table("the contact terms (docs/method.md sections 2 and 10)", toml_keys("nitsche")),
    "scheme": Table("the time scheme and the time steps", toml_keys("scheme"), required=True),
    "solver": Table(
        "the Newton solver of a step (PETSc options: [petsc])", toml_keys("solver")
    ),
    "obstacle": Table(
        "a rigid obstacle in contact with the facets tag (its keys: those of its type, below)",
        _obstacle_keys(),
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
            "follow": Key("boolean", None, "pair again in the last step's configuration "
                          "when the surfaces have slid (false: in the reference one only)",
                          shown_default="true with closest points, false along a direction"),
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
                             "2: z), the others free", shown_default="all",
                             check=(0, 1, 2).__contains__,
                             requirement="0 (x), 1 (y) or 2 (z)"),
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
    "initial": Table("the initial values", toml_keys("initial")),
    "damping": Table(
        "Rayleigh damping C = alpha M + beta K (docs/method.md section 14)", toml_keys("damping")
    ),
    "region": Table(
        "a material for the cells tagged tag (the others take [material]; "
        "docs/method.md section 13)",
        {
            "tag": Key("integer", REQUIRED, "cell tag (a physical group of cells of a .msh "
                       "file, a body of a generated mesh, or the cells of in_box)"),
            "in_box": Key("selector", None, "tags the cells whose vertices all lie in the "
                          "box lower <= x <= upper (keys: lower, upper, tolerance, as "
                          "[[facet_tag]] in_box) with tag, over the mesh's own tags",
                          shown_default="none"),
            **{name: key for name, key in toml_keys("material").items() if name != "rho"},
            "rho": Key("number", None, "density", shown_default="[material] rho"),
        },
        array=True,
    ),
    "body": Table(
        "a body: the cells tagged tag, apart from the other bodies; its momentum, centre "
        "of mass and angular momentum join the history (docs/method.md section 6)",
        {
            "tag": Key("integer", REQUIRED, "cell tag (a physical group of cells of a .msh "
                       "file, or a body of a generated mesh)"),
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
        toml_keys("output"),
    ),
    "petsc": Table(by_name("petsc_options").key.meaning, free=True),
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
    lines.append("Obstacle types ([[obstacle]] type = NAME), their dimensions and keys:")
    for name, obstacle in OBSTACLES.items():
        dimensions = ", ".join(f"{d}D" for d in obstacle.dimensions)
        add(f"  {name:16s}", f"{obstacle.meaning} ({dimensions}): {', '.join(obstacle.keys)}", 19)
    lines.append("")
    profiles = "\n".join(
        f"  {{ profile = {toml_text(name)}, {', '.join(keys)} }}"
        for name, (_, keys) in PROFILES.items()
    )
    lines.append(_FORMS.format(profiles=profiles))
    return "\n".join(lines)


def _sentence(text: str) -> str:
    """``text`` as a sentence of a Markdown page: a capital, a full stop, bars escaped."""
    return markdown_cell(text[:1].upper() + text[1:] + ".")


def _key_table(keys: dict[str, Key]) -> list[str]:
    rows = []
    for key, spec in keys.items():
        choices = f" (one of {', '.join(f'`{c}`' for c in spec.choices)})" if spec.choices else ""
        default = "**required**" if spec.required else f"`{spec.default_text()}`"
        if spec.shown_default is not None:
            default = markdown_cell(spec.shown_default)
        rows.append([f"`{key}`", spec.kind, default, markdown_cell(spec.meaning) + choices])
    return [markdown_table(["key", "kind", "default", "meaning"], rows), ""]


def markdown() -> str:
    """Every table and key of :data:`SCHEMA`, the facet selectors, mesh generators,
    obstacles and value forms, as Markdown: the site's TOML reference (docs/toml.md), made
    from the same objects that validate a file."""
    lines = ["## Tables", ""]
    for name, table in SCHEMA.items():
        header = table.header(name)
        text = _sentence(table.meaning) + " Required." * table.required
        text += " An array of tables: repeat the header for each one." * table.array
        lines += [f"### `{header}`", "", text, ""]
        if table.free:
            lines += ["Any key: each is a PETSc option, its value the option's value.", ""]
        lines += _key_table(table.keys) if table.keys else []
    lines += [
        "## Facet selectors",
        "",
        "`[[facet_tag]]` tags facets with `NAME = { key = value, ... }`, NAME one of:",
        "",
    ]
    for name, table in FACET_SELECTORS.items():
        lines += [f"### `{name}`", "", _sentence(table.meaning), ""] + _key_table(table.keys)
    lines += ["## Mesh generators", "",
              "`[mesh] generator = NAME`: each generator takes some of the `[mesh]` keys above, "
              "with its own defaults, and tags its facets and cells.", ""]  # fmt: skip
    generators = [
        [f"`{name}`", markdown_cell(generator.meaning),
         ", ".join(f"`{key} = {toml_text(value)}`" for key, value in generator.keys.items()),
         markdown_cell(generator.tags)]
        for name, generator in MESH_GENERATORS.items()
    ]  # fmt: skip
    header = ["generator", "what it makes", "its keys and defaults", "its tags"]
    lines.append(markdown_table(header, generators))
    lines += ["", "## Obstacles", "", "`[[obstacle]] type = NAME`, NAME one of:", ""]
    for name, obstacle in OBSTACLES.items():
        dimensions = ", ".join(f"{d}D" for d in obstacle.dimensions)
        lines += [f"### `{name}`", "", _sentence(f"{obstacle.meaning} ({dimensions})"), ""]
        lines += _key_table(obstacle.keys)
    profiles = ", ".join(
        f"`{{ profile = {toml_text(name)}, {', '.join(keys)} }}`"
        for name, (_, keys) in PROFILES.items()
    )
    lines += [
        "## Values in time and in space", "",
        "- **Values in time** (`[[dirichlet]]`, `[[traction]]`, `[body_force]` value): a "
        "vector such as `[0.0, -1.0]`, whose entries may be expressions of x, y, z and t; a "
        "table `[[t0, v...], [t1, v...], ...]`, linear in between and held outside; or a "
        f"profile: {profiles}.",
        "- **Values in x** (`[initial]`): a vector, or `{ constant = c, gradient = G, "
        "hessian = H }`: u_i(x) = c_i + G_ij x_j + 1/2 H_ijk x_j x_k (each optional).",
        "- No value is evaluated as code.", "",
    ]  # fmt: skip
    return "\n".join(lines)
