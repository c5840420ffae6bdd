"""The simulation a validated TOML configuration describes (:mod:`nitsche_dolfinx.config.reader`).

The values are checked first, by the parameter objects of
:mod:`nitsche_dolfinx.common.parameters`, the material, the schemes and the obstacles' classes
(and the facet selectors by theirs); then the mesh is made or read, its facets tagged by
the ``[[facet_tag]]`` selectors, and the tags, dimensions and shapes are checked against
it; then the terms are added in the order of the demos (contact pairs, obstacles,
Dirichlet conditions, loads, initial values) and the probes. The keywords of
:class:`~nitsche_dolfinx.model.problem.ContactProblem`, :class:`~nitsche_dolfinx.simulation.
Simulation` and the rest come from their TOML keys through
:data:`~nitsche_dolfinx.config.parameter_table.PARAMETERS`. Every error is a
:class:`~nitsche_dolfinx.config.reader.ConfigError` naming the ``[table] key`` it came from.
"""

from __future__ import annotations

import re
from dataclasses import fields
from typing import NamedTuple

import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from ..cases.two_bodies import body_velocities
from ..common.agreement import one_line
from ..common.keys import shown
from ..common.parameters import Discretisation, NitscheParameters, ParameterError, TimeStepping
from ..meshing.facet_selectors import InBox, NormalWithin, OnPlane, tag_cells, tag_facets
from ..meshing.meshes import load_mesh
from ..model.problem import ContactProblem
from ..output.probes import BoundaryAverage, PointValue
from ..physics.damping import check_damping
from ..physics.expressions import has_text
from ..physics.material import Material
from ..physics.motion import MovingObstacle
from ..physics.obstacles import OBSTACLES
from ..physics.valueforms import check_time_value, field_value, time_value
from ..simulation import Simulation
from ..steppers.schemes import TimeScheme, make_scheme
from .dimensions import check_dimensions
from .mesh_generators import generate_mesh
from .parameter_table import PARAMETERS
from .reader import ConfigError, bad, output_parameters, reported_at, setting
from .schema import FACET_SELECTORS, SCHEMA

__all__ = ["build_simulation"]

#: The classes of the facet selectors of [[facet_tag]] (their keys: schema.FACET_SELECTORS).
SELECTOR_CLASSES = {"on_plane": OnPlane, "normal_within": NormalWithin, "in_box": InBox}


def build_simulation(
    config: dict, comm=None, progress: bool = True, source: str = "config", petsc_flags=()
):
    """The :class:`~nitsche_dolfinx.simulation.Simulation` of a validated configuration,
    its probes added.

    Args:
        config: A configuration checked by :func:`~nitsche_dolfinx.config.reader.validate`.
        comm: The communicator (``MPI.COMM_WORLD`` by default).
        progress: Show the progress of the run on rank 0.
        source: Name of the configuration in error messages (its file name).
        petsc_flags: The keys of ``config["petsc"]`` that the command line's ``--petsc``
            flags set (an error of their option names the flag, not [petsc]).

    Raises:
        ConfigError: A value is out of range or does not fit the mesh.
    """
    comm = comm or MPI.COMM_WORLD
    # the values first, the mesh last: a bad value stops the run before any meshing
    checked = _checked_values(config, source)
    mesh, cell_tags, facet_tags = _mesh(config, comm, source)
    check_dimensions(config, mesh.geometry.dim, source)
    facet_tags = _tag_facets(mesh, facet_tags, checked.selectors, config, source)
    cell_tags = _tag_cells(mesh, cell_tags, config, source)
    for index, region in enumerate(config.get("region", [])):
        _cells(cell_tags, region["tag"], f"[[region]] #{index + 1}", "tag", source, comm)
    with reported_at("[nitsche]", source):
        problem = ContactProblem(
            mesh, facet_tags, checked.material, **_keywords(config, "ContactProblem"),
            cell_tags=cell_tags,
        )  # fmt: skip
    contacts = _add_terms(problem, config, checked.obstacles, cell_tags, source)
    scheme = ("[scheme] name", setting(config, "scheme", "name"))  # not its description
    try:
        with reported_at("[solver]", source, {"scheme": scheme}):
            simulation = Simulation(
                problem,
                **{**_keywords(config, "Simulation"), "scheme": checked.scheme},
                petsc_options=config.get("petsc"),
                progress=progress,
            )
    except PETSc.Error as error:  # a PETSc option that PETSc refused
        raise _petsc_error(error, config.get("petsc") or {}, source, petsc_flags) from None
    _add_probes(simulation, config, contacts, cell_tags, source)
    _check_columns(simulation, config, source)
    return simulation


