"""Run descriptions in TOML: the schema, its validation, and the simulation they describe.

A configuration names the mesh, the material, the obstacles, the loads, the
Nitsche settings, the time scheme and the output::

    [mesh]
    file = "ring_2d.msh"            # .msh or .xdmf, relative to the TOML file
    degree = 1

    [material]
    E = 1000.0                      # or lmbda and mu
    nu = 0.3
    rho = 1.0

    [nitsche]
    gamma0 = 1e-6
    gamma0_scaling = "absolute"     # gamma_h = gamma0 h; "E": gamma_h = gamma0 h / E
    theta = 1.0                     # the variant Theta

    [scheme]
    name = "hybrid"                 # hybrid | theta | newmark | cn
    dt = 0.005
    t_end = 1.0
    max_step_cuts = 5               # a failing step is halved down to dt / 2^5

    [[obstacle]]
    type = "plane"
    point = [0.0, 0.0]
    normal = [0.0, 1.0]
    tag = 1

    [[contact_pair]]                # two bodies of the mesh (docs/method.md section 11)
    tags = [3, 4]
    variant = "unbiased"            # or "biased": the first tag is the slave
    direction = [0.0, -1.0]         # optional: pair along it, from the first to the second

    [body_force]
    value = [0.0, -9.81]

    [initial]
    velocity = [0.0, -1.0]

    [output]
    dir = "out/ring"
    every = 10
    checkpoint_every = 0            # save the state every K steps (0: only on a failure/stop)

Everything is checked before anything is computed: an unknown key, a value of
the wrong type or a missing required key raises :class:`ConfigError` with a
message naming it; :func:`build_simulation` checks the values (material,
scheme, time step, Nitsche parameter, obstacles) before it reads the mesh.
"""

from __future__ import annotations

import contextlib
import os
from typing import Any

__all__ = [
    "ConfigError",
    "SCHEMA",
    "build_simulation",
    "load_config",
    "output_parameters",
    "validate",
]


class ConfigError(ValueError):
    """A configuration file is invalid; the message names the file and the key."""


_NUMBER = (int, float)
_VECTOR = "vector"  # a list of numbers
_TAG_PAIR = "tag pair"  # a list of two integers

#: For each table: key -> (expected type, required). Arrays of tables are lists.
SCHEMA: dict[str, Any] = {
    "mesh": {"file": (str, True), "degree": (int, False), "gdim": (int, False)},
    "material": {
        "E": (_NUMBER, False),
        "nu": (_NUMBER, False),
        "lmbda": (_NUMBER, False),
        "mu": (_NUMBER, False),
        "rho": (_NUMBER, False),
    },
    "nitsche": {
        "gamma0": (_NUMBER, False),
        "gamma0_scaling": (str, False),
        "theta": (_NUMBER, False),
    },
    "scheme": {
        "name": (str, False),
        "dt": (_NUMBER, True),
        "t_end": (_NUMBER, True),
        "theta": (_NUMBER, False),
        "beta": (_NUMBER, False),
        "gamma": (_NUMBER, False),
        "max_step_cuts": (int, False),
    },
    "obstacle": [
        {
            "type": (str, False),
            "point": (_VECTOR, True),
            "normal": (_VECTOR, True),
            "tag": (int, True),
        }
    ],
    "contact_pair": [
        {"tags": (_TAG_PAIR, True), "variant": (str, False), "direction": (_VECTOR, False)}
    ],
    "dirichlet": [{"tag": (int, True), "value": (_VECTOR, True)}],
    "traction": [{"tag": (int, True), "value": (_VECTOR, True)}],
    "body_force": {"value": (_VECTOR, True)},
    "initial": {"displacement": (_VECTOR, False), "velocity": (_VECTOR, False)},
    "output": {"dir": (str, False), "every": (int, False), "checkpoint_every": (int, False)},
    "petsc": None,  # free-form PETSc options
}
_REQUIRED_TABLES = ("mesh", "material", "scheme")
_TYPE_NAMES = {
    str: "a string",
    int: "an integer",
    _NUMBER: "a number",
    _VECTOR: "a list of numbers",
    _TAG_PAIR: "a list of two integer tags",
}


