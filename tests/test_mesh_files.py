"""Mesh files dolfinx cannot make a mesh of, each refused in one line naming the file and
what is wrong with it, on every rank and before any collective work (never a hang under
mpirun): through the API (``load_mesh``) and the command line (``[mesh] file = ...``).

The ``.msh`` files are written here in gmsh's 2.2 text format, each a unit square (or a
tetrahedron) with one defect; the same square without it is read correctly."""

import os

import pytest
import ufl
from dolfinx import fem
from mpi4py import MPI
from runs import MPIRUN, assert_one_line_error, ring_config, run

from nitsche_dolfinx.meshing import load_mesh, save_mesh
from nitsche_dolfinx.output import assemble_global

SQUARE = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
TETRAHEDRON = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]


def msh2(nodes, elements, tags=None) -> str:
    """A gmsh 2.2 text file: ``nodes`` [(x, y, z)] numbered from 1 (or ``tags``), and
    ``elements`` [(gmsh type, physical group (0: none), entity, node numbers)]."""
    tags = tags or range(1, len(nodes) + 1)
    lines = ["$MeshFormat", "2.2 0 8", "$EndMeshFormat", "$Nodes", str(len(nodes))]
    lines += [f"{tag} {x} {y} {z}" for tag, (x, y, z) in zip(tags, nodes)]
    lines += ["$EndNodes", "$Elements", str(len(elements))]
    for number, (kind, group, entity, element_nodes) in enumerate(elements, 1):
        lines.append(f"{number} {kind} 2 {group} {entity} " + " ".join(map(str, element_nodes)))
    return "\n".join([*lines, "$EndElements"]) + "\n"


def square(cells: int = 7, bottom: int = 1, others: int = 2, numbers=(1, 2, 3, 4)) -> str:
    """Two triangles (gmsh type 2) in the physical group ``cells``; the edge y = 0 in
    ``bottom``, the other three in ``others`` (type 1); nodes numbered ``numbers``."""
    a, b, c, d = numbers
    triangles = [(2, cells, 1, (a, b, c)), (2, cells, 1, (a, c, d))]
    edges = [(1, bottom, 1, (a, b))] + [(1, others, 2, e) for e in ((b, c), (c, d), (d, a))]
    return msh2(SQUARE, triangles + edges, numbers)


#: name -> (file name, content, what the message must say after the file's name)
BAD_MSH = {
    "empty": ("empty.msh", "", "is empty"),
    "text": ("text.msh", "not a mesh\n", "cannot be read"),
    "bytes": ("bytes.msh", bytes(range(256)) * 4, "cannot be read"),
    "truncated": ("cut.msh", square()[:120], "cannot be read"),
    "no-elements": ("bare.msh", msh2(SQUARE, []), "holds no mesh (no elements)"),
    "no-physical-groups": ("plain.msh", square(0, 0, 0), "has no physical groups: dolfinx"),
    "cells-only": ("cells.msh", square(7, 0, 0), "has no physical groups on its boundary"),
    "mixed-cells": (
        "mixed.msh",
        msh2(
            [(0, 0, 0), (1, 0, 0), (2, 0, 0), (2, 1, 0), (1, 1, 0), (0, 1, 0)],
            [
                (3, 7, 1, (1, 2, 5, 6)),
                (2, 7, 1, (2, 3, 4)),
                (2, 7, 1, (2, 4, 5)),
                (1, 1, 1, (1, 2)),
                (1, 1, 1, (2, 3)),
            ],
        ),  # fmt: skip
        "has cells of type Triangle 3, Quadrilateral 4",
    ),
    "mixed-dimensions": (
        "solid.msh",
        msh2(TETRAHEDRON, [(4, 0, 1, (1, 2, 3, 4)), (2, 1, 1, (1, 2, 3))]),
        "has 3D elements in no physical group",
    ),
    "lines-in-a-plane": (
        "lines.msh",
        msh2(SQUARE, [(1, 1, 1, (1, 2)), (1, 2, 2, (2, 3)), (1, 2, 2, (3, 4))]),
        "holds 1D cells (lines) in 2D space",
    ),
    "serendipity": (
        "quad8.msh",
        msh2(
            [
                (0, 0, 0),
                (1, 0, 0),
                (1, 1, 0),
                (0, 1, 0),
                (0.5, 0, 0),
                (1, 0.5, 0),
                (0.5, 1, 0),
                (0, 0.5, 0),
            ],
            [(16, 7, 1, range(1, 9)), (8, 1, 1, (1, 2, 5))],
        ),  # fmt: skip
        "has cells of type Quadrilateral 8: dolfinx reads one type",
    ),
}


