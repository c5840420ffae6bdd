"""The disk of the impact test made exactly mirror-symmetric (its left half meshed by gmsh,
then mirrored node for node), its left half, and pairs of them: meshes without physical
groups, tagged by :func:`~nitsche_dolfinx.meshing.facet_selectors.tag_facets`, for the tests that
compare a
body with its half."""

import numpy as np
from mpi4py import MPI

from nitsche_dolfinx.meshing import DISK_CONTACT, DISK_FREE, OnPlane, gmsh_session, tag_facets

RADIUS = 20.0
#: Facet tag of the cut x = 0 of the half disk.
SYMMETRY = 3


def _half_disk(mesh_size: float):
    """Nodes (N, 3) and P2 triangles (gmsh order) of the half disk x <= 0 of the impact
    test (centre (0, 20)), meshed by gmsh, without unused nodes."""
    import gmsh

    occ = gmsh.model.occ
    gmsh.model.add("half disk")
    points = [(0, 2 * RADIUS, 0), (-RADIUS, RADIUS, 0), (0, 0, 0)]  # top, left, bottom
    top, left, bottom = (occ.addPoint(*p) for p in points)
    centre = occ.addPoint(0, RADIUS, 0)
    arcs = [occ.addCircleArc(top, centre, left), occ.addCircleArc(left, centre, bottom)]
    occ.addPlaneSurface([occ.addCurveLoop([*arcs, occ.addLine(bottom, top)])])
    occ.synchronize()
    gmsh.option.setNumber("Mesh.MeshSizeMax", mesh_size)
    gmsh.option.setNumber("Mesh.MeshSizeMin", 0.5 * mesh_size)
    gmsh.model.mesh.generate(2)
    gmsh.model.mesh.setOrder(2)
    tags, xyz, _ = gmsh.model.mesh.getNodes()
    _, cells = gmsh.model.mesh.getElementsByType(9)  # 6-node triangles
    row = np.zeros(int(tags.max()) + 1, dtype=np.int64)
    row[tags] = np.arange(len(tags))
    cells = row[cells.reshape(-1, 6)]
    used = np.unique(cells)  # not the centre of the arcs
    renumber = np.zeros(len(tags), dtype=np.int64)
    renumber[used] = np.arange(len(used))
    return xyz.reshape(-1, 3)[used], renumber[cells]


def _mirrored(xyz, cells, axis: int, merge: bool):
    """Add the mirror image in the plane x_axis = 0; ``merge``: the nodes on the plane are
    shared (one body), else doubled (two bodies)."""
    on_plane = np.abs(xyz[:, axis]) < 1e-12 if merge else np.zeros(len(xyz), dtype=bool)
    xyz[on_plane, axis] = 0.0
    image = np.arange(len(xyz))
    image[~on_plane] = len(xyz) + np.arange(np.count_nonzero(~on_plane))
    mirror = xyz[~on_plane].copy()
    mirror[:, axis] *= -1.0
    mirrored_cells = image[cells][:, [0, 2, 1, 5, 4, 3]]  # the same orientation
    return np.vstack([xyz, mirror]), np.vstack([cells, mirrored_cells])


def symmetric_disks(
    half: bool, pair: bool = False, mesh_size: float = 8.0, comm=MPI.COMM_WORLD, msh=None
):
    """The disk of the impact test, exactly symmetric in x = 0 (its left half mirrored),
    or its left half; with ``pair``, also its mirror image in y = 0 (two bodies touching
    at the origin). Returns ``(mesh, cell_tags, facet_tags)``: cells 1 (upper body) and
    2; facets DISK_CONTACT (the lower half circle), DISK_FREE (the upper one), and for a
    pair 4 and 5 (the lower body's upper and lower half circles), tagged by
    :func:`tag_facets`; SYMMETRY on the cut of a half. ``msh``: a path where rank 0 also
    writes the mesh, a ``.msh`` file with the cells' physical groups only."""
    from nitsche_dolfinx.common import gmsh_model_to_mesh

    with gmsh_session() as gmsh:
        if comm.rank == 0:
            xyz, cells = _half_disk(mesh_size)
            if not half:
                xyz, cells = _mirrored(xyz, cells, 0, merge=True)
            bodies = np.ones(len(cells), dtype=np.int32)
            if pair:
                xyz, cells = _mirrored(xyz, cells, 1, merge=False)
                bodies = np.concatenate([bodies, 2 * bodies])
            gmsh.model.add("disks")
            for body in np.unique(bodies):
                entity = gmsh.model.addDiscreteEntity(2)
                if body == 1:
                    gmsh.model.mesh.addNodes(2, entity, np.arange(1, len(xyz) + 1), xyz.ravel())
                chosen = np.flatnonzero(bodies == body)
                gmsh.model.mesh.addElementsByType(entity, 9, chosen + 1, cells[chosen].ravel() + 1)
                gmsh.model.addPhysicalGroup(2, [entity], int(body))
            if msh is not None:
                gmsh.write(str(msh))
        mesh, cell_tags, _ = gmsh_model_to_mesh(gmsh.model, comm, 0, 2)

    def on_circle(centre_y, lower):
        def select(x):
            radius = np.hypot(x[0], x[1] - centre_y)
            side = x[1] <= centre_y + 1e-9 if lower else x[1] >= centre_y - 1e-9
            return np.isclose(radius, RADIUS, rtol=1e-9) & side

        return select

    selectors = {DISK_CONTACT: on_circle(RADIUS, True), DISK_FREE: on_circle(RADIUS, False)}
    if pair:
        selectors.update({4: on_circle(-RADIUS, False), 5: on_circle(-RADIUS, True)})
    if half:
        selectors[SYMMETRY] = OnPlane([0.0, 0.0], [1.0, 0.0])
    return mesh, cell_tags, tag_facets(mesh, selectors)
