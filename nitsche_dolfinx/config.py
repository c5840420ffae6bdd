"""Run descriptions in TOML: reading, checking, and the simulation they describe.

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

Every key, its kind, its default and its meaning: :data:`nitsche_dolfinx.schema.SCHEMA`,
printed by ``nitsche-dolfinx schema``. No value is ever evaluated as code: values in time
and in space are small tables (:mod:`nitsche_dolfinx.valueforms`).

Everything is checked before anything is computed: :func:`validate` checks the kinds,
the forms and the keys each choice takes; :func:`build_simulation` checks the values
(material, scheme, time step, Nitsche parameter, obstacles) before it makes or reads
the mesh, then the tags and dimensions against the mesh. A bad value raises
:class:`ConfigError` naming it as ``[table] key = value``.
"""

from __future__ import annotations

import contextlib
import math
import os

from .mesh_generators import GENERATOR_KEYS, MESH_GENERATORS
from .schema import FACET_SELECTORS, KINDS, OBSTACLE_TYPES, PROBE_QUANTITIES, REQUIRED, SCHEMA
from .valueforms import check_field_value, check_time_value

__all__ = [
    "ConfigError",
    "SCHEMA",
    "build_simulation",
    "history_columns",
    "load_config",
    "output_parameters",
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
    if os.path.isdir(path):
        raise ConfigError(f"{path}: the configuration is a folder, not a TOML file")
    if not os.path.isfile(path):
        raise ConfigError(f"{path}: configuration file does not exist")
    toml = _toml_module()
    try:
        with open(path, "rb") as f:
            config = toml.load(f)
    except toml.TOMLDecodeError as error:
        raise ConfigError(f"{path}: not valid TOML: {error}") from None
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


def _toml_module():
    try:
        import tomllib  # Python >= 3.11
    except ImportError:
        try:
            import tomli as tomllib
        except ImportError:
            raise ConfigError("reading TOML needs Python >= 3.11 or the tomli package") from None
    return tomllib


def _shown(value) -> str:
    return repr(value)


def setting(config: dict, table: str, key: str, item: dict | None = None):
    """``[table] key`` of ``config`` (of ``item``, one of the tables ``[[table]]``), or its
    default in :data:`SCHEMA` (None: not set)."""
    default = SCHEMA[table].keys[key].default
    values = item if item is not None else config.get(table, {})
    return values.get(key, None if default is REQUIRED else default)


def bad(source: str, where: str, key: str, value, requirement: str) -> ConfigError:
    """The error of ``[table] key = value``: ``requirement``."""
    return ConfigError(f"{source}: {where} {key} = {_shown(value)}: {requirement}")


# -- the checks before anything is read or computed ------------------------------------


def validate(config: dict, source: str = "config") -> None:
    """Check ``config`` against :data:`~nitsche_dolfinx.schema.SCHEMA` and the forms of its
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
    _check_scheme_keys(config["scheme"], source)
    _check_mesh(config["mesh"], source)
    for index, table in enumerate(config.get("facet_tag", [])):
        _check_facet_tag(table, f"[[facet_tag]] #{index + 1}", source)
    for index, obstacle in enumerate(config.get("obstacle", [])):
        _check_obstacle(obstacle, f"[[obstacle]] #{index + 1}", source)
    _check_values(config, source)
    for index, table in enumerate(config.get("dirichlet", [])):
        component = table.get("component", 0)
        if not 0 <= component <= 2:
            raise bad(source, f"[[dirichlet]] #{index + 1}", "component", component,
                      "must be 0 (x), 1 (y) or 2 (z)")  # fmt: skip
    _check_probes(config.get("probe", []), source)
    if config.get("body") and "velocity" in config.get("initial", {}):
        raise ConfigError(
            f"{source}: [initial] velocity is given with [[body]] velocities: give one of them"
        )
    columns = config.get("output", {}).get("columns")
    if columns is not None and (not columns or len(set(columns)) != len(columns)):
        raise bad(source, "[output]", "columns", columns, "must be distinct names, at least one")


#: Keys whose choices the parameter objects check, in their own words, before the mesh.
_OWN_CHOICES = ("name", "method", "gamma0_scaling", "mass")


def _check_table(table, spec, where: str) -> None:
    if not isinstance(table, dict):
        raise ConfigError(f"{where} must be a table")
    for key, value in table.items():
        if key not in spec.keys:
            raise ConfigError(f"{where} unknown key {key!r} (known: {', '.join(spec.keys)})")
        key_spec = spec.keys[key]
        name, check = KINDS[key_spec.kind]
        if not check(value):
            raise ConfigError(f"{where} {key} must be {name}, got {value!r}")
        if key_spec.kind in ("number", "vector"):
            numbers = value if isinstance(value, list) else [value]
            if not all(math.isfinite(x) for x in numbers):
                raise ConfigError(f"{where} {key} = {_shown(value)}: must be finite")
        if key_spec.choices and value not in key_spec.choices and key not in _OWN_CHOICES:
            raise ConfigError(
                f"{where} {key} = {value!r}: unknown; choose one of {', '.join(key_spec.choices)}"
            )
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
                f"{value!r} (write options flat, e.g. snes_rtol = 1e-8)"
            )


def _check_material(material: dict, source: str) -> None:
    if not ({"E", "nu"} <= material.keys() or {"lmbda", "mu"} <= material.keys()):
        raise ConfigError(f"{source}: [material] needs E and nu, or lmbda and mu")
    both = sorted(material.keys() & {"E", "nu"}), sorted(material.keys() & {"lmbda", "mu"})
    if both[0] and both[1]:
        raise ConfigError(
            f"{source}: [material] gives {' and '.join(both[0])} with {' and '.join(both[1])}: "
            "give E and nu, or lmbda and mu"
        )


def _check_scheme_keys(scheme: dict, source: str) -> None:
    """[scheme] theta, beta, gamma only for the scheme that takes them."""
    from .schemes import SCHEMES

    name = setting({"scheme": scheme}, "scheme", "name")
    if name not in SCHEMES:
        return  # named by the scheme's own check, with the table's label
    for key in ("theta", "beta", "gamma"):
        if key in scheme and key not in SCHEMES[name].parameters:
            raise ConfigError(
                f"{source}: [scheme] {key} = {scheme[key]!r} is not a parameter of the "
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
                f"{source}: [mesh] {extra[0]} = {mesh[extra[0]]!r} is a key of the generated "
                "meshes, not of a mesh file"
            )
        return
    name = mesh["generator"]
    generator = MESH_GENERATORS[name]
    if "gdim" in mesh:
        raise bad(source, "[mesh]", "gdim", mesh["gdim"], "is a key of mesh files")
    for key in GENERATOR_KEYS:
        if key not in mesh:
            continue
        if key not in generator.keys:
            raise bad(
                source, "[mesh]", key, mesh[key],
                f"not a key of the {name!r} mesh (it takes {', '.join(generator.keys)})",
            )  # fmt: skip
        _, _, check, requirement = GENERATOR_KEYS[key]
        if not check(mesh[key]):
            raise bad(source, "[mesh]", key, mesh[key], f"must be {requirement}")
    center = mesh.get("center")
    if center is not None:
        dimension = len(generator.keys["center"])
        if not isinstance(center, list) or len(center) != dimension:
            raise bad(source, "[mesh]", "center", center, f"must have {dimension} coordinates")


def _check_obstacle(obstacle: dict, where: str, source: str) -> None:
    kind = setting({}, "obstacle", "type", obstacle)
    keys, _ = OBSTACLE_TYPES[kind]
    for key in obstacle:
        if key not in ("type", "tag", *keys):
            raise bad(
                source, where, key, obstacle[key],
                f"not a key of a {kind} obstacle (it takes {', '.join(keys)})",
            )  # fmt: skip
    for key in keys:
        if key != "side" and key not in obstacle:
            raise ConfigError(f"{source}: {where} missing required key {key!r} (type {kind!r})")
    if "radius" in obstacle and not obstacle["radius"] > 0:
        raise bad(source, where, "radius", obstacle["radius"], "must be positive")


def _check_facet_tag(table: dict, where: str, source: str) -> None:
    """A tag >= 1 (a 32-bit integer) and at least one selector, each with the keys of its
    kind."""
    if not 1 <= table["tag"] < 2**31:
        raise bad(source, where, "tag", table["tag"], "must be from 1 to 2^31 - 1")
    selectors = [name for name in FACET_SELECTORS if name in table]
    if not selectors:
        raise ConfigError(
            f"{source}: {where} (tag = {table['tag']}) needs a selector: "
            f"{', '.join(FACET_SELECTORS)}"
        )
    for name in selectors:
        _check_table(table[name], FACET_SELECTORS[name], f"{source}: {where} {name}")
        tolerance = table[name].get("tolerance", 0.0)
        if tolerance < 0:
            raise bad(source, f"{where} {name}", "tolerance", tolerance, "must be >= 0")


#: The values in time and in space: (table, key, checker).
_VALUES = (
    ("dirichlet", "value", check_time_value),
    ("traction", "value", check_time_value),
    ("body_force", "value", check_time_value),
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

#: Where each parameter of :mod:`nitsche_dolfinx.parameters` is set in a configuration.
_KEYS = {
    "gamma0": "[nitsche] gamma0",
    "gamma0_scaling": "[nitsche] gamma0_scaling",
    "nitsche_theta": "[nitsche] theta",
    "friction": "[nitsche] friction",
    "method": "[nitsche] method",
    "scheme": "[scheme] name",
    "dt": "[scheme] dt",
    "t_end": "[scheme] t_end",
    "max_step_cuts": "[scheme] max_step_cuts",
    "theta": "[scheme] theta",
    "beta": "[scheme] beta",
    "gamma": "[scheme] gamma",
    "degree": "[mesh] degree",
    "mass": "[mesh] mass",
    "quadrature_degree": "[mesh] quadrature_degree",
    "linear_solver": "[solver] linear_solver",
    "output_every": "[output] every",
    "checkpoint_every": "[output] checkpoint_every",
    "initial displacement": "[initial] displacement",
    "initial velocity": "[initial] velocity",
    "initial_displacement": "[initial] displacement",
}


@contextlib.contextmanager
def reported_at(where: str, source: str):
    """Turn a ValueError of the block into a :class:`ConfigError` naming the table (and,
    for a :class:`~nitsche_dolfinx.parameters.ParameterError`, the key and value)."""
    from .parameters import ParameterError

    try:
        yield
    except ConfigError:
        raise
    except ParameterError as error:
        key = _KEYS.get(error.name, f"{where} {error.name}")
        if error.explicit:  # the error's own words, after its table
            raise ConfigError(f"{source}: {key.split(' ')[0]} {error}") from None
        raise ConfigError(f"{source}: {error.named(f'{key} = {error.value!r}')}") from None
    except ValueError as error:
        raise ConfigError(f"{source}: {where} {error}") from None


def output_parameters(config: dict, source: str = "config", checkpoint_every=None):
    """The :class:`~nitsche_dolfinx.parameters.OutputParameters` of ``[output]``
    (``checkpoint_every`` given: it overrides the table's). Without ``[output] every``,
    the fields are written about :data:`DEFAULT_FIELD_OUTPUTS` times over the run."""
    from .parameters import OutputParameters, TimeStepping

    output = config.get("output", {})
    if checkpoint_every is None:
        checkpoint_every = setting(config, "output", "checkpoint_every")
    every = output.get("every")
    if every is None:
        scheme = config["scheme"]
        with reported_at("[scheme]", source):
            steps = TimeStepping(scheme["dt"], scheme["t_end"]).num_steps
        every = max(1, math.ceil(steps / DEFAULT_FIELD_OUTPUTS))
    with reported_at("[output]", source):
        return OutputParameters(every, checkpoint_every)


def build_simulation(config: dict, comm=None, progress: bool = True, source: str = "config"):
    """The :class:`~nitsche_dolfinx.simulation.Simulation` a validated configuration
    describes, its probes added (see :func:`nitsche_dolfinx.builder.build_simulation`).

    Raises:
        ConfigError: A value is out of range or names a tag absent from the mesh.
    """
    from .builder import build_simulation as build

    return build(config, comm, progress, source)


def history_columns(config: dict, simulation) -> list[str]:
    """The columns of ``history.csv``: ``[output] columns``, or those of the 2D/3D demos
    (with the energy balance under friction) and then the probes."""
    from .history import FRICTION_HISTORY_COLUMNS, HISTORY_COLUMNS

    columns = config.get("output", {}).get("columns")
    if columns is not None:
        return list(columns)
    base = FRICTION_HISTORY_COLUMNS if simulation.problem.frictional else HISTORY_COLUMNS
    return [*base, *(probe["name"] for probe in config.get("probe", []))]
