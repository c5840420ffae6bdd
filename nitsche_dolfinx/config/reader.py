"""Run descriptions in TOML: reading and checking (the simulation they describe: builder).

A configuration names the mesh (a file, or one of the library's generated meshes), the
material, the contact terms, the time scheme, the obstacles and contact pairs, the
loads, the initial values, the history columns and the output::

    [mesh]
    file = "ring_2d.msh"            # relative to the TOML file; or generator = "disk"
    degree = 1

    [material]
    E = 1000.0                      # or lmbda and mu
    nu = 0.3

    [nitsche]
    gamma0 = 1e-6
    friction = 0.2                  # Coulomb; method = "penalty" or "mixed" also

    [scheme]
    name = "hybrid"                 # hybrid | theta | newmark | cn
    dt = 0.005
    t_end = 1.0

    [[obstacle]]
    type = "plane"                  # or circle, sphere, cylinder
    point = [0.0, 0.0]
    normal = [0.0, 1.0]
    tag = 1

    [body_force]
    value = [[0.0, 0.0, 0.0], [1.0, 0.0, -1.0]]   # [[t, f...], ...]: linear in t

    [initial]
    velocity = [0.0, -1.0]

    [output]
    every = 10

Every key, its kind, its default and its meaning: :data:`nitsche_dolfinx.config.schema.SCHEMA`,
printed by ``nitsche-dolfinx schema``; the run parameters under their API, TOML and flag
names: ``docs/parameters.md``. No value is ever evaluated as code: values in time and in
space are small tables (:mod:`nitsche_dolfinx.physics.valueforms`).

Everything is checked before anything is computed: :func:`load_config` reads the file
and :func:`validate` checks the kinds, the forms, the magnitudes and the keys each choice
takes; :func:`nitsche_dolfinx.config.builder.build_simulation` then checks the values with the
library's parameter objects before it makes or reads the mesh, and the tags and
dimensions against the mesh. A bad value raises :class:`ConfigError` naming it as
``file.toml: [table] key = value: ...`` (:func:`bad`, :func:`reported_at`).
"""

from __future__ import annotations

import contextlib
import math
import os

from ..common.keys import KINDS, is_number, is_plain, shown
from ..common.parameters import OutputParameters, ParameterError, TimeStepping
from ..output.history import (
    DAMPING_COLUMNS,
    FINITE_COLUMNS,
    FRICTION_HISTORY_COLUMNS,
    HISTORY_COLUMNS,
    OBSTACLE_COLUMNS,
    PAIRING_COLUMNS,
    WORK_COLUMNS,
    body_columns,
)
from ..physics.motion import MOTION_KEYS
from ..physics.obstacles import OBSTACLES
from ..physics.valueforms import check_field_value, check_time_value
from ..steppers.schemes import SCHEMES
from ..steppers.work import reaction_columns
from .mesh_generators import GENERATOR_KEYS, check_generator
from .parameter_table import by_name, in_words_of
from .schema import FACET_SELECTORS, PROBE_QUANTITIES, SCHEMA

try:  # an optional dependency: Python >= 3.11 has tomllib, before it the tomli package
    import tomllib
except ImportError:
    try:
        import tomli as tomllib
    except ImportError:
        tomllib = None

__all__ = [
    "ConfigError",
    "bad",
    "history_columns",
    "load_config",
    "output_parameters",
    "reported_at",
    "setting",
    "validate",
]

#: Fields written over a run when ``[output] every`` is not given (about this many).
DEFAULT_FIELD_OUTPUTS = 50


class ConfigError(ValueError):
    """A configuration file is invalid; the message names the file and the key."""


def load_config(path: str) -> dict:
    """Read and validate a TOML configuration.

    Relative file names in it (the mesh, the output folder) are taken relative to the
    folder of the TOML file; without ``[output] dir`` the output folder is
    ``out/<name of the TOML file>`` there.

    Raises:
        ConfigError: The file is missing, is not TOML, or is invalid.
    """
    path = str(path)
    config = _read(path)
    validate(config, path)
    base = os.path.dirname(os.path.abspath(path))
    output = config.setdefault("output", {})
    stem = os.path.splitext(os.path.basename(path))[0]
    output["dir"] = os.path.join(base, output.get("dir", os.path.join("out", stem)))
    mesh_file = config["mesh"].get("file")
    if mesh_file is not None:
        mesh_file = config["mesh"]["file"] = os.path.join(base, mesh_file)
        if os.path.isdir(mesh_file):
            raise ConfigError(f"{path}: [mesh] file {mesh_file!r} is a folder, not a mesh file")
        if not os.path.isfile(mesh_file):
            raise ConfigError(f"{path}: [mesh] file {mesh_file!r} does not exist")
    return config


