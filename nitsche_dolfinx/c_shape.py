"""The C-shaped body of the self-contact demo (docs/method.md section 11): a rectangle with
a slot cut from one side, whose two arms close the slot when the body lands on the ground.

:func:`c_shape_mesh` meshes it with gmsh; the slot's faces are one surface, paired with
itself (``ContactProblem.add_contact_pair(C_SLOT, C_SLOT)``).
"""

from __future__ import annotations

from mpi4py import MPI

from .gmsh_pipeline import distribute
from .shapes import generate, set_mesh_size

__all__ = ["C_BOTTOM", "C_REST", "C_SLOT", "c_shape_mesh"]

#: Facet tags: the slot's faces (its two sides and its end), the bottom, the rest.
C_SLOT, C_BOTTOM, C_REST = 1, 2, 3


def c_shape_mesh(
    width: float = 4.0,
    height: float = 2.2,
    back: float = 1.0,
    slot: float = 0.2,
    mesh_size: float = 0.1,
    order: int = 1,
    comm=MPI.COMM_WORLD,
):
    """The rectangle (0, width) x (0, height) less the slot (back, width) x ((height -
    slot)/2, (height + slot)/2): two arms joined at x < back, open at x = width; gmsh
    triangles of size ``mesh_size`` and geometric ``order``. Facets :data:`C_SLOT`,
    :data:`C_BOTTOM`, :data:`C_REST`. Returns ``(mesh, cell_tags, facet_tags)``, the cells
    all tagged 1."""
    if not (width > back > 0 and height > slot > 0 and mesh_size > 0):
        raise ValueError(
            f"the slot ({back!r}, {width!r}) x {slot!r} does not fit in the rectangle "
            f"{width!r} x {height!r} (or mesh_size {mesh_size!r} <= 0)"
        )
    low, high = (height - slot) / 2, (height + slot) / 2

    def build():
        import gmsh  # optional dependency: the rank that builds the model alone

        gmsh.model.add("C shape")
        occ = gmsh.model.occ
        outer = occ.addRectangle(0.0, 0.0, 0.0, width, height)
        cut = occ.addRectangle(back, low, 0.0, width - back, slot)
        body, _ = occ.cut([(2, outer)], [(2, cut)])
        occ.synchronize()
        groups = {C_SLOT: [], C_BOTTOM: [], C_REST: []}
        tolerance = 1e-9 * width
        for _, curve in gmsh.model.getBoundary(body, oriented=False):
            x, y, _ = occ.getCenterOfMass(1, curve)
            if abs(y) < tolerance:
                groups[C_BOTTOM].append(curve)
            elif (
                x > back - tolerance
                and x < width - tolerance
                and low - tolerance < y < high + tolerance
            ):
                groups[C_SLOT].append(curve)
            else:
                groups[C_REST].append(curve)
        gmsh.model.addPhysicalGroup(2, [body[0][1]], 1)
        for tag, curves in groups.items():
            gmsh.model.addPhysicalGroup(1, curves, tag)
        set_mesh_size(gmsh, mesh_size)
        generate(gmsh, 2, order)

    return distribute(build, comm, 2, [C_SLOT, C_BOTTOM])
