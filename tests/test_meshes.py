"""Loading meshes with facet tags: the shipped .msh file, XDMF, and bad files."""

import os

import numpy as np
import pytest
import ufl
from dolfinx import fem
from mpi4py import MPI

from nitsche_dolfinx.meshing import load_mesh, save_mesh
from nitsche_dolfinx.output import assemble_global

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RING = os.path.join(REPO, "meshes", "ring_2d.msh")


def boundary_length(mesh, tags, tag):
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=tags)
    return assemble_global(fem.form(fem.Constant(mesh, 1.0) * ds(tag)), mesh.comm)


@pytest.mark.mpi
def test_shipped_ring_mesh_and_its_facet_tags():
    mesh, tags = load_mesh(RING)
    comm = mesh.comm
    assert mesh.geometry.dim == 2 and mesh.topology.dim == 2
    assert set(comm.allreduce(tags.values.tolist(), op=MPI.SUM)) == {1, 2, 3}
    # contact: lower half of the outer circle; outer top: upper half; inner circle
    assert boundary_length(mesh, tags, 1) == pytest.approx(np.pi * 1.0, rel=0.01)
    assert boundary_length(mesh, tags, 2) == pytest.approx(np.pi * 1.0, rel=0.01)
    # the mean height of a half circle of radius 1 centred at y = 1.1 is 1.1 -+ 2/pi
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=tags)
    y = ufl.SpatialCoordinate(mesh)[1]
    for tag, sign in ((1, -1), (2, 1)):
        mean = assemble_global(fem.form(y * ds(tag)), comm) / boundary_length(mesh, tags, tag)
        assert mean == pytest.approx(1.1 + sign * 2 / np.pi, abs=0.01)


@pytest.mark.mpi
def test_xdmf_roundtrip(mpi_tmp_path):
    mesh, tags = load_mesh(RING)
    path = os.path.join(mpi_tmp_path, "ring.xdmf")
    save_mesh(path, mesh, tags)
    mesh2, tags2 = load_mesh(path)
    for tag in (1, 2, 3):
        assert boundary_length(mesh2, tags2, tag) == pytest.approx(boundary_length(mesh, tags, tag))


@pytest.mark.parametrize(
    "content, message", [(None, "does not exist"), ("not a mesh", "cannot be read")]
)
def test_bad_mesh_file_is_named(tmp_path, content, message):
    path = tmp_path / "bad.msh"
    if content is not None:
        path.write_text(content)
    with pytest.raises(ValueError, match=message) as info:
        load_mesh(str(path))
    assert "bad.msh" in str(info.value)


def test_xdmf_mesh_of_another_dimension_is_refused(tmp_path):
    mesh, tags = load_mesh(RING, gdim=2)
    path = str(tmp_path / "ring.xdmf")
    save_mesh(path, mesh, tags)
    with pytest.raises(ValueError, match=r"holds 2D coordinates, not gdim=3"):
        load_mesh(path, gdim=3)


# -- facets tagged by selectors (meshes without physical groups) -----------------------------


@pytest.mark.mpi
def test_tag_facets_by_plane_normal_box_and_function():
    """On the unit cube (3 x 3 x 3), the faces and parts of faces each selector chooses
    have the areas of the geometry, on any partition; later selectors win a facet."""
    from dolfinx import mesh as dmesh

    from nitsche_dolfinx.meshing import InBox, NormalWithin, OnPlane, tag_facets

    mesh = dmesh.create_unit_cube(MPI.COMM_WORLD, 3, 3, 3)
    selectors = {
        1: OnPlane([0.0, 0.0, 0.0], [0.0, 0.0, 2.0]),  # the bottom z = 0
        2: NormalWithin([1.0, 0.0, 0.2], 15.0),  # the face x = 1 (11.3 degrees away)
        3: [NormalWithin([0.0, 1.0, 0.0], 1.0), lambda x: x[0] <= 1 / 3 + 1e-12],  # y = 1, x < 1/3
        4: InBox([0.0, 0.0, 2 / 3], [1.0, 1.0, 1.0]),  # every facet with z >= 2/3
    }
    tags = tag_facets(mesh, selectors)
    area = {tag: boundary_length(mesh, tags, tag) for tag in selectors}
    assert area[1] == pytest.approx(1.0)
    assert area[2] == pytest.approx(2 / 3)  # its top third went to tag 4
    assert area[3] == pytest.approx(2 / 9)
    assert area[4] == pytest.approx(1 + 4 / 3)  # the top, the sides' top thirds


@pytest.mark.mpi
def test_tag_facets_keeps_the_tags_of_the_file():
    """New tags on the ring of the gmsh file: the facets of its lower half whose normal
    points down within 30 degrees take tag 7 (a sixth of the outer circle, to one of its
    56 edges, taken from tag 1); the others keep theirs."""
    from nitsche_dolfinx.meshing import NormalWithin, tag_facets

    mesh, tags = load_mesh(RING)
    lengths = {tag: boundary_length(mesh, tags, tag) for tag in (1, 2, 3)}
    lower = lambda x: x[1] < 1.1  # noqa: E731 (the centre of the ring is at y = 1.1)
    tagged = tag_facets(mesh, {7: [NormalWithin([0.0, -1.0], 30.0), lower]}, tags)
    assert boundary_length(mesh, tagged, 7) == pytest.approx(2 * np.pi / 6, abs=2 * np.pi / 56)
    assert boundary_length(mesh, tagged, 1) + boundary_length(mesh, tagged, 7) == pytest.approx(
        lengths[1]
    )
    for tag in (2, 3):
        assert boundary_length(mesh, tagged, tag) == pytest.approx(lengths[tag])