def _read(path: str) -> dict:
    """The tables of the TOML file ``path``; every way it can fail is named with the file."""
    if os.path.isdir(path):
        raise ConfigError(f"{path}: the configuration is a folder, not a TOML file")
    if not os.path.exists(path):
        raise ConfigError(f"{path}: configuration file does not exist")
    if not os.path.isfile(path):
        raise ConfigError(f"{path}: the configuration is not a regular file (a device?)")
    if tomllib is None:
        raise ConfigError(f"{path}: reading TOML needs Python >= 3.11 or the tomli package")
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except tomllib.TOMLDecodeError as error:
        raise ConfigError(f"{path}: not valid TOML: {error}") from None
    except UnicodeDecodeError as error:  # TOML is UTF-8 text
        byte = error.object[error.start]
        raise ConfigError(
            f"{path}: not a TOML file: not UTF-8 text (byte 0x{byte:02x} at offset "
            f"{error.start}; a binary file?)"
        ) from None
    except OSError as error:
        raise ConfigError(f"{path}: cannot be read: {error.strerror}") from None


def setting(config: dict, table: str, key: str, item: dict | None = None):
    """``[table] key`` of ``config`` (of ``item``, one of the tables ``[[table]]``), or its
    default in :data:`~nitsche_dolfinx.config.schema.SCHEMA` (None: not set)."""
    spec = SCHEMA[table].keys[key]
    values = item if item is not None else config.get(table, {})
    return values.get(key, None if spec.required else spec.default)


def bad(source: str, where: str, key: str, value, requirement: str) -> ConfigError:
    """The error of ``[table] key = value``: ``requirement`` (a long value cut,
    :func:`~nitsche_dolfinx.common.keys.shown`)."""
    return ConfigError(f"{source}: {where} {key} = {shown(value)}: {requirement}")


# -- the checks before anything is read or computed ------------------------------------


def validate(config: dict, source: str = "config") -> None:
    """Check ``config`` against :data:`~nitsche_dolfinx.config.schema.SCHEMA` and the forms of its
    values; raise :class:`ConfigError` on the first problem."""
    for table in config:
        if table not in SCHEMA:
            raise ConfigError(
                f"{source}: unknown table [{table}] (known: {', '.join(sorted(SCHEMA))})"
            )
    for name, table in SCHEMA.items():
        if name not in config:
            if table.required:
                raise ConfigError(f"{source}: missing required table [{name}]")
            continue
        value = config[name]
        if table.array:
            if not isinstance(value, list):
                raise ConfigError(f"{source}: [[{name}]] must be an array of tables")
            for index, item in enumerate(value):
                _check_table(item, table, f"{source}: [[{name}]] #{index + 1}")
        elif table.free:
            _check_petsc(value, source)
        else:
            _check_table(value, table, f"{source}: [{name}]")
    _check_material(config["material"], source)
    tags = [region["tag"] for region in config.get("region", [])]
    for index, region in enumerate(config.get("region", [])):
        _check_material(region, source, f"[[region]] #{index + 1} (tag = {region['tag']})")
        if "in_box" in region:
            _check_table(region["in_box"], FACET_SELECTORS["in_box"],
                         f"{source}: [[region]] #{index + 1} in_box")  # fmt: skip
        if tags.count(region["tag"]) > 1:
            raise ConfigError(f"{source}: [[region]] #{index + 1}: tag = {region['tag']} "
                              "is given a material twice")  # fmt: skip
    _check_scheme_keys(config["scheme"], source)
    _check_mesh(config["mesh"], source)
    for index, table in enumerate(config.get("facet_tag", [])):
        _check_facet_tag(table, f"[[facet_tag]] #{index + 1}", source)
    for index, obstacle in enumerate(config.get("obstacle", [])):
        _check_obstacle(obstacle, f"[[obstacle]] #{index + 1}", source)
    _check_values(config, source)
    _check_mixed(config, source)
    _check_probes(config.get("probe", []), source)
    if config.get("body") and "velocity" in config.get("initial", {}):
        raise ConfigError(
            f"{source}: [initial] velocity is given with [[body]] velocities: give one of them"
        )
    columns = config.get("output", {}).get("columns")
    if columns is not None and (not columns or len(set(columns)) != len(columns)):
        raise bad(source, "[output]", "columns", columns, "must be distinct names, at least one")