def _petsc_error(error, options: dict, source: str, flags) -> ConfigError:
    """The error of a PETSc option PETSc refused, named by its key (that whose value the
    message quotes; else the table) as the file or the ``--petsc`` flag gave it."""
    message = one_line(error)
    for key, value in options.items():
        if value is not None and re.search(rf"(?<![\w.-]){re.escape(str(value))}(?![\w.-])",
                                           message):  # fmt: skip
            if key in flags:
                return ConfigError(f"--petsc {key}={value}: {message}")
            return ConfigError(f"{source}: [petsc] {key} = {shown(value)}: {message}")
    given = ", ".join(options) or "none given"
    return ConfigError(f"{source}: [petsc] (options: {given}): {message}")


def _keywords(config: dict, owner: str) -> dict:
    """The keywords of ``owner`` (``"ContactProblem"``, ``"Simulation"``, ... : a key of
    :data:`~nitsche_dolfinx.config.parameter_table.OWNERS`) that TOML keys set, each as given or
    at its TOML default."""
    return {
        parameter.argument: setting(config, parameter.table, parameter.toml_key)
        for parameter in PARAMETERS
        if parameter.owner == owner and parameter.toml_key is not None
    }


class _Checked(NamedTuple):
    """What the configuration makes before the mesh (every value checked)."""

    material: Material | dict
    scheme: TimeScheme
    obstacles: list
    selectors: list[list]


def _checked_values(config: dict, source: str) -> _Checked:
    """The material, the scheme, the obstacles and the facet selectors, and the checks of
    every run parameter by its object (gamma0 and Theta against E): all before the mesh."""
    material = _material(config, source)
    with reported_at("[scheme]", source):
        scheme = make_scheme(setting(config, "scheme", "name"), **_keywords(config, "make_scheme"))
    problem, run = _keywords(config, "ContactProblem"), _keywords(config, "Simulation")
    with reported_at("[scheme]", source):
        TimeStepping(run["dt"], run["t_end"], run["max_step_cuts"])
    with reported_at("[nitsche]", source):
        nitsche = NitscheParameters(**{f.name: problem[f.name] for f in fields(NitscheParameters)})
        materials = material.values() if isinstance(material, dict) else [material]
        nitsche = nitsche.resolved(max(each.E for each in materials))  # as ContactProblem
        for each in materials:
            nitsche.check_scale(each.E)
    with reported_at("[mesh]", source):
        Discretisation(**{f.name: problem[f.name] for f in fields(Discretisation)})
    with reported_at("[damping]", source):
        check_damping(**_keywords(config, "ContactProblem.set_damping"))
    obstacles = _obstacles(config, source)
    selectors = _selectors(config, source)
    output_parameters(config, source)
    return _Checked(material, scheme, obstacles, selectors)


def _material(config: dict, source: str) -> Material | dict:
    """[material], or with [[region]] tables a dict {cell tag: Material, None: [material]}."""
    with reported_at("[material]", source):
        material = _material_of(config["material"])
    if not config.get("region"):
        return material
    one_material = "a hyperelastic material is one material for the whole mesh so far"
    if material.finite:  # each law named in the table that gives it
        raise bad(source, "[material]", "law", material.law, f"{one_material}: not with "
                  "[[region]] tables")  # fmt: skip
    materials = {None: material}
    for index, region in enumerate(config["region"]):
        where = f"[[region]] #{index + 1}"
        try:
            materials[region["tag"]] = _material_of({"rho": material.rho, **region})
        except ParameterError as error:  # named in its own table, not [material]
            raise bad(source, where, error.name, error.value, error.requirement) from None
        if materials[region["tag"]].finite:
            raise bad(source, where, "law", region["law"], f"{one_material}: give it in "
                      "[material], without [[region]] tables")  # fmt: skip
    return materials


def _material_of(values: dict) -> Material:
    """The material of a table of [material]'s keys (E and nu, or lmbda and mu; rho)."""
    rho = values.get("rho", SCHEMA["material"].keys["rho"].default)
    law = values.get("law", SCHEMA["material"].keys["law"].default)
    if "E" in values:
        return Material(E=values["E"], nu=values["nu"], rho=rho, law=law)
    return Material.from_lame(values["lmbda"], values["mu"], rho=rho, law=law)


def _obstacles(config: dict, source: str) -> list:
    """The obstacles of the [[obstacle]] tables, made by their classes (which check their
    values) with the keys of their type."""
    obstacles = []
    for index, table in enumerate(config.get("obstacle", [])):
        kind = OBSTACLES[setting(config, "obstacle", "type", table)]
        given = {key: table.get(key, spec.default) for key, spec in kind.keys.items()}
        where = f"[[obstacle]] #{index + 1}"
        with reported_at(where, source):
            obstacle = kind.make(**given)
        if "translation" in table or "angle" in table:
            with reported_at(where, source, _motion_names(table)):
                obstacle = _moving(obstacle, table)
        obstacles.append(obstacle)
    return obstacles


