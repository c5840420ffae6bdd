"""The simulation a validated TOML configuration describes (:mod:`nitsche_dolfinx.config`).

The values are checked first, by the parameter objects of
:mod:`nitsche_dolfinx.parameters`; then the mesh is made or read, and the tags,
dimensions and shapes are checked against it; then the terms are added in the order of
the demos (contact pairs, obstacles, Dirichlet conditions, loads, initial values) and
the probes. Every error is a :class:`~nitsche_dolfinx.config.ConfigError` naming the
``[table] key`` it came from.
"""

from __future__ import annotations

import numpy as np

from .config import bad, output_parameters, reported_at, setting
from .schema import SCHEMA
from .valueforms import field_value, time_value

__all__ = ["build_simulation"]


def build_simulation(config: dict, comm=None, progress: bool = True, source: str = "config"):
    """The :class:`~nitsche_dolfinx.simulation.Simulation` of a validated configuration,
    its probes added.

    Args:
        config: A configuration checked by :func:`~nitsche_dolfinx.config.validate`.
        comm: The communicator (``MPI.COMM_WORLD`` by default).
        progress: Show the progress of the run on rank 0.
        source: Name of the configuration in error messages (its file name).

    Raises:
        ConfigError: A value is out of range or does not fit the mesh.
    """
    from mpi4py import MPI

    from .model import ContactProblem
    from .parameters import Discretisation, NitscheParameters, TimeStepping
    from .schemes import make_scheme
    from .simulation import Simulation

    comm = comm or MPI.COMM_WORLD

    def get(table: str, key: str):
        return setting(config, table, key)

    # the values first, the mesh last: a bad value stops the run before any meshing
    material = _material(config, source)
    with reported_at("[scheme]", source):
        scheme = make_scheme(*(get("scheme", key) for key in ("name", "theta", "beta", "gamma")))
        time_stepping = TimeStepping(
            get("scheme", "dt"), get("scheme", "t_end"), get("scheme", "max_step_cuts")
        )
    with reported_at("[nitsche]", source):
        contact = NitscheParameters(
            *(get("nitsche", key) for key in ("gamma0", "theta", "friction", "method")),
            gamma0_scaling=get("nitsche", "gamma0_scaling"),
        )
    with reported_at("[mesh]", source):
        discretisation = Discretisation(
            *(get("mesh", key) for key in ("degree", "mass", "quadrature_degree"))
        )
    obstacles = _obstacles(config, source)
    output_parameters(config, source)
    mesh, cell_tags, facet_tags = _mesh(config["mesh"], comm, source)
    _check_dimensions(config, mesh.geometry.dim, source)
    with reported_at("[nitsche]", source):
        problem = ContactProblem(
            mesh, facet_tags, material, **vars(contact), **vars(discretisation)
        )
    contacts = _add_terms(problem, config, obstacles, cell_tags, source)
    with reported_at("[solver]", source), reported_at("[scheme]", source):
        simulation = Simulation(
            problem,
            scheme,
            time_stepping.dt,
            time_stepping.t_end,
            petsc_options=config.get("petsc"),
            progress=progress,
            reuse_jacobian=get("solver", "reuse_jacobian"),
            preconditioner_lag=get("solver", "preconditioner_lag"),
            guard_friction=get("solver", "guard_friction"),
            linear_solver=get("solver", "linear_solver"),
            max_step_cuts=time_stepping.max_step_cuts,
        )
    _add_probes(simulation, config, contacts, cell_tags, source)
    _check_columns(simulation, config, source)
    return simulation


def _material(config: dict, source: str):
    from .material import Material

    m = config["material"]
    rho = setting(config, "material", "rho")
    with reported_at("[material]", source):
        if "E" in m:
            return Material(E=m["E"], nu=m["nu"], rho=rho)
        return Material.from_lame(m["lmbda"], m["mu"], rho=rho)


def _obstacles(config: dict, source: str) -> list:
    """The obstacles of the [[obstacle]] tables (checked without the mesh)."""
    from .obstacles import CylinderObstacle, PlaneObstacle, SphereObstacle

    obstacles = []
    for index, table in enumerate(config.get("obstacle", [])):
        kind, side = (setting(config, "obstacle", key, table) for key in ("type", "side"))
        with reported_at(f"[[obstacle]] #{index + 1}", source):
            if kind == "plane":
                obstacle = PlaneObstacle(table["point"], table["normal"])
            elif kind == "cylinder":
                obstacle = CylinderObstacle(table["point"], table["axis"], table["radius"], side)
            else:
                obstacle = SphereObstacle(table["center"], table["radius"], side)
        obstacles.append(obstacle)
    return obstacles


