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
    depth: float = 0.0,
    comm=MPI.COMM_WORLD,
):
    """The rectangle (0, width) x (0, height) less the slot (back, width) x ((height -
    slot)/2, (height + slot)/2): two arms joined at x < back, open at x = width; gmsh
    triangles of size ``mesh_size`` and geometric ``order``. ``depth`` > 0: the prism of
    that depth along z over it, in tetrahedra (the slot's faces then end at z = 0 and
    z = depth). Facets :data:`C_SLOT`, :data:`C_BOTTOM`, :data:`C_REST`. Returns
    ``(mesh, cell_tags, facet_tags)``, the cells all tagged 1."""
    if not (width > back > 0 and height > slot > 0 and mesh_size > 0 and depth >= 0):
        raise ValueError(
            f"the slot ({back!r}, {width!r}) x {slot!r} does not fit in the rectangle "
            f"{width!r} x {height!r} (or mesh_size {mesh_size!r} <= 0, depth {depth!r} < 0)"
        )
    low, high = (height - slot) / 2, (height + slot) / 2
    dim = 3 if depth > 0 else 2

    def build():
        import gmsh  # optional dependency: the rank that builds the model alone

        gmsh.model.add("C shape")
        occ = gmsh.model.occ
        if dim == 2:
            outer = occ.addRectangle(0.0, 0.0, 0.0, width, height)
            cut = occ.addRectangle(back, low, 0.0, width - back, slot)
        else:  # (the cut passes through the prism's ends)
            outer = occ.addBox(0.0, 0.0, 0.0, width, height, depth)
            cut = occ.addBox(back, low, -depth, 2 * (width - back), slot, 3 * depth)
        body, _ = occ.cut([(dim, outer)], [(dim, cut)])
        occ.synchronize()
        groups = {C_SLOT: [], C_BOTTOM: [], C_REST: []}
        tolerance = 1e-9 * width
        for _, entity in gmsh.model.getBoundary(body, oriented=False):
            x, y, z = occ.getCenterOfMass(dim - 1, entity)
            inside = dim == 2 or tolerance < z < depth - tolerance
            if abs(y) < tolerance:
                groups[C_BOTTOM].append(entity)
            elif (
                back - tolerance < x < width - tolerance
                and low - tolerance < y < high + tolerance
                and inside
            ):
                groups[C_SLOT].append(entity)
            else:
                groups[C_REST].append(entity)
        gmsh.model.addPhysicalGroup(dim, [body[0][1]], 1)
        for tag, entities in groups.items():
            gmsh.model.addPhysicalGroup(dim - 1, entities, tag)
        set_mesh_size(gmsh, mesh_size)
        generate(gmsh, dim, order)

    return distribute(build, comm, dim, [C_SLOT, C_BOTTOM])