def _motion_names(table: dict) -> dict:
    """The keys of an [[obstacle]] table under the API's names of
    :class:`~nitsche_dolfinx.physics.motion.MovingObstacle` and of the checks of a moving
    obstacle (for :func:`~nitsche_dolfinx.config.reader.reported_at`): its ``axis`` is the table's
    ``rotation_axis`` (a cylinder's own ``axis`` is its shape's), and the obstacle as a
    whole is named by its motion."""
    motion = "translation" if "translation" in table else "angle"
    return {
        "axis": ("rotation_axis", table.get("rotation_axis")),
        "obstacle": (motion, table.get(motion)),
        "shape": ("type", setting({}, "obstacle", "type", table)),
    }


def _moving(shape, table: dict) -> MovingObstacle:
    """The obstacle of a table with a motion (:data:`~nitsche_dolfinx.physics.motion.MOTION_KEYS`):
    the translation and the angle as functions of t or texts of t."""

    def in_time(key: str):
        if key not in table:
            return None
        value = time_value(table[key])
        if callable(value) or has_text(value):
            return value
        constant = value if key == "translation" else value[0]  # a fixed shift or turn
        return lambda t: constant

    angle = table.get("angle")
    if angle is not None and check_time_value(angle) != 1:
        raise ParameterError("angle", angle, "the angle is one number (or one value in time)")
    return MovingObstacle(
        shape,
        translation=in_time("translation"),
        angle=in_time("angle"),
        pivot=table.get("pivot"),
        axis=table.get("rotation_axis"),
    )


def _selectors(config: dict, source: str) -> list[list]:
    """The selectors of each [[facet_tag]] table (checked without the mesh)."""
    selectors = []
    for index, table in enumerate(config.get("facet_tag", [])):
        selectors.append([])
        for name in FACET_SELECTORS:
            if name in table:
                try:
                    selectors[-1].append(SELECTOR_CLASSES[name](**table[name]))
                except ValueError as error:
                    where = f"[[facet_tag]] #{index + 1}"
                    raise bad(source, where, name, table[name], str(error)) from None
    return selectors


def _mesh(config: dict, comm, source: str):
    """``(mesh, cell_tags or None, facet_tags or None)`` of [mesh]: a mesh file may lack
    facet tags when [[facet_tag]] tables tag its facets."""
    table = config["mesh"]
    with reported_at("[mesh]", source):
        if "generator" in table:
            return generate_mesh(table["generator"], table, comm)
        return load_mesh(
            table["file"], table.get("gdim"), comm,
            facet_tags_required=not config.get("facet_tag"), with_cell_tags=True,
        )  # fmt: skip


def _tag_cells(mesh, cell_tags, config: dict, source: str):
    """The cell tags of the mesh with those of the [[region]] tables' boxes, in their
    order."""
    for index, region in enumerate(config.get("region", [])):
        if "in_box" not in region:
            continue
        where = f"[[region]] #{index + 1}"
        try:
            box = InBox(**region["in_box"])
            cell_tags = tag_cells(mesh, {region["tag"]: box}, cell_tags)
        except ValueError as error:
            raise bad(source, where, "in_box", region["in_box"], str(error)) from None
    return cell_tags


def _tag_facets(mesh, facet_tags, selectors: list[list], config: dict, source: str):
    """The facet tags of the mesh with those of the [[facet_tag]] tables, in their order."""
    for index, (table, chosen_by) in enumerate(zip(config.get("facet_tag", []), selectors)):
        try:
            facet_tags = tag_facets(mesh, {table["tag"]: chosen_by}, facet_tags)
        except ValueError:  # the only error of checked selectors
            given = ", ".join(name for name in FACET_SELECTORS if name in table)
            raise bad(
                source, f"[[facet_tag]] #{index + 1}", "tag", table["tag"],
                f"its selectors ({given}) choose no boundary facet of the mesh",
            ) from None  # fmt: skip
    return facet_tags


