"""The SNES wrapper on a nonlinear problem with a known solution, serially and under MPI."""

import numpy as np
import pytest
import ufl
from dolfinx import fem, mesh
from mpi4py import MPI

from nitsche_dolfinx import SNESSolver, SolverError
from nitsche_dolfinx.common import compat


def _nonlinear_poisson(comm):
    """-div((1 + u^2) grad u) = f with exact solution u = 1 + x + 2y (in P1: recovered exactly)."""
    msh = mesh.create_unit_square(comm, 8, 8)
    V = compat.function_space(msh, "Lagrange", 1)
    x = ufl.SpatialCoordinate(msh)
    u_exact = 1 + x[0] + 2 * x[1]
    f = -ufl.div((1 + u_exact**2) * ufl.grad(u_exact))
    u, v = fem.Function(V), ufl.TestFunction(V)
    F = ufl.inner((1 + u**2) * ufl.grad(u), ufl.grad(v)) * ufl.dx - f * v * ufl.dx
    msh.topology.create_connectivity(1, 2)
    facets = mesh.locate_entities_boundary(msh, 1, lambda x: np.full(x.shape[1], True))
    g = fem.Function(V)
    g.interpolate(lambda x: 1 + x[0] + 2 * x[1])
    bc = fem.dirichletbc(g, fem.locate_dofs_topological(V, 1, facets))
    error = fem.form((u - u_exact) ** 2 * ufl.dx)
    return F, u, [bc], error


@pytest.mark.mpi
def test_snes_recovers_exact_solution():
    F, u, bcs, error = _nonlinear_poisson(MPI.COMM_WORLD)
    solver = SNESSolver(F, u, bcs)
    iterations = solver.solve()
    assert 2 <= iterations <= 10  # genuinely nonlinear, and Newton converges fast
    comm = MPI.COMM_WORLD
    l2 = np.sqrt(comm.allreduce(fem.assemble_scalar(error), op=MPI.SUM))
    assert l2 < 1e-9 * 4.0  # Newton's solution against exact: 1e-9 of u's scale, max u = 4
    solver.destroy()


@pytest.mark.mpi
def test_snes_failure_names_reason_and_residual():
    F, u, bcs, _ = _nonlinear_poisson(MPI.COMM_WORLD)
    solver = SNESSolver(
        F, u, bcs, petsc_options={"snes_max_it": 1, "snes_rtol": 1e-14, "snes_atol": 1e-300}
    )
    with pytest.raises(SolverError) as info:
        solver.solve()
    message = str(info.value)
    assert "DIVERGED_MAX_IT" in message
    assert "residual norm" in message
    assert info.value.reason < 0 and info.value.iterations == 1
    assert info.value.residual_norm > 0
    solver.destroy()


def test_petsc_options_prefix_overrides_defaults():
    from petsc4py import PETSc

    F, u, bcs, _ = _nonlinear_poisson(MPI.COMM_SELF)
    PETSc.Options()["mytest_snes_max_it"] = 1
    try:
        solver = SNESSolver(F, u, bcs, options_prefix="mytest_")
        assert solver.snes.getTolerances()[3] == 1
        solver.destroy()
    finally:
        PETSc.Options().delValue("mytest_snes_max_it")
    solver = SNESSolver(F, u, bcs, petsc_options={"snes_max_it": 7})
    assert solver.snes.getTolerances()[3] == 7
    assert solver.snes.getKSP().getPC().getType() == "lu"
    solver.destroy()


@pytest.mark.mpi
@pytest.mark.parametrize("scheme", ["hybrid", "theta", "newmark"])
def test_cell_residual_at_zero_by_products_equals_its_assembly(scheme):
    """F_cell(0) as products of dF_cell/ds with the state s = (u, v, a) is the cell
    residual assembled at w = 0, for random states, with a time step and a load that
    changes in time (the loads are assembled again only when their constants change)."""
    from dolfinx.fem import petsc as fem_petsc
    from petsc4py import PETSc

    from nitsche_dolfinx import make_scheme
    from nitsche_dolfinx.assembly import CellResidualAtZero, split_cell_integrals
    from nitsche_dolfinx.cases import impact_problem

    problem = impact_problem(dim=2, mesh_size=8.0, comm=MPI.COMM_WORLD)
    problem.add_body_force(lambda t: [t, 0.0])
    V = problem.V
    w, u, v, a = (fem.Function(V) for _ in range(4))
    dt = fem.Constant(problem.mesh, 0.1)
    F = make_scheme(scheme).residual(problem, w, u, v, a, dt, ufl.TestFunction(V))
    F_cell, _ = split_cell_integrals(F)
    at_zero = CellResidualAtZero(F_cell, w, (u, v, a), "baij")
    assert u in at_zero.functions and v in at_zero.functions  # not in the assembled rest
    rng = np.random.default_rng(MPI.COMM_WORLD.rank)
    products, assembled = compat.create_vector(V), compat.create_vector(V)
    for t in (0.0, 0.0, 1.0):
        problem.set_time(t)
        for function in (u, v, a):
            function.x.array[:] = rng.standard_normal(function.x.array.size)
            function.x.scatter_forward()
        at_zero.assemble(products)
        with assembled.localForm() as local:
            local.set(0.0)
        fem_petsc.assemble_vector(assembled, fem.form(F_cell))  # w = 0
        assembled.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        difference = products.copy()
        difference.axpy(-1.0, assembled)
        assert difference.norm() <= 1e-9 * assembled.norm()  # two computations: 1e-9 of it
        assert assembled.norm() > 0.0


@pytest.mark.mpi
def test_jacobian_summed_by_rows_is_the_assembled_jacobian(monkeypatch):
    """In contact the Jacobian K_bc + B is summed again on B's rows only: at iterates whose
    contact sets differ, it equals the Jacobian form assembled at that iterate."""
    from dolfinx.fem import petsc as fem_petsc
    from petsc4py import PETSc

    from nitsche_dolfinx import HybridScheme, Simulation
    from nitsche_dolfinx.assembly import jacobian_sum
    from nitsche_dolfinx.cases import impact_problem

    monkeypatch.setattr(jacobian_sum, "SUM_IN_FULL_BELOW", 0)  # by rows, however small

    problem = impact_problem(dim=2, mesh_size=8.0, comm=MPI.COMM_WORLD)
    simulation = Simulation(problem, HybridScheme(), dt=0.1, t_end=12.0, linear_solver="cg-jacobi")
    for _ in range(105):  # in contact from t = 10
        simulation.step()
    solver = simulation.solver
    w = compat.petsc_vector(solver.u)
    A = solver.snes.getJacobian()[0]
    for scale in (1.0, 1.5, 0.5, 1.0):
        x = w.copy()
        x.scale(scale)  # other contact sets: B's rows change
        solver.snes.computeJacobian(x, A)
        direct = fem_petsc.assemble_matrix(solver.system.J_forms.form)
        direct.assemble()
        difference = A.convert("aij", PETSc.Mat())
        difference.axpy(-1.0, direct, PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
        assert difference.norm() <= 1e-9 * direct.norm()  # summed against assembled: 1e-9
    assert solver.petsc.jacobian_updates >= 3