def _check_table(table, spec, where: str) -> None:
    """The keys of ``table`` are those of ``spec``, each of its kind and range, the
    required ones given."""
    if not isinstance(table, dict):
        raise ConfigError(f"{where} must be a table")
    for key, value in table.items():
        if key not in spec.keys:
            raise ConfigError(f"{where} unknown key {key!r} (known: {', '.join(spec.keys)})")
        key_spec = spec.keys[key]
        if not key_spec.fits(value):
            raise ConfigError(
                f"{where} {key} must be {KINDS[key_spec.kind][0]}, got {shown(value)}"
            )
        problem = key_spec.problem(value)
        if problem is not None:
            raise ConfigError(f"{where} {key} = {shown(value)}: {problem}")
    for key, key_spec in spec.keys.items():
        if key_spec.required and key not in table:
            raise ConfigError(f"{where} missing required key {key!r}")


def _check_petsc(petsc, source: str) -> None:
    """[petsc]: a flat table of options whose values are strings, numbers or booleans."""
    if not isinstance(petsc, dict):
        raise ConfigError(f"{source}: [petsc] must be a table of PETSc options")
    for key, value in petsc.items():
        if isinstance(value, (dict, list)):
            raise ConfigError(
                f"{source}: [petsc] {key} must be a string, number or boolean, got "
                f"{shown(value)} (write options flat, e.g. snes_rtol = 1e-8)"
            )


def _check_material(material: dict, source: str, where: str = "[material]") -> None:
    if not ({"E", "nu"} <= material.keys() or {"lmbda", "mu"} <= material.keys()):
        raise ConfigError(f"{source}: {where} needs E and nu, or lmbda and mu")
    both = sorted(material.keys() & {"E", "nu"}), sorted(material.keys() & {"lmbda", "mu"})
    if both[0] and both[1]:
        raise ConfigError(
            f"{source}: {where} gives {' and '.join(both[0])} with {' and '.join(both[1])}: "
            "give E and nu, or lmbda and mu"
        )


def _check_scheme_keys(scheme: dict, source: str) -> None:
    """[scheme] theta, beta, gamma only for the scheme that takes them."""
    name = setting({"scheme": scheme}, "scheme", "name")
    if name not in SCHEMES:
        return  # named by the scheme's own check, with the table's label
    others = {key for cls in SCHEMES.values() for key in cls.parameters}
    for key in sorted(others & scheme.keys(), key=list(scheme).index):
        if key not in SCHEMES[name].parameters:
            raise ConfigError(
                f"{source}: [scheme] {key} = {shown(scheme[key])} is not a parameter of the "
                f"{name!r} scheme (it takes {', '.join(SCHEMES[name].parameters) or 'none'})"
            )


def _check_mesh(mesh: dict, source: str) -> None:
    """A file or a generator, and only the keys the generator takes, in their ranges."""
    if ("file" in mesh) == ("generator" in mesh):
        raise ConfigError(f"{source}: [mesh] needs one of file (a mesh file) and generator")
    if "file" in mesh:
        extra = [key for key in mesh if key in GENERATOR_KEYS]
        if extra:
            raise ConfigError(
                f"{source}: [mesh] {extra[0]} = {shown(mesh[extra[0]])} is a key of the generated "
                "meshes, not of a mesh file"
            )
        return
    if "gdim" in mesh:
        raise bad(source, "[mesh]", "gdim", mesh["gdim"], "is a key of mesh files")
    with reported_at("[mesh]", source):
        check_generator(mesh["generator"], mesh)