def _add_terms(problem, config: dict, obstacles: list, cell_tags, source: str) -> list:
    """Contact pairs, obstacles, Dirichlet conditions, loads and initial values; returns the
    contacts of the obstacles."""
    for index, pair in enumerate(config.get("contact_pair", [])):
        with reported_at(f"[[contact_pair]] #{index + 1}", source):
            problem.add_contact_pair(
                *pair["tags"],
                setting(config, "contact_pair", "variant", pair),
                setting(config, "contact_pair", "direction", pair),
                setting(config, "contact_pair", "follow", pair),
            )
    contacts = []
    for index, (obstacle, table) in enumerate(zip(obstacles, config.get("obstacle", []))):
        with reported_at(f"[[obstacle]] #{index + 1}", source, _motion_names(table)):
            contacts.append(problem.add_obstacle(obstacle, table["tag"]))
    for index, table in enumerate(config.get("dirichlet", [])):
        with reported_at(f"[[dirichlet]] #{index + 1}", source):
            problem.add_dirichlet(table["tag"], time_value(table["value"]), table.get("component"))
    for index, table in enumerate(config.get("traction", [])):
        with reported_at(f"[[traction]] #{index + 1}", source):
            problem.add_traction(table["tag"], time_value(table["value"]))
    if "body_force" in config:
        with reported_at("[body_force]", source):
            problem.add_body_force(time_value(config["body_force"]["value"]))
    initial = config.get("initial", {})
    values = {
        key: field_value(initial[key], problem.gdim) if key in initial else None
        for key in ("displacement", "velocity")
    }
    if config.get("body"):
        values["velocity"] = _body_velocities(problem, config["body"], cell_tags, source)
    with reported_at("[initial]", source):
        problem.set_initial_conditions(**values)
    if "damping" in config:  # (without the table: no damping term in the forms)
        with reported_at("[damping]", source):
            problem.set_damping(**_keywords(config, "ContactProblem.set_damping"))
    return contacts


def _cells(cell_tags, tag: int, where: str, key: str, source: str, comm) -> None:
    """Refuse a cell tag that the mesh does not have."""
    if cell_tags is None:
        raise bad(
            source,
            where,
            key,
            tag,
            "the mesh has no cell tags (the two-body meshes and "
            "the physical groups of cells of a .msh file do)",
        )
    if comm.allreduce(len(cell_tags.find(tag)), op=MPI.SUM) == 0:
        present = sorted(set(comm.allreduce(np.unique(cell_tags.values).tolist(), op=MPI.SUM)))
        raise bad(source, where, key, tag, f"not a cell tag of the mesh (it has {present})")


def _body_velocities(problem, bodies: list, cell_tags, source: str):
    """Declare each [[body]] a body of the problem (its history columns) and return the
    initial velocity its tables give."""
    for index, body in enumerate(bodies):
        where = f"[[body]] #{index + 1}"
        _cells(cell_tags, body["tag"], where, "tag", source, problem.mesh.comm)
        with reported_at(where, source):
            problem.add_body(body["tag"], cell_tags)
    velocities = {body["tag"]: np.asarray(body["velocity"], dtype=float) for body in bodies}
    return body_velocities(problem, cell_tags, velocities)


def _add_probes(simulation, config: dict, contacts: list, cell_tags, source: str) -> None:
    """The [[probe]] columns: u or v at a point, means of u, v or lambda_h over facets,
    cells or the mesh."""
    problem = simulation.problem
    for index, probe in enumerate(config.get("probe", [])):
        where = f"[[probe]] #{index + 1}"
        quantity = probe["quantity"]
        if quantity == "contact_pressure":
            if problem.method != "mixed" and not contacts:
                raise bad(source, where, "quantity", quantity, "there is no [[obstacle]]")
            # lambda_h of the first obstacle (the mixed method: its multiplier)
            expression = (
                simulation.contact_pressure()
                if problem.method == "mixed"
                else contacts[0].pressure(simulation.u)
            )
        else:
            component = setting(config, "probe", "component", probe)
            if not 0 <= component < problem.gdim:
                raise bad(source, where, "component", component, f"the mesh is {problem.gdim}D")
            function = simulation.u if quantity == "displacement" else simulation.v
            expression = function[component]
        if "point" in probe:
            try:
                value = PointValue(function, probe["point"], component)
            except ValueError:  # the point and the component are checked: outside the mesh
                raise bad(
                    source, where, "point", probe["point"], "is in no cell of the mesh"
                ) from None
            simulation.add_probe(probe["name"], value)
            continue
        if "facets" in probe:
            with reported_at(where, source):
                problem.facets(probe["facets"])
            measure = problem.ds(probe["facets"])
        elif "cells" in probe:
            _cells(cell_tags, probe["cells"], where, "cells", source, problem.mesh.comm)
            dx = ufl.Measure(
                "dx", domain=problem.mesh, subdomain_data=cell_tags, metadata=problem.dx.metadata()
            )
            measure = dx(probe["cells"])
        else:
            measure = problem.dx
        simulation.add_probe(probe["name"], BoundaryAverage(problem.mesh, expression, measure))


def _check_columns(simulation, config: dict, source: str) -> None:
    """``[output] columns`` are names of the history (diagnostics and probes)."""
    columns = config.get("output", {}).get("columns")
    if columns is None:
        return
    known = list(simulation.state())
    for name in columns:
        if name not in known:
            raise bad(
                source, "[output]", "columns", columns,
                f"{name!r} is not a column of this run (it has {', '.join(known)})",
            )  # fmt: skip
