"""The explicit steps' contact force from operators on Gamma_C's quadrature points
(docs/method.md section 12): the assembled force terms to round-off, and the same
histories as with the assembly at each step."""

import numpy as np
import pytest
import ufl
from dolfinx import fem
from dolfinx import mesh as dmesh
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc

from nitsche_dolfinx import ContactProblem, Material, ParameterError, Simulation
from nitsche_dolfinx.cases import bar_problem, impact_problem
from nitsche_dolfinx.common import TimeStepping, compat
from nitsche_dolfinx.contact import QuadratureContact, positive_part
from nitsche_dolfinx.physics import SphereObstacle
from nitsche_dolfinx.steppers import ExplicitStepper, VerletScheme


def pressed(problem, depth: float) -> fem.Function:
    """A smooth displacement that pushes the body ``depth`` against its obstacle (along
    -e_gdim, the obstacles of the cases lying below), so that part of Gamma_C is in
    contact and part is not."""
    u = fem.Function(problem.V)
    gdim = problem.gdim

    def values(x):
        wave = 0.1 * np.sin(x[0] + 2.0) * np.cos(x[1] if gdim > 1 else x[0])
        field = np.tile(wave, (gdim, 1))
        field[gdim - 1] -= depth
        return field

    u.interpolate(values)
    return u


def assembled_and_quadrature(problem, u):
    """The force terms of the problem's contacts at ``u``, assembled and from
    :class:`QuadratureContact`, as two ghost-updated vectors."""
    test = ufl.TestFunction(problem.V)
    terms = sum(c.force_terms(u, None, positive_part(c.projection(u)), test)
                for c in problem.contacts)  # fmt: skip
    assembled, quadrature = compat.create_vector(problem.V), compat.create_vector(problem.V)
    for vector in (assembled, quadrature):
        with vector.localForm() as local:
            local.set(0.0)
    fem_petsc.assemble_vector(assembled, fem.form(terms))
    operator = QuadratureContact(problem, problem.contacts, u)
    with quadrature.localForm() as local:
        operator.subtract(local.array)
    for vector in (assembled, quadrature):
        vector.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    quadrature.scale(-1.0)  # (owned entries: after the ghosts' sums)
    operator.destroy()
    return assembled, quadrature


@pytest.mark.mpi
@pytest.mark.parametrize(
    "dim, degree, theta", [(2, 1, 1.0), (2, 2, 0.0), (3, 1, -1.0), (3, 2, 1.0), (3, 2, 0.0)]
)
def test_the_quadrature_force_is_the_assembled_one(dim, degree, theta):
    """The disk and the ball, P1 on straight cells and P2 on curved ones, symmetric and
    not (B != C for Theta != 1), part of Gamma_C pressed in: B^T (omega [C u - g]_+) is
    the assembled int (1/gamma_h) [P_gamma(u)]_+ P_Thgamma(v) to round-off (measured
    below 1e-15 of its largest entry), on one rank and on several."""
    problem = impact_problem(dim=dim, mesh_size=8.0 if dim == 2 else 4.0, degree=degree,
                             geometry_order=degree, nitsche_theta=theta)  # fmt: skip
    assembled, quadrature = assembled_and_quadrature(problem, pressed(problem, 1.0))
    scale = assembled.norm(PETSc.NormType.INFINITY)
    assert scale > 0.0
    quadrature.axpy(-1.0, assembled)
    # two computations of one vector: 1e-9 of its largest entry, on any processor
    assert quadrature.norm(PETSc.NormType.INFINITY) <= 1e-9 * scale


@pytest.mark.mpi
def test_the_quadrature_force_of_the_bar_is_the_assembled_one():
    """The bar's wall (Gamma_C a point; on two ranks, on one of them only)."""
    problem = bar_problem(nx=20, gamma0=0.2, nitsche_theta=0.0)
    assembled, quadrature = assembled_and_quadrature(problem, pressed(problem, 0.3))
    scale = assembled.norm(PETSc.NormType.INFINITY)
    assert scale > 0.0
    quadrature.axpy(-1.0, assembled)
    # two computations of one vector: 1e-9 of its largest entry, on any processor
    assert quadrature.norm(PETSc.NormType.INFINITY) <= 1e-9 * scale


