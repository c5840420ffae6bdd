"""One unit test per shim of nitsche_dolfinx.common.compat, on whichever dolfinx runs the suite."""

import numpy as np
import pytest
import ufl
from dolfinx import fem, mesh
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc

from nitsche_dolfinx.common import compat


@pytest.fixture
def square():
    return mesh.create_unit_square(MPI.COMM_WORLD, 4, 4)


def test_trapezoid():
    x = np.linspace(0, 1, 101)
    assert compat.trapezoid(x**2, x) == pytest.approx(1 / 3, abs=1e-4)


@pytest.mark.parametrize("shape", [(), (2,)])
def test_function_space_shape(square, shape):
    V = compat.function_space(square, "Lagrange", 2, shape)
    u = fem.Function(V)
    assert u.ufl_shape == shape
    bs = V.dofmap.index_map_bs
    assert bs == (shape[0] if shape else 1)
    # P2 on 4x4 triangles: 81 vertices + 208 edges = 81 + ... globally 9*9 nodes of the P2 grid
    assert V.dofmap.index_map.size_global == 81


def test_petsc_vector_shares_memory(square):
    u = fem.Function(compat.function_space(square, "Lagrange", 1))
    vec = compat.petsc_vector(u)
    vec.set(3.0)
    assert np.allclose(u.x.array[: V_local(u)], 3.0)
    u.x.array[:] = 5.0
    assert np.allclose(vec.array_r, 5.0)


def V_local(u):
    V = u.function_space
    return V.dofmap.index_map.size_local * V.dofmap.index_map_bs


def test_create_vector(square):
    V = compat.function_space(square, "Lagrange", 1, (2,))
    b = compat.create_vector(V)
    assert b.getSize() == 2 * 25
    assert b.getLocalSize() == V_local(fem.Function(V))


def test_apply_lifting_and_set_bc(square):
    """Lifting with x0 and alpha = -1 puts x - g on the Dirichlet rows, as SNES needs."""
    V = compat.function_space(square, "Lagrange", 1)
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    a = fem.form(ufl.inner(ufl.grad(u), ufl.grad(v)) * ufl.dx)
    L = fem.form(fem.Constant(square, 0.0) * v * ufl.dx)
    square.topology.create_connectivity(1, 2)
    facets = mesh.locate_entities_boundary(square, 1, lambda x: np.isclose(x[0], 0.0))
    dofs = fem.locate_dofs_topological(V, 1, facets)
    g = fem.Function(V)
    g.x.array[:] = 2.0
    bc = fem.dirichletbc(g, dofs)
    x = fem.Function(V)
    x.x.array[:] = 0.5
    b = compat.create_vector(V)
    with b.localForm() as b_local:
        b_local.set(0.0)
    fem.petsc.assemble_vector(b, L)
    compat.apply_lifting(b, a, [bc], compat.petsc_vector(x), -1.0)
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    compat.set_bc(b, [bc], compat.petsc_vector(x), -1.0)
    owned = dofs[dofs < V.dofmap.index_map.size_local]
    assert np.allclose(b.array_r[owned], 0.5 - 2.0)
    # the lifted residual is A (g - x) with the sign flipped, i.e. non-zero next to the boundary
    total = b.sum()
    assert total != pytest.approx(0.0)


def test_divergence_tolerance():
    snes = PETSc.SNES().create(MPI.COMM_SELF)
    snes.setOptionsPrefix("compat_test_")
    option = compat.divergence_tolerance(snes, 1e300)
    for key, value in option.items():  # no setter: through the options database
        PETSc.Options()[f"compat_test_{key}"] = value
    snes.setFromOptions()
    if hasattr(snes, "getDivergenceTolerance"):
        assert snes.getDivergenceTolerance() == pytest.approx(1e300)
    for key in option:
        PETSc.Options().delValue(f"compat_test_{key}")
    snes.destroy()