def _check_obstacle(obstacle: dict, where: str, source: str) -> None:
    """The keys of the obstacle's type (:data:`~nitsche_dolfinx.physics.obstacles.OBSTACLES`)."""
    kind = setting({}, "obstacle", "type", obstacle)
    keys = OBSTACLES[kind].keys
    for key in obstacle:
        if key not in ("type", "tag", *keys, *MOTION_KEYS):
            raise bad(
                source, where, key, obstacle[key],
                f"not a key of a {kind} obstacle (it takes {', '.join([*keys, *MOTION_KEYS])})",
            )  # fmt: skip
    for key, spec in keys.items():
        if spec.required and key not in obstacle:
            raise ConfigError(f"{source}: {where} missing required key {key!r} (type {kind!r})")
    for key in ("pivot", "rotation_axis"):  # the keys of a turn, without one
        if key in obstacle and "angle" not in obstacle:
            raise bad(source, where, key, obstacle[key], "it goes with angle, which the "
                      "table does not give")  # fmt: skip


def _check_facet_tag(table: dict, where: str, source: str) -> None:
    """At least one selector, each with the keys of its kind."""
    selectors = [name for name in FACET_SELECTORS if name in table]
    if not selectors:
        raise ConfigError(
            f"{source}: {where} (tag = {table['tag']}) needs a selector: "
            f"{', '.join(FACET_SELECTORS)}"
        )
    for name in selectors:
        _check_table(table[name], FACET_SELECTORS[name], f"{source}: {where} {name}")


#: The values in time and in space: (table, key, checker).
_VALUES = (
    ("dirichlet", "value", check_time_value),
    ("traction", "value", check_time_value),
    ("body_force", "value", check_time_value),
    ("obstacle", "translation", check_time_value),
    ("obstacle", "angle", check_time_value),
    ("initial", "displacement", check_field_value),
    ("initial", "velocity", check_field_value),
)


def _check_values(config: dict, source: str) -> None:
    for table, key, check in _VALUES:
        items = config.get(table, [] if SCHEMA[table].array else {})
        for index, item in enumerate(items if SCHEMA[table].array else [items]):
            if key not in item:
                continue
            where = f"[[{table}]] #{index + 1}" if SCHEMA[table].array else f"[{table}]"
            try:
                check(item[key])
            except ValueError as error:
                raise bad(source, where, key, item[key], str(error)) from None


def _check_mixed(config: dict, source: str) -> None:
    """What the mixed method takes, named in the file's words: one [[obstacle]], and
    Dirichlet values that are zero (:class:`~nitsche_dolfinx.steppers.mixed.MixedStepper`)."""
    if setting(config, "nitsche", "method") != "mixed":
        return
    count = len(config.get("obstacle", []))
    if count != 1:
        raise bad(
            source, "[nitsche]", "method", "mixed",
            f"the mixed method takes exactly one [[obstacle]], the file has {count}",
        )  # fmt: skip
    for index, table in enumerate(config.get("dirichlet", [])):
        value = table["value"]
        numbers = [value] if is_number(value) else value
        if not (isinstance(numbers, list) and all(is_number(x) and x == 0 for x in numbers)):
            raise bad(
                source, f"[[dirichlet]] #{index + 1}", "value", value,
                "the mixed method ([nitsche] method = 'mixed') takes zero Dirichlet values "
                "only (a constant 0 or [0.0, ...])",
            )  # fmt: skip


def _check_probes(probes: list, source: str) -> None:
    names = set()
    for index, probe in enumerate(probes):
        where = f"[[probe]] #{index + 1}"
        if probe["name"] in names:
            raise bad(source, where, "name", probe["name"], "a second probe of that name")
        names.add(probe["name"])
        given = [key for key in ("point", "facets", "cells") if key in probe]
        if len(given) > 1:
            raise ConfigError(
                f"{source}: {where} gives {' and '.join(given)}: give one of them (none: the "
                "mean over the mesh)"
            )
        if "point" in probe and not PROBE_QUANTITIES[probe["quantity"]]:
            raise bad(
                source, where, "point", probe["point"],
                f"{probe['quantity']} is a mean over facets, not a value at a point",
            )  # fmt: skip
        if "component" in probe and not PROBE_QUANTITIES[probe["quantity"]]:
            raise bad(source, where, "component", probe["component"], "the quantity is scalar")


# -- the checks of values, named where they came from ----------------------------------


