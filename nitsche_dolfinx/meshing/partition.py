"""The contact-aware cell partition: each rank gets its share of every contact surface.

dolfinx's default graph partition takes no account of where contact happens and often
leaves a whole contact zone on one rank, whose contact work the others then wait for
(docs/method.md section 8). :func:`contact_bisection` cuts the mesh instead by recursive
coordinate bisection of the cells' centroids, each cut across the direction in which the
contact surfaces extend most. How dolfinx calls a partitioner, and what it must return,
differs between versions: :func:`nitsche_dolfinx.common.compat.cell_partitioner` wraps it.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..common import compat

__all__ = ["contact_bisection"]


def contact_bisection(x: np.ndarray, contact, num_vertices: int):
    """A cell partitioner for ``dolfinx.mesh.create_mesh`` that spreads the contact
    boundary over the ranks: recursive coordinate bisection of the cells by their
    centroids, each cut across the direction in which the contact surfaces of the part
    extend most (the sum of their extents; the cells' own extent where no surface has two
    nodes in the part), at the median that gives each side cells in proportion to its
    ranks. With one surface, each cut halves it; with two facing surfaces (two bodies in
    contact), each rank gets its share of both.

    Args:
        x: The nodes, by input index (num_nodes, 3); the rows that the partitioner's
            cells index. Empty on ranks that give no cells.
        contact: The coordinates of the nodes of the contact boundary (n, 3), or a list
            of such arrays, one per contact surface.
        num_vertices: The vertices of a cell.

    Returns:
        The partitioner (see :func:`nitsche_dolfinx.common.compat.cell_partitioner`).
    """
    surfaces = [contact] if isinstance(contact, np.ndarray) else list(contact)
    surfaces = [np.asarray(nodes, dtype=float).reshape(-1, 3) for nodes in surfaces]

    def owners(vertices: np.ndarray, parts: int) -> np.ndarray:
        ranks = np.zeros(len(vertices), dtype=np.int32)
        if len(vertices):
            centroids = x[vertices].mean(axis=1)
            _bisect(centroids, surfaces, np.arange(len(vertices)), 0, parts, ranks)
        return ranks

    return compat.cell_partitioner(owners, num_vertices)


def _bisect(centroids, surfaces: Sequence[np.ndarray], cells, first: int, parts: int, ranks):
    """Give ``cells`` to ranks ``first`` to ``first + parts - 1`` (see contact_bisection)."""
    if parts == 1:
        ranks[cells] = first
        return
    points = centroids[cells]
    axis = int(np.argmax(_extent(points, surfaces)))
    order = cells[np.argsort(points[:, axis], kind="stable")]
    left = parts // 2
    cut = len(cells) * left // parts
    _bisect(centroids, surfaces, order[:cut], first, left, ranks)
    _bisect(centroids, surfaces, order[cut:], first + left, parts - left, ranks)


def _extent(points: np.ndarray, surfaces: Sequence[np.ndarray]) -> np.ndarray:
    """The extent along each axis of the surfaces' nodes in the bounding box of
    ``points``, summed over the surfaces that have two nodes or more there; else the
    extent of ``points``."""
    low, high = points.min(axis=0), points.max(axis=0)
    extent, found = np.zeros(points.shape[1]), False
    for nodes in surfaces:
        inside = nodes[np.all((nodes >= low) & (nodes <= high), axis=1)]
        if len(inside) > 1:
            extent = extent + (inside.max(axis=0) - inside.min(axis=0))
            found = True
    return extent if found else high - low