def test_solvers_leave_the_options_database_as_they_found_it():
    """PETSc 3.18 holds at most 512 options: a suite, or a parameter sweep, that builds
    hundreds of solvers must not leave entries behind (it did: one per solver)."""
    from nitsche_dolfinx import HybridScheme
    from nitsche_dolfinx.cases import bar_simulation

    before = PETSc.Options().getAll()
    bar_simulation(HybridScheme(), nx=10, t_end=0.03).run()
    assert PETSc.Options().getAll() == before


def test_expression_interpolation(square):
    V = compat.function_space(square, "Lagrange", 2)
    x = ufl.SpatialCoordinate(square)
    f = fem.Function(V)
    f.interpolate(compat.expression(x[0] ** 2 + x[1], V))
    points = compat.interpolation_points(V)
    assert points.shape[1] == 2
    g = fem.Function(V)
    g.interpolate(lambda x: x[0] ** 2 + x[1])
    assert np.allclose(f.x.array, g.x.array)


def test_dofmaps_and_geometry(square):
    V = compat.function_space(square, "DG", 0)
    dofs = compat.dofmap_array(V)
    num_cells = square.topology.index_map(2).size_local + square.topology.index_map(2).num_ghosts
    assert dofs.shape == (num_cells, 1)
    geometry = compat.geometry_dofmap(square)
    assert geometry.shape == (num_cells, 3)
    assert compat.geometry_degree(square) == 1
    assert compat.cell_name(square) == "triangle"


def _gmsh_disk(order):
    import gmsh

    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("disk")
    if MPI.COMM_WORLD.rank == 0:
        disk = gmsh.model.occ.addDisk(0, 0, 0, 1, 1)
        gmsh.model.occ.synchronize()
        gmsh.model.addPhysicalGroup(2, [disk], 7)
        curves = [c[1] for c in gmsh.model.getBoundary([(2, disk)], oriented=False)]
        gmsh.model.addPhysicalGroup(1, curves, 3)
        gmsh.option.setNumber("Mesh.CharacteristicLengthMax", 0.4)
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.setOrder(order)
    return gmsh


@pytest.mark.parametrize("order", [1, 2])
def test_gmsh_model_to_mesh(order):
    gmsh = _gmsh_disk(order)
    try:
        msh, cell_tags, facet_tags = compat.gmsh_model_to_mesh(gmsh.model, MPI.COMM_WORLD, 0, 2)
    finally:
        gmsh.finalize()
    assert compat.geometry_degree(msh) == order
    comm = msh.comm
    assert comm.allreduce(np.count_nonzero(cell_tags.values == 7), op=MPI.SUM) > 0
    assert set(comm.allreduce(facet_tags.values.tolist(), op=MPI.SUM)) == {3}
    area = comm.allreduce(
        fem.assemble_scalar(fem.form(fem.Constant(msh, 1.0) * ufl.dx)), op=MPI.SUM
    )
    assert area == pytest.approx(np.pi, rel=0.05 if order == 1 else 2e-3)


@pytest.mark.mpi
def test_xdmf_meshtags_roundtrip(mpi_tmp_path):
    from dolfinx.io import XDMFFile

    comm = MPI.COMM_WORLD
    msh = mesh.create_unit_square(comm, 3, 3)
    msh.name = "mesh"
    msh.topology.create_connectivity(1, 2)
    facets = mesh.locate_entities_boundary(msh, 1, lambda x: np.isclose(x[1], 0.0))
    tags = mesh.meshtags(msh, 1, facets, np.full(len(facets), 5, dtype=np.int32))
    tags.name = "facets"
    path = f"{mpi_tmp_path}/tags.xdmf"
    with XDMFFile(comm, path, "w") as xdmf:
        xdmf.write_mesh(msh)
        compat.write_meshtags(xdmf, tags, msh)
    with XDMFFile(comm, path, "r") as xdmf:
        msh2 = xdmf.read_mesh(name="mesh")
        msh2.topology.create_connectivity(1, 2)
        tags2 = xdmf.read_meshtags(msh2, "facets")
    assert comm.allreduce(np.count_nonzero(tags2.values == 5), op=MPI.SUM) >= 3


