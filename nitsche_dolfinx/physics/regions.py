"""Several materials in one mesh, one per cell tag (docs/method.md section 13).

:class:`CellwiseMaterial` holds the parameters of the materials as fields constant in
each cell (DG0), with the names of
:class:`~nitsche_dolfinx.physics.material.MaterialConstants` (``E``, ``nu``, ``lmbda``, ``mu``,
``rho``), so that every formula takes either. Their values are runtime values: changing
a material changes the fields, not the compiled forms.
"""

from __future__ import annotations

import numpy as np
from dolfinx import fem
from mpi4py import MPI

from ..common import compat
from ..common.parameters import ParameterError
from .material import Material

__all__ = ["CellwiseMaterial"]

#: The parameters a material gives each cell.
PARAMETERS = ("E", "nu", "lmbda", "mu", "rho")


class CellwiseMaterial:
    """The materials of the cells, by cell tag.

    Args:
        mesh: The mesh.
        cell_tags: The cell tags (``dolfinx.mesh.MeshTags`` of the cells).
        materials: The :class:`~nitsche_dolfinx.physics.material.Material` of each cell tag; the
            key None, when present, gives the material of every other cell (untagged
            too); without it every cell must carry one of the tags.

    Attributes ``E``, ``nu``, ``lmbda``, ``mu`` and ``rho`` are DG0 Functions;
    :attr:`material_id` is the tag of each cell (a field of the output).
    """

    def __init__(self, mesh, cell_tags, materials: dict[int, Material]):
        _check_materials(materials)
        tdim = mesh.topology.dim
        owned = mesh.topology.index_map(tdim).size_local
        tag_of = _owned_cell_tags(mesh, cell_tags, owned)
        _check_every_cell_tagged(mesh, tag_of, materials)
        self.materials = dict(materials)
        D = compat.function_space(mesh, "DG", 0)
        dofs = compat.dofmap_array(D)[:owned, 0]
        self.material_id = fem.Function(D, name="material_id")
        self.material_id.x.array[dofs] = tag_of
        for name in PARAMETERS:
            field = fem.Function(D, name=name)
            values = {tag: getattr(material, name) for tag, material in materials.items()}
            field.x.array[dofs] = [values.get(tag, values.get(None)) for tag in tag_of]
            setattr(self, name, field)
        for field in (self.material_id, *(getattr(self, name) for name in PARAMETERS)):
            field.x.scatter_forward()


def _check_materials(materials) -> None:
    if not isinstance(materials, dict) or not materials:
        requirement = "must be a Material or a dict {cell tag: Material}"
        raise ParameterError("material", materials, requirement)
    for tag, material in materials.items():
        if tag is not None and (not isinstance(tag, (int, np.integer)) or isinstance(tag, bool)):
            requirement = "the keys of a dict of materials are cell tags (or None: the others)"
            raise ParameterError("material", tag, requirement)
        if not isinstance(material, Material):
            raise ParameterError(f"material[{tag}]", material, "must be a Material")


def _owned_cell_tags(mesh, cell_tags, owned: int) -> np.ndarray:
    """The tag of each owned cell (-1: untagged)."""
    if cell_tags is None or cell_tags.dim != mesh.topology.dim:
        raise ParameterError("cell_tags", cell_tags, "several materials need the mesh's cell tags")
    tags = np.full(owned, -1, dtype=np.int64)
    mine = cell_tags.indices < owned
    tags[cell_tags.indices[mine]] = cell_tags.values[mine]
    return tags


def _check_every_cell_tagged(mesh, tag_of: np.ndarray, materials: dict) -> None:
    """Every cell has a tag of ``materials``, and every such tag has cells."""
    comm = mesh.comm
    present = sorted(set(comm.allreduce(np.unique(tag_of).tolist(), op=MPI.SUM)))
    missing = [tag for tag in present if tag not in materials]
    if missing and None not in materials:
        what = "untagged cells" if missing == [-1] else f"cells tagged {missing}"
        raise ParameterError(
            "material", _tags(materials), f"{what} have no material (given for the tags "
            f"{_tags(materials)}; the mesh's cell tags are {[t for t in present if t >= 0]})",
        )  # fmt: skip
    unused = [tag for tag in materials if tag is not None and tag not in present]
    if unused:
        raise ParameterError(
            "material", _tags(materials), f"no cell carries the tags {unused} (the mesh's "
            f"cell tags are {[t for t in present if t >= 0]})",
        )  # fmt: skip


def _tags(materials: dict) -> list:
    """The cell tags of ``materials``, sorted (None, the others' key, last)."""
    return sorted(tag for tag in materials if tag is not None) + [None] * (None in materials)
