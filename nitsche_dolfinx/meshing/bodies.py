"""The bodies of a problem: the parts of its mesh that a cell tag names, apart from each
other (docs/method.md section 11).

A body is known by its nodes: the nodes of the displacement space on its cells. Its
columns in the history (momentum, centre of mass, angular momentum) are sums over these
nodes of the mass matrix's rows (:class:`~nitsche_dolfinx.output.mass_moments.MassMoments`), so
bodies must not share a node: the rows of a shared node would count in both.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc

from ..common import compat
from ..common.parameters import ParameterError

__all__ = ["Body", "body_nodes", "make_body"]


@dataclass(frozen=True)
class Body:
    """A body: its cell tag and its nodes.

    Attributes:
        tag: The cell tag.
        nodes: Whether each node this rank owns is the body's (a boolean array over the
            owned nodes of the displacement space).
    """

    tag: int
    nodes: np.ndarray


def body_nodes(V, cells: np.ndarray) -> np.ndarray:
    """The owned nodes of ``V`` on the given cells of this rank, those on cells of other
    ranks too: a boolean array over this rank's owned nodes (collective)."""
    marks = fem.Function(V)
    bs = V.dofmap.index_map_bs
    values = marks.x.array.reshape(-1, bs)
    values[np.unique(compat.dofmap_array(V)[cells])] = 1.0
    vector = compat.petsc_vector(marks)  # a node's ghosts add up to its owner
    vector.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    return marks.x.array[: V.dofmap.index_map.size_local * bs : bs] > 0


def make_body(V, cell_tags, tag: int, others: list[Body]) -> Body:
    """The :class:`Body` of the cells tagged ``tag``, checked against the bodies before.

    Raises:
        ParameterError: No cell tags, no cell of that tag on any rank, a tag given twice,
            or a node shared with another body.
    """
    comm = V.mesh.comm
    if cell_tags is None:
        raise ParameterError(
            "tag", tag, "the mesh has no cell tags (give cell_tags: the two-body meshes and "
            "the physical groups of cells of a .msh file have them)",
        )  # fmt: skip
    if any(body.tag == tag for body in others):
        raise ParameterError("tag", tag, "is a body already")
    cells = cell_tags.find(tag)
    if comm.allreduce(len(cells), op=MPI.SUM) == 0:
        present = sorted(set(comm.allreduce(np.unique(cell_tags.values).tolist(), op=MPI.SUM)))
        raise ParameterError("tag", tag, f"not a cell tag of the mesh (it has {present})")
    nodes = body_nodes(V, cells)
    for body in others:
        if comm.allreduce(int(np.count_nonzero(nodes & body.nodes)), op=MPI.SUM):
            raise ParameterError(
                "tag", tag, f"shares nodes with the body of tag {body.tag}: bodies are "
                "parts of the mesh apart from each other (a body's columns sum its nodes' "
                "rows of the mass matrix)",
            )  # fmt: skip
    return Body(int(tag), nodes)