def load_config(path: str) -> dict:
    """Read and validate a TOML configuration.

    Relative file names in it (the mesh, the output folder) are taken relative to
    the folder of the TOML file.

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
    config["mesh"]["file"] = os.path.join(base, config["mesh"]["file"])
    if "dir" in config.get("output", {}):
        config["output"]["dir"] = os.path.join(base, config["output"]["dir"])
    mesh_file = config["mesh"]["file"]
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


def validate(config: dict, source: str = "config") -> None:
    """Check ``config`` against :data:`SCHEMA`; raise :class:`ConfigError` on the first problem."""
    for table in config:
        if table not in SCHEMA:
            raise ConfigError(
                f"{source}: unknown table [{table}] (known: {', '.join(sorted(SCHEMA))})"
            )
    for table in _REQUIRED_TABLES:
        if table not in config:
            raise ConfigError(f"{source}: missing required table [{table}]")
    for table, schema in SCHEMA.items():
        if table not in config or schema is None:
            continue
        value = config[table]
        if isinstance(schema, list):
            if not isinstance(value, list):
                raise ConfigError(f"{source}: [[{table}]] must be an array of tables")
            for index, item in enumerate(value):
                _check_table(item, schema[0], f"{source}: [[{table}]] #{index + 1}")
        else:
            _check_table(value, schema, f"{source}: [{table}]")
    _check_petsc(config.get("petsc", {}), source)
    material = config["material"]
    if not ({"E", "nu"} <= material.keys() or {"lmbda", "mu"} <= material.keys()):
        raise ConfigError(f"{source}: [material] needs E and nu, or lmbda and mu")
    both = sorted(material.keys() & {"E", "nu"}), sorted(material.keys() & {"lmbda", "mu"})
    if both[0] and both[1]:
        raise ConfigError(
            f"{source}: [material] gives {' and '.join(both[0])} with {' and '.join(both[1])}: "
            "give E and nu, or lmbda and mu"
        )
    _check_scheme_keys(config["scheme"], source)
    for index, obstacle in enumerate(config.get("obstacle", [])):
        kind = obstacle.get("type", "plane")
        if kind != "plane":
            raise ConfigError(
                f"{source}: [[obstacle]] #{index + 1} type {kind!r} is not known (use 'plane')"
            )


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


def _check_scheme_keys(scheme: dict, source: str) -> None:
    """[scheme] theta, beta, gamma only for the scheme that takes them."""
    from .schemes import SCHEMES

    name = scheme.get("name", "hybrid")
    if name not in SCHEMES:
        return  # named by the scheme's own check, with the table's label
    for key in ("theta", "beta", "gamma"):
        if key in scheme and key not in SCHEMES[name].parameters:
            raise ConfigError(
                f"{source}: [scheme] {key} = {scheme[key]!r} is not a parameter of the "
                f"{name!r} scheme (it takes {', '.join(SCHEMES[name].parameters) or 'none'})"
            )


def _check_table(table, schema: dict, where: str) -> None:
    if not isinstance(table, dict):
        raise ConfigError(f"{where} must be a table")
    for key, value in table.items():
        if key not in schema:
            raise ConfigError(f"{where} unknown key {key!r} (known: {', '.join(schema)})")
        expected, _ = schema[key]
        if not _has_type(value, expected):
            raise ConfigError(f"{where} {key} must be {_TYPE_NAMES[expected]}, got {value!r}")
    for key, (_, required) in schema.items():
        if required and key not in table:
            raise ConfigError(f"{where} missing required key {key!r}")


def _has_type(value, expected) -> bool:
    if isinstance(value, bool):  # TOML booleans are not numbers
        return False
    if expected == _TAG_PAIR:
        return (
            isinstance(value, list)
            and len(value) == 2
            and all(isinstance(x, int) and not isinstance(x, bool) for x in value)
        )
    if expected == _VECTOR:
        if isinstance(value, _NUMBER):
            return True
        return isinstance(value, list) and all(
            isinstance(x, _NUMBER) and not isinstance(x, bool) for x in value
        )
    return isinstance(value, expected)


#: Where each parameter of :mod:`nitsche_dolfinx.parameters` is set in a configuration.
_KEYS = {
    "gamma0": "[nitsche] gamma0",
    "gamma0_scaling": "[nitsche] gamma0_scaling",
    "nitsche_theta": "[nitsche] theta",
    "scheme": "[scheme] name",
    "dt": "[scheme] dt",
    "t_end": "[scheme] t_end",
    "max_step_cuts": "[scheme] max_step_cuts",
    "theta": "[scheme] theta",
    "beta": "[scheme] beta",
    "gamma": "[scheme] gamma",
    "degree": "[mesh] degree",
    "output_every": "[output] every",
    "checkpoint_every": "[output] checkpoint_every",
    "initial displacement": "[initial] displacement",
    "initial velocity": "[initial] velocity",
    "initial_displacement": "[initial] displacement",
}


@contextlib.contextmanager
def _reported_at(where: str, source: str):
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
    (``checkpoint_every`` given: it overrides the table's)."""
    from .parameters import OutputParameters

    output = config.get("output", {})
    if checkpoint_every is None:
        checkpoint_every = output.get("checkpoint_every", 0)
    with _reported_at("[output]", source):
        return OutputParameters(output.get("every", 0), checkpoint_every)