def _mesh(table: dict, comm, source: str):
    """``(mesh, cell_tags or None, facet_tags)`` of [mesh]."""
    from .mesh_generators import generate_mesh
    from .meshes import load_mesh

    with reported_at("[mesh]", source):
        if "generator" in table:
            return generate_mesh(table["generator"], table, comm)
        mesh, facet_tags = load_mesh(table["file"], gdim=table.get("gdim"), comm=comm)
        return mesh, None, facet_tags


def _components(value) -> int | None:
    """The number of components of a checked value (None: a scalar, any dimension)."""
    from .valueforms import check_field_value, check_time_value

    if isinstance(value, dict) and "profile" not in value:
        return check_field_value(value)
    return check_time_value(value)


#: The types of obstacle that exist in each dimension.
_OBSTACLE_DIMENSIONS = {"plane": (1, 2, 3), "circle": (2,), "sphere": (3,), "cylinder": (3,)}


def _check_dimensions(config: dict, gdim: int, source: str) -> None:
    """Every vector of the configuration has the mesh's dimension, and every obstacle
    type exists in it."""
    for name, spec in SCHEMA.items():
        # the obstacles and pairs check their points and directions themselves
        if name not in config or spec.free or name in ("mesh", "obstacle", "contact_pair"):
            continue
        items = config[name] if spec.array else [config[name]]
        for index, item in enumerate(items):
            where = f"[[{name}]] #{index + 1}" if spec.array else f"[{name}]"
            for key, value in item.items():
                kind = spec.keys[key].kind
                if kind not in ("vector", "value in time", "value in x"):
                    continue
                size = _components(value)
                if size != gdim and not (size == 1 and gdim == 1):
                    raise bad(
                        source, where, key, value,
                        f"has {size} component{'s' * (size != 1)}, the mesh is {gdim}D",
                    )  # fmt: skip
    for index, table in enumerate(config.get("obstacle", [])):
        kind = setting(config, "obstacle", "type", table)
        if gdim not in _OBSTACLE_DIMENSIONS[kind]:
            dims = " or ".join(f"{d}D" for d in _OBSTACLE_DIMENSIONS[kind])
            raise bad(
                source, f"[[obstacle]] #{index + 1}", "type", kind,
                f"a {kind} obstacle is {dims}, the mesh is {gdim}D",
            )  # fmt: skip


def _add_terms(problem, config: dict, obstacles: list, cell_tags, source: str) -> list:
    """Contact pairs, obstacles, Dirichlet conditions, loads and initial values; returns the
    contacts of the obstacles."""
    for index, pair in enumerate(config.get("contact_pair", [])):
        with reported_at(f"[[contact_pair]] #{index + 1}", source):
            problem.add_contact_pair(
                *pair["tags"],
                setting(config, "contact_pair", "variant", pair),
                setting(config, "contact_pair", "direction", pair),
            )
    contacts = []
    for index, (obstacle, table) in enumerate(zip(obstacles, config.get("obstacle", []))):
        with reported_at(f"[[obstacle]] #{index + 1}", source):
            contacts.append(problem.add_obstacle(obstacle, table["tag"]))
    for name, add in (("dirichlet", problem.add_dirichlet), ("traction", problem.add_traction)):
        for index, table in enumerate(config.get(name, [])):
            with reported_at(f"[[{name}]] #{index + 1}", source):
                add(table["tag"], time_value(table["value"]))
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
    return contacts


def _cells(cell_tags, tag: int, where: str, key: str, source: str, comm) -> None:
    """Refuse a cell tag that the mesh does not have."""
    from mpi4py import MPI

    if cell_tags is None:
        raise bad(source, where, key, tag, "the mesh has no cell tags (the two-body meshes do)")
    if comm.allreduce(len(cell_tags.find(tag)), op=MPI.SUM) == 0:
        present = sorted(set(comm.allreduce(np.unique(cell_tags.values).tolist(), op=MPI.SUM)))
        raise bad(source, where, key, tag, f"not a cell tag of the mesh (it has {present})")


def _body_velocities(problem, bodies: list, cell_tags, source: str):
    from .twobody import body_velocities

    for index, body in enumerate(bodies):
        _cells(cell_tags, body["tag"], f"[[body]] #{index + 1}", "tag", source, problem.mesh.comm)
    velocities = {body["tag"]: np.asarray(body["velocity"], dtype=float) for body in bodies}
    return body_velocities(problem, cell_tags, velocities)


def _add_probes(simulation, config: dict, contacts: list, cell_tags, source: str) -> None:
    """The [[probe]] columns: means of u, v or lambda_h over facets, cells or the mesh."""
    import ufl

    from .diagnostics import BoundaryAverage

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
