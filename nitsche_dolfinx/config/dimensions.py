"""The vectors of a configuration checked against its mesh's dimension, once the mesh is made
(:mod:`nitsche_dolfinx.config.builder`): every vector, value in time and value in x has the
mesh's dimension, one component of a Dirichlet value has one, and every obstacle type
exists in the dimension, with its rotation given as that dimension takes it. Every error is
a :class:`~nitsche_dolfinx.config.reader.ConfigError` naming the ``[table] key`` and the
value the file gives.
"""

from __future__ import annotations

from ..physics.obstacles import OBSTACLES
from ..physics.valueforms import check_field_value, check_time_value
from .reader import bad, setting
from .schema import FACET_SELECTORS, SCHEMA

__all__ = ["check_dimensions"]


def _components(value) -> int | None:
    """The number of components of a checked value (None: a scalar, any dimension)."""
    if isinstance(value, dict) and "profile" not in value:
        return check_field_value(value)
    return check_time_value(value)


def _check_vectors(item: dict, spec, gdim: int, where: str, source: str) -> None:
    """The vectors, values in time and values in x of a table have gdim components."""
    for key, value in item.items():
        if spec.keys[key].kind not in ("vector", "value in time", "value in x"):
            continue
        size = _components(value)
        if size != gdim and not (size == 1 and gdim == 1):
            raise bad(
                source, where, key, value,
                f"has {size} component{'s' * (size != 1)}, the mesh is {gdim}D",
            )  # fmt: skip


def _check_component(item: dict, gdim: int, where: str, source: str) -> None:
    """A component of the mesh's displacement, and a scalar value for it."""
    component = item["component"]
    if component >= gdim:
        components = "component 0" if gdim == 1 else f"components 0 to {gdim - 1}"
        raise bad(source, where, "component", component, f"the mesh is {gdim}D ({components})")
    size = _components(item["value"])
    if size != 1:
        raise bad(
            source, where, "value", item["value"],
            f"has {size} components; one component (component = {component}) takes a scalar",
        )  # fmt: skip


def check_dimensions(config: dict, gdim: int, source: str) -> None:
    """Every vector of the configuration has the mesh's dimension (one component of a
    Dirichlet value has one), and every obstacle type exists in it."""
    for name, spec in SCHEMA.items():
        # a contact pair checks its direction itself, the generators their centres
        if name not in config or spec.free or name in ("mesh", "contact_pair"):
            continue
        items = config[name] if spec.array else [config[name]]
        for index, item in enumerate(items):
            where = f"[[{name}]] #{index + 1}" if spec.array else f"[{name}]"
            if name == "dirichlet" and "component" in item:
                _check_component(item, gdim, where, source)
            elif name == "facet_tag":
                for selector in FACET_SELECTORS:
                    if selector in item:
                        _check_vectors(item[selector], FACET_SELECTORS[selector], gdim,
                                       f"{where} {selector}", source)  # fmt: skip
            elif name == "obstacle":
                _check_obstacle_dimension(item, gdim, where, source)
            else:
                _check_vectors(item, spec, gdim, where, source)


def _check_obstacle_dimension(item: dict, gdim: int, where: str, source: str) -> None:
    """An obstacle type that exists in the mesh's dimension, with vectors of it."""
    name = setting({}, "obstacle", "type", item)
    dimensions = OBSTACLES[name].dimensions
    if gdim not in dimensions:
        dims = " or ".join(f"{d}D" for d in dimensions)
        raise bad(source, where, "type", name, f"a {name} obstacle is {dims}, the mesh is {gdim}D")
    if "angle" in item and gdim == 1:
        raise bad(source, where, "angle", item["angle"], "a 1D obstacle can only translate")
    if "angle" in item and gdim == 3 and "rotation_axis" not in item:
        raise bad(source, where, "angle", item["angle"],
                  "a rotation in 3D needs its axis: give rotation_axis")  # fmt: skip
    if "rotation_axis" in item and gdim == 2:
        raise bad(source, where, "rotation_axis", item["rotation_axis"],
                  "a 2D obstacle turns about z: rotation_axis is for a 3D mesh")  # fmt: skip
    _check_vectors(item, SCHEMA["obstacle"], gdim, where, source)