def _write(folder: str, name: str, content) -> str:
    """Write a file on rank 0 (the others wait for it): its path."""
    path = os.path.join(folder, name)
    if MPI.COMM_WORLD.rank == 0:
        with open(path, "wb" if isinstance(content, bytes) else "w") as f:
            f.write(content)
    MPI.COMM_WORLD.barrier()
    return path


def _refused_everywhere(path: str, message: str, **kwargs) -> None:
    """load_mesh raises a ValueError of one line on every rank, naming the file and
    ``message``, the same on all ranks."""
    with pytest.raises(ValueError) as caught:
        load_mesh(path, **kwargs)
    text = str(caught.value)
    assert f"mesh file {path!r}" in text and message in text, text
    assert "\n" not in text
    assert len(set(MPI.COMM_WORLD.allgather(text))) == 1


def _measure(mesh, tags, tag=None) -> float:
    one = fem.Constant(mesh, 1.0)
    if tag is None:
        return assemble_global(fem.form(one * ufl.dx(domain=mesh)), mesh.comm)
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=tags)
    return assemble_global(fem.form(one * ds(tag)), mesh.comm)


@pytest.mark.mpi
@pytest.mark.parametrize("numbers", [(1, 2, 3, 4), (1, 2, 3, 5)], ids=["nodes", "node-gaps"])
def test_the_square_without_defects_is_read(mpi_tmp_path, numbers):
    """The files of the bad cases less their defect: area 1, bottom 1, the rest 3 (gmsh
    may number nodes with gaps: they are numbered again for dolfinx)."""
    mesh, tags = load_mesh(_write(mpi_tmp_path, "square.msh", square(numbers=numbers)))
    assert mesh.geometry.dim == mesh.topology.dim == 2
    assert mesh.topology.index_map(2).size_global == 2
    # assembled measures against exact ones: 1e-9 of each
    assert _measure(mesh, tags) == pytest.approx(1.0, rel=1e-9)
    assert _measure(mesh, tags, 1) == pytest.approx(1.0, rel=1e-9)
    assert _measure(mesh, tags, 2) == pytest.approx(3.0, rel=1e-9)


@pytest.mark.mpi
@pytest.mark.parametrize("case", BAD_MSH)
def test_bad_msh_file_is_refused_on_every_rank(mpi_tmp_path, case):
    name, content, message = BAD_MSH[case]
    _refused_everywhere(_write(mpi_tmp_path, name, content), message)


@pytest.mark.mpi
def test_msh_file_without_boundary_groups_is_read_when_tags_are_not_required(mpi_tmp_path):
    path = _write(mpi_tmp_path, "cells.msh", square(7, 0, 0))
    mesh, tags = load_mesh(path, facet_tags_required=False)
    assert tags is None and _measure(mesh, None) == pytest.approx(1.0, rel=1e-9)  # assembled


@pytest.mark.mpi
def test_gdim_other_than_the_cells_is_refused(mpi_tmp_path):
    path = _write(mpi_tmp_path, "square.msh", square())
    _refused_everywhere(path, "holds 2D cells (triangles), not gdim=3", gdim=3)


@pytest.mark.mpi
def test_contact_tag_that_is_no_facet_group_is_refused(mpi_tmp_path):
    path = _write(mpi_tmp_path, "square.msh", square())
    message = "has no physical group 9 of dimension 1 (a contact surface)"
    _refused_everywhere(path, message, contact_tags=[1, 9])