def test_mixed_function_space_and_collapse(square):
    W = compat.mixed_function_space(square, [("Lagrange", 2, (2,)), ("Lagrange", 1, ())])
    V, dofs = compat.collapse(W.sub(0))
    Q, multiplier_dofs = compat.collapse(W.sub(1))
    assert dofs.ndim == 1 and multiplier_dofs.ndim == 1

    def local(S):
        index_map = S.dofmap.index_map
        return (index_map.size_local + index_map.num_ghosts) * S.dofmap.index_map_bs

    assert len(dofs) == local(V) and len(multiplier_dofs) == local(Q)
    assert len(np.intersect1d(dofs, multiplier_dofs)) == 0
    assert len(dofs) + len(multiplier_dofs) == local(W)


COMPILE_A_NEW_FORM = """
import random
import ufl
from dolfinx import fem, mesh
from mpi4py import MPI
import nitsche_dolfinx
m = mesh.create_unit_square(MPI.COMM_SELF, 2, 2)
x = ufl.SpatialCoordinate(m)
fem.form(ufl.sin({c!r} * x[0]) * ufl.dx(domain=m))
"""


def test_form_compilation_is_quiet():
    """No compiler lines on the terminal when a form is compiled (dolfinx 0.5 logs pages of
    them); NITSCHE_DOLFINX_VERBOSE brings them back where the JIT prints them."""
    import random
    import subprocess
    import sys

    code = COMPILE_A_NEW_FORM.format(c=random.random())
    quiet = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert quiet.returncode == 0, quiet.stderr
    assert "INFO:root" not in quiet.stderr and "gcc" not in quiet.stderr


@pytest.mark.mpi
def test_form_on_facets_is_the_form_compiled_on_them():
    """A compiled form moved to other facets (its kernels used again) assembles to the
    bit what the form compiled on those facets does: two subdomain ids, one of them
    without facets, and no facets at all, on every rank (the move may be collective)."""
    cube = mesh.create_unit_cube(MPI.COMM_WORLD, 3, 3, 3)
    dim = cube.topology.dim - 1
    cube.topology.create_connectivity(dim, dim + 1)
    facets = mesh.locate_entities_boundary(
        cube, dim, lambda x: np.isclose(x[2], 0.0) | np.isclose(x[0], 1.0)
    )
    bottom = np.isclose(mesh.compute_midpoints(cube, dim, facets)[:, 2], 0.0)
    ids = np.where(bottom, 3, 5).astype(np.int32)
    ds = ufl.Measure("ds", domain=cube, subdomain_data=mesh.meshtags(cube, dim, facets, ids))
    V = compat.function_space(cube, "Lagrange", 2, (3,))
    u, v, w = ufl.TrialFunction(V), ufl.TestFunction(V), fem.Function(V)
    w.interpolate(lambda x: np.stack([x[0], x[1] ** 2, x[2]]))
    c = fem.Constant(cube, 2.0)
    form = c * (1 + ufl.inner(w, w)) * ufl.inner(u, v) * ds(3) + ufl.inner(
        ufl.grad(u), ufl.grad(v)
    ) * ds(5)
    compiled = fem.form(form)

    def assembled(a):
        A = compat.create_matrix(compiled)  # every entry of the form on all facets
        fem_petsc.assemble_matrix(A, a)
        A.assemble()
        return A

    for chosen in (np.arange(len(facets)) % 2 == 0, ~bottom, np.zeros(len(facets), bool)):
        tags = mesh.meshtags(cube, dim, facets[chosen], ids[chosen])
        there = ufl.Form([i.reconstruct(subdomain_data=tags) for i in form.integrals()])
        moved = assembled(compat.form_on_facets(compiled, form, facets[chosen], ids[chosen]))
        reference = assembled(fem.form(there))
        whole = cube.comm.allreduce(int(chosen.sum()), op=MPI.SUM)
        assert (reference.norm() > 0) == (whole > 0)
        assert moved.equal(reference)  # the same kernels on the same facets: bitwise