@pytest.mark.mpi
@pytest.mark.parametrize("cell", ["quadrilateral", "hexahedron"])
@pytest.mark.parametrize("degree", [1, 2])
def test_the_quadrature_force_on_quadrilaterals_and_hexahedra(cell, degree):
    """A unit square or cube of quadrilaterals or hexahedra on a rigid circle or sphere
    (Theta = 0): the assembled force terms to round-off (measured 6e-15)."""
    comm = MPI.COMM_WORLD
    if cell == "quadrilateral":
        mesh = dmesh.create_unit_square(comm, 6, 5, dmesh.CellType.quadrilateral)
    else:
        mesh = dmesh.create_unit_cube(comm, 3, 3, 4, dmesh.CellType.hexahedron)
    tdim = mesh.topology.dim
    bottom = dmesh.locate_entities_boundary(mesh, tdim - 1, lambda x: np.isclose(x[tdim - 1], 0))
    bottom = np.sort(bottom).astype(np.int32)
    tags = dmesh.meshtags(mesh, tdim - 1, bottom, np.full(bottom.size, 1, dtype=np.int32))
    problem = ContactProblem(mesh, tags, Material(E=1.0, nu=0.3, rho=1.0), degree=degree,
                             gamma0=1.0, nitsche_theta=0.0)  # fmt: skip
    problem.add_obstacle(SphereObstacle([0.5] * (tdim - 1) + [-3.0], 3.0), 1)
    assembled, quadrature = assembled_and_quadrature(problem, pressed(problem, 0.05))
    scale = assembled.norm(PETSc.NormType.INFINITY)
    assert scale > 0.0
    quadrature.axpy(-1.0, assembled)
    # two computations of one vector: 1e-9 of its largest entry, on any processor
    assert quadrature.norm(PETSc.NormType.INFINITY) <= 1e-9 * scale


COLUMNS = ["t", "energy", "energy_theta", "kinetic", "elastic", "contact_force",
           "penetration_max"]  # fmt: skip


def history(problem, contact_force: str, steps: int) -> dict[str, np.ndarray]:
    """``steps`` Verlet steps at the automatic step, the force terms by ``contact_force``."""
    dt = Simulation(problem, VerletScheme(), dt="auto", t_end=1.0).dt
    stepper = ExplicitStepper(problem, VerletScheme(), TimeStepping(dt, steps * dt),
                              contact_force=contact_force)  # fmt: skip
    rows = [stepper.state(COLUMNS)]
    while not stepper.finished:
        stepper.step()
        rows.append(stepper.state(COLUMNS))
    return {name: np.array([row[name] for row in rows]) for name in COLUMNS}


@pytest.mark.mpi
@pytest.mark.parametrize(
    "case, steps",
    [("disk P2 lumped", 400), ("bar P1 redistributed, Theta 0", 1500)],
)
def test_the_histories_by_quadrature_and_by_forms_agree(case, steps):
    """The disk through its impact (P2, the HRZ mass) and the bar through two impacts
    (P1, its massless contact node in equilibrium, Theta = 0), on all ranks: each column
    as with the force terms assembled at each step on one rank, to round-off (measured
    below 1e-13 of the column's largest value, serially and on two ranks; compared to 1e-9)."""
    make = {
        "disk P2 lumped": lambda comm: impact_problem(dim=2, mesh_size=8.0, mass="lumped",
                                                      comm=comm),
        "bar P1 redistributed, Theta 0": lambda comm: bar_problem(
            nx=40, gamma0=0.2, nitsche_theta=0.0, mass="redistributed", comm=comm
        ),
    }[case]  # fmt: skip
    quadrature = history(make(MPI.COMM_WORLD), "quadrature", steps)
    forms = history(make(MPI.COMM_SELF), "forms", steps)
    assert forms["contact_force"].max() > 0
    for name in COLUMNS:
        scale = np.abs(forms[name]).max()  # other terms, other ranks: 1e-9 of the column
        assert np.abs(quadrature[name] - forms[name]).max() <= 1e-9 * scale, name


def test_an_unknown_contact_force_is_refused():
    problem = bar_problem(nx=10, mass="lumped")
    with pytest.raises(ParameterError, match="unknown contact force; choose one of quadrature"):
        ExplicitStepper(problem, VerletScheme(), TimeStepping(1e-3, 1e-2), contact_force="x")