@contextlib.contextmanager
def reported_at(where: str, source: str, names: dict | None = None):
    """Turn a ValueError of the block into a :class:`ConfigError` naming the table ``where``
    (and, for a :class:`~nitsche_dolfinx.common.parameters.ParameterError`, the key and value: a
    run parameter's TOML key from :mod:`~nitsche_dolfinx.config.parameter_table`, any other name
    as a key of ``where``). Another run parameter that the message names in the API's
    words (``degree=2``) is named by its TOML key (``[mesh] degree = 2``,
    :func:`~nitsche_dolfinx.config.parameter_table.in_words_of`).

    ``names`` maps the API's name of a value that the file writes under another key to
    that key (of ``where``, or a whole ``[table] key``) and the value the file gives,
    ``{"axis": ("rotation_axis", [0, 0, 1])}``: the message then quotes what the user wrote.
    A value that a configuration cannot hold (an object of the library, None) is not
    quoted: the key alone is named."""
    try:
        yield
    except ConfigError:
        raise
    except ParameterError as error:
        error = ParameterError(
            error.name, error.value, in_words_of(error.requirement, "toml"),
            in_words_of(error.label, "toml") if error.explicit else None,
        )  # fmt: skip
        if names and error.name in names and not error.explicit:
            key, value = names[error.name]
            label = _assignment(key if key.startswith("[") else f"{where} {key}", value)
            raise ConfigError(f"{source}: {error.named(label)}") from None
        parameter = by_name(error.name)
        key = parameter.toml if parameter is not None and parameter.toml else where
        if error.explicit:  # the error's own words, after its table
            raise ConfigError(f"{source}: {key.split(' ')[0]} {error}") from None
        if key == where:
            key = f"{where} {error.name}"
        raise ConfigError(f"{source}: {error.named(_assignment(key, error.value))}") from None
    except ValueError as error:
        raise ConfigError(f"{source}: {where} {in_words_of(str(error), 'toml')}") from None


def _assignment(key: str, value) -> str:
    """``key = value`` as a message of a configuration names a value (cut when long); the
    key alone for a value that no TOML file holds (None, an object of the library)."""
    if value is None or not is_plain(value):
        return key
    return f"{key} = {shown(value)}"


def output_parameters(
    config: dict, source: str = "config", checkpoint_every=None, num_steps: int | None = None
):
    """The :class:`~nitsche_dolfinx.common.parameters.OutputParameters` of ``[output]``
    (``checkpoint_every`` given: it overrides the table's). Without ``[output] every``,
    the fields are written about :data:`DEFAULT_FIELD_OUTPUTS` times over the run of
    ``num_steps`` steps (by default those of [scheme]; with dt = "auto", known once the
    simulation is built: every step until then)."""
    output = config.get("output", {})
    if checkpoint_every is None:
        checkpoint_every = setting(config, "output", "checkpoint_every")
    every = output.get("every")
    if every is None:
        scheme = config["scheme"]
        with reported_at("[scheme]", source):
            timing = TimeStepping(scheme["dt"], scheme["t_end"])
        if num_steps is None and not timing.automatic:
            num_steps = timing.num_steps
        every = 1 if num_steps is None else max(1, math.ceil(num_steps / DEFAULT_FIELD_OUTPUTS))
    with reported_at("[output]", source):
        return OutputParameters(every, checkpoint_every)


def history_columns(config: dict, simulation) -> list[str]:
    """The columns of ``history.csv``: ``[output] columns``, or those of the 2D/3D demos
    (with the energy balance under friction), the probes and the [[body]] tables' columns,
    each that the run gives: the mixed method's stepper gives no reactions of the supports
    and no work (its Dirichlet values are zero: the supports do none), so that its default
    columns leave them out."""
    columns = config.get("output", {}).get("columns")
    if columns is not None:
        return list(columns)
    base = FRICTION_HISTORY_COLUMNS if simulation.problem.frictional else HISTORY_COLUMNS
    problem = simulation.problem
    work = OBSTACLE_COLUMNS if problem.moving_contacts else ()
    finite = FINITE_COLUMNS if problem.finite else ()
    damping = DAMPING_COLUMNS if problem.damping is not None else ()
    pairing = PAIRING_COLUMNS if any(pair.follow for pair in problem.pairs) else ()
    tags = sorted({condition.tag for condition in problem.dirichlet})
    supports = reaction_columns(tags, problem.gdim)
    balance = WORK_COLUMNS if tags or work else ()
    probes = (probe["name"] for probe in config.get("probe", []))
    bodies = (name for body in problem.bodies for name in body_columns(body.tag, problem.gdim))
    columns = [*base, *finite, *work, *damping, *pairing, *supports, *balance, *probes, *bodies]
    given = simulation.state()
    return [name for name in columns if name in given]
