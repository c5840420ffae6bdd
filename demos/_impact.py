"""The impact of an elastic ball (3D) or disk (2D) on a rigid plane: what the two demos share.

``demos/ball_3d.py`` and ``demos/disk_2d.py`` tell the story; this module holds
the parts they have in common, so that each demo reads as set up, run, look:

- the command line (the flags of SPEC section 6, plus the linear solver);
- the linear solvers: direct LU (MUMPS when PETSc has it), the same factorisation
  reused as a GMRES preconditioner, or CG/GMRES with algebraic multigrid (GAMG)
  and the rigid-body near-nullspace;
- one run of the impact with a given scheme, its summary numbers, the figure
  of the energies and the picture of the deformed body, coloured by von Mises.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import time

import numpy as np
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc

from nitsche_dolfinx import HISTORY_COLUMNS, SCHEMES, Simulation, SolverError, compat, make_scheme
from nitsche_dolfinx.cases import impact_problem

#: Time of the talk's picture of the deformed ball.
PICTURE_TIME = 18.0

#: ``--linear-solver`` choices: name -> what it is.
LINEAR_SOLVERS = {
    "lu": "direct LU at every change of the Jacobian (MUMPS when PETSc has it)",
    "lu-lagged": "the last LU factorisation as a GMRES preconditioner, refreshed after 10 iterations",
    "cg-gamg": "conjugate gradients, algebraic multigrid with the rigid-body near-nullspace",
    "gmres-gamg": "GMRES, algebraic multigrid with the rigid-body near-nullspace",
}

#: The schemes of the talk's figure "Energy E^h for different methods", with their
#: parameters. Newmark is taken with beta = 1/2, gamma = 1, the only choice for which
#: the talk proves stability (the default (1/4, 1/2) would be Crank-Nicolson again).
COMPARED_SCHEMES = {
    "hybrid": {},
    "cn": {},
    "theta": {"theta": 1.0},
    "newmark": {"beta": 0.5, "gamma": 1.0},
}


# -- command line ----------------------------------------------------------------------


def finite_float(text: str) -> float:
    """A float flag; ``nan`` and ``inf`` are refused here, range checks are the library's."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not np.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text!r}")
    return value


def petsc_option(text: str) -> tuple[str, str | None]:
    """``KEY=VALUE`` (or ``KEY`` alone, for a switch such as ``ksp_monitor``) as a pair."""
    key, has_value, value = text.partition("=")
    key = key.strip().lstrip("-")
    if not key:
        raise argparse.ArgumentTypeError(f"expected KEY=VALUE, got {text!r}")
    return key, (value.strip() if has_value and value.strip() else None)


