"""Loading meshes with facet tags: the shipped .msh file, XDMF, and bad files."""

import os

import numpy as np
import pytest
import ufl
from dolfinx import fem
from mpi4py import MPI

from nitsche_dolfinx.diagnostics import assemble_global
from nitsche_dolfinx.meshes import load_mesh, save_mesh

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