def build_simulation(config: dict, comm=None, progress: bool = True, source: str = "config"):
    """The :class:`~nitsche_dolfinx.simulation.Simulation` a validated configuration describes.

    Every value is checked by the parameter objects of :mod:`nitsche_dolfinx.parameters`
    before the mesh is read.

    Args:
        config: A configuration checked by :func:`validate` (e.g. from :func:`load_config`).
        comm: The communicator (``MPI.COMM_WORLD`` by default).
        progress: Print one line per step on rank 0.
        source: Name of the configuration in error messages (its file name).

    Raises:
        ConfigError: A value is out of range or names a tag absent from the mesh.
    """
    from mpi4py import MPI

    from .meshes import load_mesh
    from .model import ContactProblem
    from .parameters import Discretisation, NitscheParameters, TimeStepping
    from .schemes import make_scheme
    from .simulation import Simulation

    comm = comm or MPI.COMM_WORLD
    # the values first, the mesh last: a bad value stops the run before any reading
    material = _material(config, source)
    s, nitsche, mesh_table = config["scheme"], config.get("nitsche", {}), config["mesh"]
    with _reported_at("[scheme]", source):
        scheme = make_scheme(
            s.get("name", "hybrid"), s.get("theta", 1.0), s.get("beta", 0.25), s.get("gamma", 0.5)
        )
        time_stepping = TimeStepping(s["dt"], s["t_end"], s.get("max_step_cuts", 5))
    with _reported_at("[nitsche]", source):
        contact = NitscheParameters(
            nitsche.get("gamma0", 1e-3),
            nitsche.get("theta", 1.0),
            gamma0_scaling=nitsche.get("gamma0_scaling", "absolute"),
        )
    with _reported_at("[mesh]", source):
        discretisation = Discretisation(mesh_table.get("degree", 1))
    obstacles = _obstacles(config, source)
    output_parameters(config, source)
    with _reported_at("[mesh]", source):
        mesh, facet_tags = load_mesh(mesh_table["file"], gdim=mesh_table.get("gdim"), comm=comm)
    problem = ContactProblem(mesh, facet_tags, material, **vars(contact), **vars(discretisation))
    _add_terms(problem, config, obstacles, source)
    with _reported_at("[scheme]", source):
        return Simulation(
            problem,
            scheme,
            time_stepping.dt,
            time_stepping.t_end,
            petsc_options=config.get("petsc"),
            progress=progress,
            max_step_cuts=time_stepping.max_step_cuts,
        )


def _material(config: dict, source: str):
    from .material import Material

    m = config["material"]
    rho = m.get("rho", 1.0)
    with _reported_at("[material]", source):
        if "E" in m:
            return Material(E=m["E"], nu=m["nu"], rho=rho)
        return Material.from_lame(m["lmbda"], m["mu"], rho=rho)


def _obstacles(config: dict, source: str) -> list:
    from .obstacles import PlaneObstacle

    obstacles = []
    for index, obstacle in enumerate(config.get("obstacle", [])):
        with _reported_at(f"[[obstacle]] #{index + 1}", source):
            obstacles.append(PlaneObstacle(obstacle["point"], obstacle["normal"]))
    return obstacles


def _add_terms(problem, config: dict, obstacles: list, source: str) -> None:
    """The obstacles, Dirichlet conditions, loads and initial conditions of ``config``."""
    for index, (obstacle, table) in enumerate(zip(obstacles, config.get("obstacle", []))):
        with _reported_at(f"[[obstacle]] #{index + 1}", source):
            problem.add_obstacle(obstacle, table["tag"])
    for index, pair in enumerate(config.get("contact_pair", [])):
        with _reported_at(f"[[contact_pair]] #{index + 1}", source):
            problem.add_contact_pair(
                *pair["tags"], pair.get("variant", "unbiased"), pair.get("direction")
            )
    for index, dirichlet in enumerate(config.get("dirichlet", [])):
        with _reported_at(f"[[dirichlet]] #{index + 1}", source):
            problem.add_dirichlet(dirichlet["tag"], dirichlet["value"])
    for index, traction in enumerate(config.get("traction", [])):
        with _reported_at(f"[[traction]] #{index + 1}", source):
            problem.add_traction(traction["tag"], traction["value"])
    if "body_force" in config:
        with _reported_at("[body_force]", source):
            problem.add_body_force(config["body_force"]["value"])
    initial = config.get("initial", {})
    with _reported_at("[initial]", source):
        problem.set_initial_conditions(
            displacement=initial.get("displacement"), velocity=initial.get("velocity")
        )