def make_parser(description: str, default_out: str) -> argparse.ArgumentParser:
    """The command-line parser of the ball and disk demos (SPEC section 6)."""
    parser = argparse.ArgumentParser(
        description=description, formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
    parser.add_argument("--scheme", choices=SCHEMES, default="hybrid", help="time scheme")
    parser.add_argument("--theta", type=finite_float, default=1.0, help="theta of the theta-scheme")
    parser.add_argument(
        "--beta", type=finite_float, default=0.5, help="Newmark beta (1/2: stable, as in the talk)"
    )
    parser.add_argument(
        "--gamma", type=finite_float, default=1.0, help="Newmark gamma (1: stable, as in the talk)"
    )
    parser.add_argument(
        "--nitsche-theta",
        type=finite_float,
        default=1.0,
        help="Nitsche variant Theta: 1 symmetric, 0 non-symmetric, -1 skew-symmetric",
    )
    parser.add_argument(
        "--gamma0", type=finite_float, default=1e-3, help="Nitsche parameter, gamma_h = gamma0 h"
    )
    parser.add_argument("--degree", type=int, default=2, help="Lagrange degree (1 or 2)")
    parser.add_argument("--mesh-size", type=finite_float, default=8.0, help="mesh size h")
    parser.add_argument("--dt", type=finite_float, default=0.1, help="time step tau")
    parser.add_argument("--t-end", type=finite_float, default=40.0, help="final time T")
    parser.add_argument(
        "--output-every",
        type=int,
        default=10,
        help="write solution.xdmf every this many steps (0: never)",
    )
    parser.add_argument("--out", default=default_out, help="output folder")
    parser.add_argument(
        "--linear-solver",
        choices=tuple(LINEAR_SOLVERS),
        default="lu",
        help="; ".join(f"{name}: {what}" for name, what in LINEAR_SOLVERS.items()),
    )
    parser.add_argument(
        "--petsc",
        type=petsc_option,
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="extra PETSc option of the step's solver, e.g. ksp_monitor or "
        "pc_gamg_threshold=0.02 (repeatable; wins over the --linear-solver settings)",
    )
    parser.add_argument("--quiet", action="store_true", help="no line per time step")
    parser.add_argument("--no-plot", action="store_true", help="no energy figure, no picture")
    parser.add_argument(
        "--compare",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="also run the other schemes of the talk's energy figure (into OUT/<scheme>)",
    )
    return parser


@contextlib.contextmanager
def one_line_errors(parser: argparse.ArgumentParser):
    """Turn a bad parameter, a Newton failure or a PETSc error into one line and exit status 2."""
    try:
        yield
    except (ValueError, SolverError, PETSc.Error) as error:
        if MPI.COMM_WORLD.rank == 0:
            message = str(error).strip().splitlines()[0] if str(error).strip() else repr(error)
            print(f"{parser.prog}: error: {message}", file=sys.stderr)
        sys.exit(2)


# -- linear solvers --------------------------------------------------------------------


def has_mumps(comm=MPI.COMM_WORLD) -> bool:
    """Whether PETSc can factorise with MUMPS, found out by trying it on a 1 x 1 matrix."""
    A = PETSc.Mat().createAIJ([1, 1], nnz=1, comm=PETSc.COMM_SELF)
    A.setValue(0, 0, 1.0)
    A.assemble()
    pc = PETSc.PC().create(PETSc.COMM_SELF)
    try:
        pc.setOperators(A)
        pc.setType("lu")
        pc.setFactorSolverType("mumps")
        pc.setUp()
        found = True
    except PETSc.Error:
        found = False
    finally:
        pc.destroy()
        A.destroy()
    return comm.allreduce(found, op=MPI.LAND)


def linear_solver(name: str, comm=MPI.COMM_WORLD) -> tuple[dict, int, str]:
    """PETSc options, preconditioner lag and a description of the linear solver ``name``.

    The library's default is Newton with one direct LU solve per iteration; only
    the factorisation package is chosen here. The Krylov solvers must be accurate
    enough for Newton to converge as with LU: relative tolerance 1e-12.
    """
    if name in ("lu", "lu-lagged"):
        mumps = has_mumps(comm)
        options = {"pc_factor_mat_solver_type": "mumps"} if mumps else {}
        package = "MUMPS" if mumps else "PETSc's own LU, serial only"
        if name == "lu":
            return options, 0, f"lu ({package})"
        return options, 10, f"lu-lagged ({package}, GMRES, lag 10)"
    krylov = name.split("-")[0]
    options = {
        "ksp_type": krylov,
        "ksp_rtol": 1e-12,
        "ksp_atol": 1e-14,
        "ksp_max_it": 1000,
        "pc_type": "gamg",
    }
    return options, 0, f"{name} (rigid-body near-nullspace)"


def rigid_body_modes(V) -> list[PETSc.Vec]:
    """The rigid motions on the vector space ``V`` as orthonormal PETSc vectors.

    gdim translations and the rotations about the coordinate axes: one in 2D,
    three in 3D. Interpolation is exact for these linear fields, also on curved cells.
    """
    gdim = V.mesh.geometry.dim

    def translation(i):
        return lambda x: np.stack([np.full(x.shape[1], float(j == i)) for j in range(gdim)])

    def zero(x):
        return np.zeros(x.shape[1])

    modes = [translation(i) for i in range(gdim)]
    if gdim == 2:
        modes.append(lambda x: np.stack((-x[1], x[0])))
    else:
        modes.append(lambda x: np.stack((-x[1], x[0], zero(x))))
        modes.append(lambda x: np.stack((zero(x), -x[2], x[1])))
        modes.append(lambda x: np.stack((x[2], zero(x), -x[0])))
    function = fem.Function(V)
    vectors = []
    for mode in modes:
        function.interpolate(mode)
        vector = compat.petsc_vector(function).copy()
        for other in vectors:  # Gram-Schmidt
            vector.axpy(-vector.dot(other), other)
        vector.normalize()
        vectors.append(vector)
    return vectors


def set_near_nullspace(simulation: Simulation) -> None:
    """Give algebraic multigrid the rigid motions as the near-nullspace of the Jacobian."""
    V = simulation.problem.V
    nullspace = PETSc.NullSpace().create(vectors=rigid_body_modes(V), comm=V.mesh.comm)
    jacobian = simulation.solver.snes.getJacobian()[0]
    jacobian.setNearNullSpace(nullspace)


# -- one run -----------------------------------------------------------------------------


def scheme_parameters(args: argparse.Namespace, name: str, compared: bool) -> dict:
    """theta, beta, gamma of the scheme ``name``: the flags, or the talk's figure's values."""
    parameters = {"theta": args.theta, "beta": args.beta, "gamma": args.gamma}
    if compared:
        parameters.update(COMPARED_SCHEMES[name])
    return parameters


def scheme_label(name: str, theta: float, beta: float, gamma: float) -> str:
    """The name of a scheme in the figure and the summary."""
    if name == "hybrid":
        return "hybrid"
    if name == "cn":
        return "Crank-Nicolson"
    if name == "theta":
        return "backward Euler" if theta == 1.0 else f"theta-scheme, theta = {theta:g}"
    return f"Newmark, beta = {beta:g}, gamma = {gamma:g}"


def impact_simulation(
    args: argparse.Namespace, dim: int, scheme_name: str, compared: bool = False
) -> Simulation:
    """The impact test (``dim`` 3: ball, 2: disk) with the flags and the scheme ``scheme_name``.

    Raises:
        ValueError: If a parameter is out of range.
    """
    if args.output_every < 0:
        raise ValueError(f"--output-every must be >= 0, got {args.output_every}")
    scheme = make_scheme(scheme_name, **scheme_parameters(args, scheme_name, compared))
    problem = impact_problem(
        dim=dim,
        mesh_size=args.mesh_size,
        degree=args.degree,
        gamma0=args.gamma0,
        nitsche_theta=args.nitsche_theta,
        comm=MPI.COMM_WORLD,
    )
    options, lag, _ = linear_solver(args.linear_solver, problem.mesh.comm)
    options.update(dict(args.petsc))
    simulation = Simulation(
        problem,
        scheme,
        dt=args.dt,
        t_end=args.t_end,
        petsc_options=options,
        progress=not (args.quiet or compared),
        preconditioner_lag=lag,
    )
    if args.linear_solver.endswith("gamg"):
        set_near_nullspace(simulation)
    return simulation


def run(
    args: argparse.Namespace,
    dim: int,
    scheme_name: str,
    out: str,
    compared: bool = False,
    output_every: int = 0,
    callback=None,
) -> dict:
    """Run the impact with the scheme ``scheme_name``, writing ``out/history.csv``.

    ``compared`` runs take the parameters of the talk's figure (:data:`COMPARED_SCHEMES`)
    instead of the scheme flags, and print no line per step.

    Returns:
        The history (a dict of column arrays) with the run's label, output folder,
        number of DOFs and time-loop wall time (max over ranks).
    """
    simulation = impact_simulation(args, dim, scheme_name, compared)
    comm = simulation.comm
    comm.barrier()
    start = time.perf_counter()
    records = simulation.run(out=out, output_every=output_every, callback=callback)
    seconds = comm.allreduce(time.perf_counter() - start, op=MPI.MAX)
    V = simulation.problem.V
    label = scheme_label(scheme_name, **scheme_parameters(args, scheme_name, compared))
    return {
        "label": f"Nitsche + {label}",
        "out": out,
        "dofs": V.dofmap.index_map.size_global * V.dofmap.index_map_bs,
        "seconds": seconds,
        **{name: np.array([record[name] for record in records]) for name in HISTORY_COLUMNS},
    }


def compared_runs(args: argparse.Namespace) -> list[str]:
    """The schemes of the energy figure other than the main run's, when comparing."""
    return [name for name in COMPARED_SCHEMES if args.compare and name != args.scheme]


# -- summary -------------------------------------------------------------------------


def measure(result: dict) -> dict:
    """The numbers of the summary for one run."""
    t, force = result["t"], result["contact_force"]
    energy, energy_theta = result["energy"], result["energy_theta"]
    touching = t[force > 0]
    return {
        "first_contact": touching[0] if touching.size else np.nan,
        "drift": energy[-1] / energy[0] - 1,
        "drift_theta": energy_theta[-1] / energy_theta[0] - 1,
        "rise_theta": np.max(np.diff(energy_theta)) / abs(energy_theta[0]),
        "penetration": np.max(result["penetration_max"]),
        "newton": np.mean(result["newton_iterations"][1:]),  # row 0 is t = 0: no solve
    }


def print_summary(results: list[dict], args: argparse.Namespace, solver: str) -> None:
    """One header line, then one line of numbers per run (rank 0)."""
    main = results[0]
    print(
        f"{main['dofs']} DOFs (P{args.degree}, h = {args.mesh_size:g}), "
        f"{len(main['t']) - 1} steps of tau = {args.dt:g} to T = {args.t_end:g}, "
        f"Theta = {args.nitsche_theta:g}, gamma0 = {args.gamma0:g}, linear solver {solver}"
    )
    header = (
        f"{'run':40s} {'1st contact':>11s} {'E(T)/E(0)-1':>12s} {'E_Th drift':>11s} "
        f"{'max dE_Th/E_Th(0)':>17s} {'max penetr.':>11s} {'Newton':>6s} {'loop (s)':>8s}"
    )
    print(header)
    for result in results:
        m = measure(result)
        print(
            f"{result['label']:40s} {m['first_contact']:11.4g} {m['drift']:+12.3e} "
            f"{m['drift_theta']:+11.3e} {m['rise_theta']:17.2e} {m['penetration']:11.3e} "
            f"{m['newton']:6.2f} {result['seconds']:8.2f}"
        )
    print(
        "(1st contact: first t with contact force > 0; drifts: relative changes over [0, T]; "
        "max dE_Th/E_Th(0): largest one-step rise of E_Theta; Newton: iterations per step)"
    )
    for result in results:
        print(f"history: {os.path.join(result['out'], 'history.csv')}")


# -- the energy figure -------------------------------------------------------------------


def latex_number(x: float) -> str:
    """``x`` for a LaTeX title: ``1e-06`` becomes ``10^{-6}``."""
    mantissa, _, exponent = f"{x:.3g}".partition("e")
    if not exponent:
        return mantissa
    power = f"10^{{{int(exponent)}}}"
    return power if mantissa == "1" else rf"{mantissa} \cdot {power}"


#: Colours of the schemes in the energy figure, as in the talk's legend order.
COLOURS = {"hybrid": "tab:blue", "cn": "tab:red", "theta": "tab:green", "newmark": "tab:orange"}


def plot_energies(
    results: list[dict], schemes: list[str], args: argparse.Namespace, body: str, path: str
) -> None:
    """The talk's "Energy E^h for different methods" (or the main run's energies alone).

    Top: E^h of every run (with one run, also E_Theta^h and the kinetic, elastic
    and gravity parts). Bottom: E^h / E^h(0) - 1 and the contact force.
    """
    try:
        import matplotlib
    except ImportError:
        print("matplotlib is not installed: no figure")
        return
    matplotlib.use("Agg")  # no display needed
    import matplotlib.pyplot as plt

    fig, (top, middle, bottom) = plt.subplots(
        3,
        1,
        figsize=(9, 9.5),
        sharex=True,
        gridspec_kw={"height_ratios": (2.2, 1.3, 1)},
        constrained_layout=True,
    )
    # the main run last, on top of the others
    order = list(range(1, len(results))) + [0]
    for i in order:
        result, colour = results[i], COLOURS[schemes[i]]
        width = 2.0 if i == 0 else 1.2
        top.plot(result["t"], result["energy"], color=colour, lw=width, label=result["label"])
        middle.plot(
            result["t"], result["energy"] / result["energy"][0] - 1, color=colour, lw=width
        )
        bottom.plot(result["t"], result["contact_force"], color=colour, lw=0.8 * width)
    main = results[0]
    if len(results) == 1:
        for name, label, style in (
            ("energy_theta", r"$E_\Theta^h$", {"color": "tab:cyan", "ls": "--"}),
            ("kinetic", "kinetic", {"color": "tab:purple", "lw": 1}),
            ("elastic", "elastic", {"color": "tab:brown", "lw": 1}),
            ("potential", "potential (gravity)", {"color": "tab:gray", "lw": 1}),
        ):
            top.plot(main["t"], main[name], label=label, **style)
        middle.plot(
            main["t"],
            main["energy_theta"] / main["energy_theta"][0] - 1,
            color="tab:cyan",
            ls="--",
        )
    top.set_ylabel("energy $E^h$")
    top.legend(loc="best", fontsize="small")
    middle.set_ylabel("$E^h / E^h(0) - 1$")
    middle.axhline(0.0, color="black", lw=0.5)
    bottom.set_ylabel("contact force")
    bottom.set_xlabel("time $t$")
    for ax in (top, middle, bottom):
        ax.grid(alpha=0.3)
    fig.suptitle(
        rf"Energy $E^h$ for different methods: {body}, Nitsche $\Theta = {args.nitsche_theta:g}$, "
        rf"$\gamma_0 = {latex_number(args.gamma0)}$, P{args.degree}, $h = {args.mesh_size:g}$, "
        rf"$\tau = {latex_number(args.dt)}$"
        if len(results) > 1
        else rf"Energies of the {body}, {main['label']}, Nitsche $\Theta = {args.nitsche_theta:g}$, "
        rf"$\gamma_0 = {latex_number(args.gamma0)}$, P{args.degree}, $\tau = {latex_number(args.dt)}$",
        fontsize="medium",
    )
    fig.savefig(path, dpi=120)
    plt.close(fig)
    print(f"figure: {path}")


# -- the picture of the deformed body ------------------------------------------------


def _vtk_mesh(V):
    """dolfinx.plot.vtk_mesh (>= 0.7), create_vtk_mesh before: (topology, cell types, points)."""
    import dolfinx.plot

    function = getattr(dolfinx.plot, "vtk_mesh", None) or dolfinx.plot.create_vtk_mesh
    return function(V)


class Snapshot:
    """A ``Simulation.run`` callback that keeps the fields at the time level closest to ``at``.

    The displacement and the von Mises stress are interpolated into the Lagrange
    space of the mesh's geometric degree and gathered on rank 0 with the cells
    (owned cells of each rank, dofs numbered globally), so that the picture of an
    MPI run is the same as a serial one.
    """

    def __init__(self, at: float = PICTURE_TIME):
        self.at = at
        self.t = None
        self.grid = None  # on rank 0: (cells, cell types, points, displacement, von Mises)

    def __call__(self, simulation: Simulation) -> None:
        if simulation.step_index != int(round(self.at / simulation.dt)):
            return
        mesh = simulation.problem.mesh
        gdim = mesh.geometry.dim
        W = compat.function_space(mesh, "Lagrange", compat.geometry_degree(mesh))
        expressions = [simulation.u[i] for i in range(gdim)] + [simulation.von_mises()]
        values = []
        for expression in expressions:
            field = fem.Function(W)
            field.interpolate(compat.expression(expression, W))
            values.append(field.x.array.copy())
        topology, cell_types, points = _vtk_mesh(W)
        index_map = W.dofmap.index_map
        owned = index_map.size_local
        global_index = np.concatenate(
            [np.arange(*index_map.local_range, dtype=np.int64), index_map.ghosts.astype(np.int64)]
        )
        cells = np.asarray(topology, dtype=np.int64).reshape(len(cell_types), -1)
        cells[:, 1:] = global_index[cells[:, 1:]]
        local = (cells, cell_types, global_index[:owned], points[:owned], np.stack(values, 1)[:owned])
        parts = mesh.comm.gather(local, root=0)
        self.t = simulation.t
        if mesh.comm.rank != 0:
            return
        size = index_map.size_global
        all_points, all_values = np.zeros((size, 3)), np.zeros((size, gdim + 1))
        for _, _, indices, part_points, part_values in parts:
            all_points[indices] = part_points
            all_values[indices] = part_values
        displacement = np.zeros((size, 3))
        displacement[:, :gdim] = all_values[:, :gdim]
        self.grid = (
            np.concatenate([p[0].reshape(-1) for p in parts]),
            np.concatenate([p[1] for p in parts]),
            all_points,
            displacement,
            all_values[:, gdim],
        )


def render_deformed(snapshot: Snapshot, dim: int, title: str, path: str) -> None:
    """Draw the deformed body coloured by von Mises into ``path`` (rank 0).

    pyvista is optional and renders off screen; if it is missing or rendering
    fails, one line says so and the demo goes on.
    """
    if snapshot.grid is None:
        print(f"no picture: the run ends before t = {snapshot.at:g}")
        return
    with _own_symbols():
        try:
            import pyvista
        except ImportError:
            print("pyvista is not installed: no picture")
            return
        try:
            _render(pyvista, snapshot, dim, title, path)
        except Exception as error:  # a picture is never worth a failed run
            print(f"no picture: rendering failed ({type(error).__name__}: {error})")
            return
    print(f"picture: {path}")


@contextlib.contextmanager
def _own_symbols():
    """Let the libraries loaded in the block bind their own symbols first (RTLD_DEEPBIND).

    dolfinx 0.5 leaves RTLD_GLOBAL in the dlopen flags after its import, so that its
    C++ template instances (std::regex among them) come first for every library
    loaded later; VTK's pip wheels, built with another C++ ABI, then crash in
    std::regex (std::bad_alloc) when they draw a colour bar.
    """
    flags = sys.getdlopenflags()
    sys.setdlopenflags(os.RTLD_NOW | getattr(os, "RTLD_DEEPBIND", 0))
    try:
        yield
    finally:
        sys.setdlopenflags(flags)


def _render(pyvista, snapshot: Snapshot, dim: int, title: str, path: str) -> None:
    with contextlib.suppress(ImportError):  # no "bad X server connection" warnings
        from vtkmodules.vtkCommonCore import vtkLogger

        vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_ERROR)
    pyvista.OFF_SCREEN = True
    cells, cell_types, points, displacement, von_mises = snapshot.grid
    grid = pyvista.UnstructuredGrid(cells, cell_types, points)
    grid.point_data["displacement"] = displacement
    grid.point_data["von Mises"] = von_mises
    deformed = grid.warp_by_vector("displacement", factor=1.0)
    # the quadratic faces, subdivided so that the curved body looks curved
    surface = _surface(deformed, 3)
    edges = _surface(deformed, 1).extract_all_edges()
    plotter = pyvista.Plotter(off_screen=True, window_size=(1200, 900))
    bar = {"title": "von Mises stress", "vertical": True, "position_x": 0.86, "position_y": 0.2}
    plotter.add_mesh(surface, scalars="von Mises", cmap="jet", scalar_bar_args=bar)
    plotter.add_mesh(edges, color="black", line_width=0.5, opacity=0.25)
    bounds = deformed.bounds
    size = 2.2 * max(bounds[1] - bounds[0], bounds[3] - bounds[2])
    if dim == 3:
        ground = pyvista.Plane(center=(0, 0, 0), direction=(0, 0, 1), i_size=size, j_size=size)
        plotter.add_mesh(ground, color="lightgray", opacity=0.6)
        plotter.camera_position = [(95.0, -110.0, 45.0), (0.0, 0.0, 16.0), (0.0, 0.0, 1.0)]
    else:
        half = size / 2
        ground = pyvista.Line((-half, 0.0, 0.0), (half, 0.0, 0.0))
        plotter.add_mesh(ground, color="black", line_width=3)
        plotter.view_xy()
    plotter.add_text(f"{title}, t = {snapshot.t:.4g}", font_size=12)
    plotter.screenshot(path)
    plotter.close()


def _surface(grid, subdivision: int):
    """The boundary of ``grid``, its quadratic faces cut ``subdivision`` times."""
    try:
        return grid.extract_surface(nonlinear_subdivision=subdivision, algorithm="dataset_surface")
    except TypeError:  # pyvista before the ``algorithm`` keyword
        return grid.extract_surface(nonlinear_subdivision=subdivision)