def _xdmf_cases(folder: str) -> dict:
    """name -> (path, message): XDMF files of the square with one defect each."""
    mesh, tags = load_mesh(_write(folder, "square.msh", square()), comm=MPI.COMM_SELF)
    if MPI.COMM_WORLD.rank == 0:
        save_mesh(os.path.join(folder, "renamed.xdmf"), mesh, tags, mesh_name="square")
        save_mesh(os.path.join(folder, "untagged.xdmf"), mesh, tags, facet_tags_name="other")
        save_mesh(os.path.join(folder, "orphan.xdmf"), mesh, tags)
        os.remove(os.path.join(folder, "orphan.h5"))
    MPI.COMM_WORLD.barrier()
    path = {name: os.path.join(folder, name) for name in ("renamed.xdmf", "untagged.xdmf")}
    return {
        "no-mesh-grid": (path["renamed.xdmf"], "has no grid 'mesh' (its grids: 'square',"),
        "no-facet-tags": (path["untagged.xdmf"], "has no grid 'facet_tags', the facet tags"),
        "no-hdf5-file": (os.path.join(folder, "orphan.xdmf"), "orphan.h5', which does not"),
        "not-xml": (_write(folder, "text.xdmf", "not xml"), "is not an XDMF file (XML)"),
        "empty": (_write(folder, "empty.xdmf", ""), "is empty"),
        "unknown-kind": (_write(folder, "mesh.vtk", "x"), "unknown kind '.vtk' (use .msh or"),
    }


@pytest.mark.mpi
def test_bad_xdmf_files_are_refused_on_every_rank(mpi_tmp_path):
    for path, message in _xdmf_cases(mpi_tmp_path).values():
        _refused_everywhere(path, message)


@pytest.mark.mpi
def test_missing_file_and_folder_are_refused(mpi_tmp_path):
    _refused_everywhere(os.path.join(mpi_tmp_path, "missing.msh"), "does not exist")
    _refused_everywhere(mpi_tmp_path, "is a folder, not a mesh file")


# -- the command line: nitsche-dolfinx run with [mesh] file = a bad file -----------------


def _command(folder: str, name: str, content, ranks: int = 1):
    """``nitsche-dolfinx run`` of the ring's configuration with ``[mesh] file = name``."""
    config = ring_config(folder, {'"ring_2d.msh"': f'"{name}"'})
    with open(os.path.join(folder, name), "wb" if isinstance(content, bytes) else "w") as f:
        f.write(content)
    out = os.path.join(folder, "out")
    return run("-m", "nitsche_dolfinx", "run", config, "--out", out, ranks=ranks, timeout=120)


@pytest.mark.parametrize(
    "case", ["empty", "truncated", "no-physical-groups", "mixed-cells", "mixed-dimensions"]
)
def test_command_refuses_bad_msh_file_in_one_line(tmp_path, case):
    if MPI.COMM_WORLD.size > 1:
        pytest.skip("starts the command itself: run it serially")
    name, content, message = BAD_MSH[case]
    result = _command(str(tmp_path), name, content)
    assert_one_line_error(result, f"{name}' {message}")
    assert "config.toml: [mesh] mesh file '" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert not (tmp_path / "out" / "history.csv").exists()


@pytest.mark.mpi
@pytest.mark.skipif(MPIRUN is None, reason="needs mpirun")
@pytest.mark.skipif(MPI.COMM_WORLD.size > 1, reason="starts mpirun itself: run it serially")
@pytest.mark.parametrize("case", ["no-physical-groups", "mixed-cells", "no-elements"])
def test_command_under_mpirun_refuses_bad_msh_file_once(tmp_path, case):
    """Rank 0 alone reads the file: the others learn what is wrong from it, and the
    line is printed once (these files made rank 1 wait forever, or crashed dolfinx)."""
    name, content, message = BAD_MSH[case]
    result = _command(str(tmp_path), name, content, ranks=2)
    assert_one_line_error(result, f"{name}' {message}")
    assert result.stderr.count("nitsche-dolfinx: error:") == 1
    assert "aborting" not in result.stderr


def test_command_refuses_xdmf_file_that_is_not_xml(tmp_path):
    if MPI.COMM_WORLD.size > 1:
        pytest.skip("starts the command itself: run it serially")
    result = _command(str(tmp_path), "ring.xdmf", "not xml\n")
    assert_one_line_error(result, "ring.xdmf' is not an XDMF file (XML)")
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr
