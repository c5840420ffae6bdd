"""The meshes a configuration can generate (``[mesh] generator = "..."``): the meshes of the
shipped demos, each the function of the library that the demo calls, with its keys and
their defaults.

A generator returns ``(mesh, cell_tags, facet_tags)``; ``cell_tags`` is None for the
one-body meshes, and names the bodies of the two-body meshes (``[[body]]`` tables).
:data:`MESH_GENERATORS` owns each generator's keys, defaults, dimension and size;
:data:`GENERATOR_KEYS` the kind, meaning and range of every key; :func:`check_generator`
checks a table against both before anything is made.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

from ..common.keys import Key, is_number
from ..common.parameters import ParameterError
from ..meshing.c_shape import c_shape_mesh
from ..meshing.meshes import MAX_CELLS, bar_mesh, block_mesh
from ..meshing.shapes import ball_mesh, disk_mesh
from ..meshing.two_bodies import (
    ball_on_slab_mesh,
    block_on_slab_mesh,
    mirrored_bodies_mesh,
    two_bars_mesh,
)

__all__ = ["GENERATOR_KEYS", "MESH_GENERATORS", "MeshGenerator", "check_generator", "generate_mesh"]


@dataclass(frozen=True)
class MeshGenerator:
    """A mesh of the library: what it is, its keys with their defaults, its dimension
    (``None``: the key ``dim`` says it), its tags, and the number of cells its keys ask
    for (``None``: the library's function checks its own size)."""

    meaning: str
    keys: dict[str, object]
    make: Callable = field(repr=False)
    gdim: int | None = None
    tags: str = ""
    cells: Callable[..., float] | None = field(default=None, repr=False)

    def dimension(self, table: dict) -> int:
        """The geometric dimension of the mesh that ``table`` asks for."""
        return self.gdim if self.gdim is not None else int(table.get("dim", self.keys["dim"]))

    def values(self, table: dict) -> dict:
        """The generator's keys with the values of ``table``, the others at their defaults."""
        return {key: table.get(key, default) for key, default in self.keys.items()}


def _bar(comm, nx, length):
    mesh, facet_tags = bar_mesh(nx, length, comm=comm)
    return mesh, None, facet_tags


def _block(comm, width, height, nx, ny):
    mesh, facet_tags = block_mesh(width, height, nx, ny, comm=comm)
    return mesh, None, facet_tags


def _disk(comm, mesh_size, order, radius, center):
    mesh, facet_tags = disk_mesh(mesh_size, order, radius, center, comm=comm)
    return mesh, None, facet_tags


def _ball(comm, mesh_size, order, radius, center):
    mesh, facet_tags = ball_mesh(mesh_size, order, radius, center, comm=comm)
    return mesh, None, facet_tags


def _two_bars(comm, nx, gap):
    return two_bars_mesh(nx, gap, comm)


def _mirrored_bodies(comm, dim, mesh_size, order, gap, offset):
    return mirrored_bodies_mesh(dim, mesh_size, order, gap, comm, offset)


def _ball_on_slab(comm, dim, mesh_size, radius, width, thickness, gap):
    return ball_on_slab_mesh(dim, mesh_size, radius, width, thickness, gap, comm)


def _block_on_slab(comm, **keys):
    return block_on_slab_mesh(**keys, comm=comm)


def _c_shape(comm, dim, depth, **keys):
    return c_shape_mesh(**keys, depth=depth if dim == 3 else 0.0, comm=comm)


def _c_shape_cells(dim, width, height, back, slot, mesh_size, order, depth):
    area = width * height / mesh_size**2
    return 2 * area if dim == 2 else 6 * area * depth / mesh_size


#: name -> the generator. The keys are those of the library's function, with its defaults.
MESH_GENERATORS: dict[str, MeshGenerator] = {
    "bar": MeshGenerator(
        "the interval (0, length) of nx cells (meshes.bar_mesh)",
        {"nx": 100, "length": 1.0},
        _bar,
        1,
        "facets 1 at x = 0, 2 at x = length",
        lambda nx, length: nx,
    ),
    "block": MeshGenerator(
        "the rectangle (-width/2, width/2) x (0, height) in nx x ny x 2 triangles "
        "(meshes.block_mesh)",
        {"width": 2.0, "height": 1.0, "nx": 8, "ny": 4},
        _block,
        2,
        "facets 1 at y = 0",
        lambda width, height, nx, ny: 2 * nx * ny,
    ),
    "disk": MeshGenerator(
        "the gmsh disk of the 2D impact test (shapes.disk_mesh)",
        {"mesh_size": 8.0, "order": 2, "radius": 20.0, "center": [0.0, 20.0]},
        _disk,
        2,
        "facets 1 lower half circle, 2 upper half",
    ),
    "ball": MeshGenerator(
        "the gmsh ball of the 3D impact test (shapes.ball_mesh)",
        {"mesh_size": 8.0, "order": 2, "radius": 20.0, "center": [0.0, 0.0, 20.0]},
        _ball,
        3,
        "facets 1 lower hemisphere, 2 upper hemisphere",
    ),
    "two_bars": MeshGenerator(
        "two bars of length 1, (gap, 1 + gap) and (-1, 0), nx cells each "
        "(meshing.two_bodies.two_bars_mesh)",
        {"nx": 100, "gap": 0.0},
        _two_bars,
        1,
        "cells 1 right bar, 2 left bar; facets 1 at x = gap, 2 at x = 0, 3 and 4 outer ends",
        lambda nx, gap: 2 * nx,
    ),
    "mirrored_bodies": MeshGenerator(
        "the disk (dim = 2) or ball (dim = 3) of the impact test, lowest point gap/2 above "
        "the plane x_dim = 0, and its mirror image; offset: the two that far apart along x "
        "(meshing.two_bodies.mirrored_bodies_mesh)",
        {"dim": 2, "mesh_size": 8.0, "order": 2, "gap": 0.0, "offset": 0.0},
        _mirrored_bodies,
        None,
        "cells 1 upper body, 2 lower body; facets 1 upper body's lower half, 2 lower body's "
        "upper half, 3 and 4 the rest",
    ),
    "ball_on_slab": MeshGenerator(
        "a ball (dim = 3) or disk (dim = 2) gap above a slab (-width/2, width/2)^(dim-1) x "
        "(0, thickness) (meshing.two_bodies.ball_on_slab_mesh)",
        {
            "dim": 3,
            "mesh_size": 8.0,
            "radius": 20.0,
            "width": 80.0,
            "thickness": 10.0,
            "gap": 1.0,
        },
        _ball_on_slab,
        None,
        "cells 1 ball, 2 slab; facets 1 ball's lower half, 2 slab top, 3 slab bottom",
    ),
    "block_on_slab": MeshGenerator(
        "a block (-width/2, width/2) x (gap, gap + height) above a slab (slab_start, "
        "slab_start + slab_length) x (-thickness, 0), structured triangles "
        "(meshing.two_bodies.block_on_slab_mesh)",
        {
            "width": 2.0,
            "height": 1.0,
            "nx": 8,
            "ny": 4,
            "slab_start": -1.5,
            "slab_length": 6.0,
            "thickness": 0.5,
            "slab_nx": 24,
            "slab_ny": 2,
            "gap": 1e-6,
        },
        _block_on_slab,
        2,
        "cells 1 block, 2 slab; facets 1 block bottom, 2 slab top, 3 slab bottom",
        lambda nx, ny, slab_nx, slab_ny, **sizes: 2 * (nx * ny + slab_nx * slab_ny),
    ),
    "c_shape": MeshGenerator(
        "the rectangle (0, width) x (0, height) less a slot (back, width) x ((height - "
        "slot)/2, (height + slot)/2): a C open at x = width; dim = 3: the prism of depth "
        "depth over it (c_shape.c_shape_mesh)",
        {
            "dim": 2,
            "width": 4.0,
            "height": 2.2,
            "back": 1.0,
            "slot": 0.2,
            "mesh_size": 0.1,
            "order": 1,
            "depth": 1.0,
        },
        _c_shape,
        None,
        "cells 1; facets 1 the slot's faces, 2 the bottom, 3 the rest",
        _c_shape_cells,
    ),
}


def _positive(value) -> bool:
    return math.isfinite(value) and value > 0


def _key(kind: str, meaning: str, check: Callable, requirement: str) -> Key:
    return Key(kind, None, meaning, shown_default="the generator's", check=check,
               requirement=requirement)  # fmt: skip


#: Each generator key: its kind, what it is, and its range.
GENERATOR_KEYS: dict[str, Key] = {
    "nx": _key("integer", "cells along x (two_bars: per bar)", lambda n: n >= 1, "at least 1"),
    "ny": _key("integer", "cells along y", lambda n: n >= 1, "at least 1"),
    "slab_nx": _key("integer", "cells of the slab along x", lambda n: n >= 1, "at least 1"),
    "slab_ny": _key("integer", "cells of the slab along y", lambda n: n >= 1, "at least 1"),
    "slab_start": _key("number", "x of the slab's left end", math.isfinite, "finite"),
    "slab_length": _key("number", "length of the slab", _positive, "positive"),
    "length": _key("number", "length of the bar", _positive, "positive"),
    "width": _key("number", "width of the block, the slab or the C", _positive, "positive"),
    "height": _key("number", "height of the block or the C", _positive, "positive"),
    "back": _key("number", "length of the C's closed end, where its slot ends", _positive,
                 "positive"),
    "slot": _key("number", "width of the C's slot", _positive, "positive"),
    "depth": _key("number", "depth of the 3D C along z", _positive, "positive"),
    "thickness": _key("number", "thickness of the slab", _positive, "positive"),
    "mesh_size": _key("number", "target edge length of the gmsh cells", _positive, "positive"),
    "order": _key("integer", "geometric order of the gmsh mesh (2: curved)",
                  (1, 2).__contains__, "1 or 2"),
    "radius": _key("number", "radius of the disk or ball", _positive, "positive"),
    "center": _key("vector", "centre of the disk or ball", lambda c: True, ""),
    "gap": _key("number", "initial gap between the bodies", lambda g: g >= 0, ">= 0"),
    "dim": _key("integer", "2 (disks, the C) or 3 (balls, the prism)", (2, 3).__contains__,
                "2 or 3"),
    "offset": _key("number", "distance of the bodies' centres along x (an off-centre hit)",
                   lambda d: abs(d) < 40.0, "less than a diameter (40) in magnitude"),
}  # fmt: skip


def check_generator(name: str, table: dict) -> None:
    """Check the keys of ``table``, each of its kind and range (:data:`GENERATOR_KEYS`,
    checked with the table's other keys), for the generator ``name``: keys it takes, a
    centre of the mesh's dimension, and a mesh of at most
    :data:`~nitsche_dolfinx.meshing.meshes.MAX_CELLS` cells.

    Raises:
        ParameterError: Naming the first bad key and its value.
    """
    generator = MESH_GENERATORS[name]
    for key, value in table.items():
        if key in GENERATOR_KEYS and key not in generator.keys:
            raise ParameterError(
                key, value, f"not a key of the {name!r} mesh (it takes {', '.join(generator.keys)})"
            )
    center = table.get("center")
    if center is not None:
        dimension = len(generator.keys["center"])
        if not isinstance(center, list) or len(center) != dimension:
            raise ParameterError("center", center, f"must have {dimension} coordinates")
    if generator.cells is not None:
        values = generator.values(table)
        cells = generator.cells(**values)
        if not (is_number(cells) and cells <= MAX_CELLS):
            given = ", ".join(f"{key} = {values[key]}" for key in generator.keys)
            raise ParameterError(
                name, cells, f"{given} make {cells:.2g} cells, more than {MAX_CELLS:.0e}",
                label=f"generator = {name!r}",
            )  # fmt: skip


def generate_mesh(name: str, table: dict, comm):
    """The mesh ``name`` with the keys of ``table`` (the others at their defaults):
    ``(mesh, cell_tags or None, facet_tags)``.

    Raises:
        ValueError: A value the library refuses (the size of a gmsh body, say).
    """
    return MESH_GENERATORS[name].make(comm, **MESH_GENERATORS[name].values(table))
