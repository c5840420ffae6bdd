"""The impact of an elastic ball (3D) or disk (2D) on a rigid plane: what the two demos share.

``demos/ball_3d.py`` and ``demos/disk_2d.py`` tell the story; this module holds
the parts they have in common, so that each demo reads as set up, run, look:

- the command line (the flags of SPEC section 6, plus the linear solver and the
  checkpoint flags ``--checkpoint-every`` and ``--restart``), checked before any computing;
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
import time

import numpy as np
from dolfinx import fem
from mpi4py import MPI

from nitsche_dolfinx import HISTORY_COLUMNS, Simulation, compat, make_scheme
from nitsche_dolfinx.arguments import (
    add_method_arguments,
    add_output_every_argument,
    add_run_arguments,
    check_method_arguments,
    check_output_folder,
    finite_float,
    one_line_errors,
    petsc_option,
)
from nitsche_dolfinx.cases import impact_problem
from nitsche_dolfinx.checkpoint import CHECKPOINT_FILE
from nitsche_dolfinx.plotting import latex_number
from nitsche_dolfinx.problem import FRICTION_HISTORY_COLUMNS
from nitsche_dolfinx.solver import rigid_body_modes

#: Time of the talk's picture of the deformed ball.
PICTURE_TIME = 18.0

#: ``--linear-solver`` choices: name -> what it is.
LINEAR_SOLVERS = {
    "lu": "a direct factorisation at every change of the Jacobian (MUMPS when PETSc has "
    "it; its LDL^T when the Jacobian is symmetric: Theta = 1 without friction)",
    "lu-lagged": "the last factorisation as GMRES preconditioner, renewed past 10 iterations",
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


def make_parser(description: str, default_out: str) -> argparse.ArgumentParser:
    """The command-line parser of the ball and disk demos (SPEC section 6)."""
    parser = argparse.ArgumentParser(
        description=description, formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
    # Newmark (1/2, 1): the stable member the talk compares with
    add_method_arguments(parser, gamma0=1e-3, degree=2, dt=0.1, t_end=40.0, beta=0.5, gamma=1.0)
    parser.add_argument("--mesh-size", type=finite_float, default=8.0, help="mesh size h")
    add_output_every_argument(parser)
    parser.add_argument(
        "--mu",
        type=finite_float,
        default=None,
        help="Coulomb friction coefficient (default: frictionless); with friction the "
        "energy figure shows the main run alone",
    )
    parser.add_argument(
        "--tangential-velocity",
        type=finite_float,
        default=0.0,
        help="initial velocity along x: the body is thrown obliquely",
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
    add_run_arguments(parser)
    parser.add_argument("--quiet", action="store_true", help="no line per time step")
    parser.add_argument("--no-plot", action="store_true", help="no energy figure, no picture")
    parser.add_argument(
        "--compare",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="also run the other schemes of the talk's energy figure (into OUT/<scheme>)",
    )
    return parser


def check_arguments(args: argparse.Namespace) -> None:
    """Check every flag, and that the output folder can be written, before any computing.

    Raises:
        ValueError: Naming the first bad value.
    """
    check_method_arguments(args)
    if not args.mesh_size > 0:
        raise ValueError(f"the mesh size must be positive, got --mesh-size {args.mesh_size:g}")
    if args.mu is not None and args.mu < 0:
        raise ValueError(f"the friction coefficient must be >= 0, got --mu {args.mu:g}")
    check_output_folder(args.out)


# -- linear solvers --------------------------------------------------------------------


def linear_solver(name: str, comm=MPI.COMM_WORLD) -> tuple[dict, int, str]:
    """PETSc options, preconditioner lag and a description of the linear solver ``name``.

    The library's default is Newton with one direct LU solve per iteration; only
    the factorisation package is chosen here. The Krylov solvers must be accurate
    enough for Newton to converge as with LU: relative tolerance 1e-12.
    """
    if name in ("lu", "lu-lagged"):
        mumps = compat.has_mumps(comm)
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
) -> tuple[Simulation, str]:
    """The impact test (``dim`` 3: ball, 2: disk) with the flags and the scheme ``scheme_name``.

    Returns:
        The simulation and a description of its linear solver.

    Raises:
        ValueError: If a parameter is out of range.
    """
    scheme = make_scheme(scheme_name, **scheme_parameters(args, scheme_name, compared))
    problem = impact_problem(
        dim=dim,
        mesh_size=args.mesh_size,
        degree=args.degree,
        gamma0=args.gamma0,
        nitsche_theta=args.nitsche_theta,
        comm=MPI.COMM_WORLD,
        friction=args.mu,
        tangential_velocity=args.tangential_velocity,
    )
    options, lag, solver = linear_solver(args.linear_solver, problem.mesh.comm)
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
        simulation.solver.set_near_nullspace(rigid_body_modes(simulation.problem.V))
    return simulation, solver


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
    instead of the scheme flags, and print no line per step. With ``--restart`` the
    main run continues from ``out/checkpoint``, and a compared run too if it has one
    (a run interrupted before it started it starts afresh).

    Returns:
        The history (a dict of column arrays) with the run's label, output folder,
        number of DOFs and time-loop wall time (max over ranks).
    """
    simulation, solver = impact_simulation(args, dim, scheme_name, compared)
    comm = simulation.comm
    comm.barrier()
    start = time.perf_counter()
    restart = args.restart and (
        not compared or os.path.exists(os.path.join(out, "checkpoint", CHECKPOINT_FILE))
    )
    columns = HISTORY_COLUMNS if simulation.problem.friction is None else FRICTION_HISTORY_COLUMNS
    records = simulation.run(
        out=out,
        columns=columns,
        output_every=output_every,
        callback=callback,
        checkpoint_every=args.checkpoint_every,
        restart=restart,
    )
    seconds = comm.allreduce(time.perf_counter() - start, op=MPI.MAX)
    simulation.solver.destroy()  # collectively, rather than whenever the garbage collector runs
    V = simulation.problem.V
    label = scheme_label(scheme_name, **scheme_parameters(args, scheme_name, compared))
    return {
        "label": f"Nitsche + {label}",
        "out": out,
        "dofs": V.dofmap.index_map.size_global * V.dofmap.index_map_bs,
        "seconds": seconds,
        "linear_solver": solver,
        **{name: np.array([record[name] for record in records]) for name in columns},
    }


def compared_runs(args: argparse.Namespace) -> list[str]:
    """The schemes of the energy figure other than the main run's, when comparing."""
    compare = args.compare and args.mu is None  # the talk's figure is frictionless
    return [name for name in COMPARED_SCHEMES if compare and name != args.scheme]


# -- summary -------------------------------------------------------------------------


def measure(result: dict) -> dict:
    """The numbers of the summary for one run."""
    t, force = result["t"], result["contact_force"]
    energy, energy_theta = result["energy"], result["energy_theta"]
    touching = t[force > 0]
    return {
        "first_contact": f"{touching[0]:.3f}" if touching.size else "never",
        "drift": energy[-1] / energy[0] - 1,
        "drift_theta": energy_theta[-1] / energy_theta[0] - 1,
        "rise_theta": np.max(np.diff(energy_theta)) / abs(energy_theta[0]),
        "penetration": np.max(result["penetration_max"]),
        "newton": np.mean(result["newton_iterations"][1:]),  # row 0 is t = 0: no solve
    }


def print_summary(results: list[dict], args: argparse.Namespace) -> None:
    """One header line, then one line of numbers per run (rank 0)."""
    main = results[0]
    print(
        f"{main['dofs']} DOFs (P{args.degree}, h = {args.mesh_size:g}), "
        f"{len(main['t']) - 1} steps of tau = {args.dt:g} to T = {args.t_end:g}, "
        f"Theta = {args.nitsche_theta:g}, gamma0 = {args.gamma0:g}, "
        f"linear solver {main['linear_solver']}"
    )
    header = (
        f"{'run':40s} {'1st contact':>11s} {'E(T)/E(0)-1':>12s} {'E_Th drift':>11s} "
        f"{'max dE_Th/E_Th(0)':>17s} {'max penetr.':>11s} {'Newton':>6s} {'loop (s)':>8s}"
    )
    print(header)
    for result in results:
        m = measure(result)
        print(
            f"{result['label']:40s} {m['first_contact']:>11s} {m['drift']:+12.3e} "
            f"{m['drift_theta']:+11.3e} {m['rise_theta']:17.2e} {m['penetration']:11.3e} "
            f"{m['newton']:6.2f} {result['seconds']:8.2f}"
        )
    print(
        "(1st contact: first t with contact force > 0; drifts: relative changes over [0, T]; "
        "max dE_Th/E_Th(0): largest one-step rise of E_Theta; Newton: iterations per step)"
    )
    if "friction_dissipation" in main:
        work, balance = main["friction_dissipation"], main["energy_balance_residual"]
        print(
            f"friction (mu_f = {args.mu:g}): frictional work {np.sum(work):.6g}, "
            f"smallest D^n {np.min(work):+.3e}, largest |E_Th^(n+1) - E_Th^n + D^n| "
            f"{np.max(np.abs(balance)):.3e} (the hybrid scheme's own dissipation where "
            "contact starts or ends)"
        )
    for result in results:
        print(f"history: {os.path.join(result['out'], 'history.csv')}")


# -- the energy figure -------------------------------------------------------------------


#: Colours of the schemes in the energy figure, as in the talk's legend order.
COLOURS = {"hybrid": "tab:blue", "cn": "tab:red", "theta": "tab:green", "newmark": "tab:orange"}


def plot_energies(
    results: list[dict], schemes: list[str], args: argparse.Namespace, body: str, path: str
) -> None:
    """The talk's "Energy E^h for different methods", or the main run's energies alone.

    Top: E^h of every run (of one run: E^h, E_Theta^h and the kinetic, elastic and
    gravity parts). Middle, zoomed on the runs that keep E^h within 2 %: the relative
    changes of E^h (thin) and E_Theta^h (thick), where the increases of E_Theta^h
    show. Bottom: the contact force.
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
        figsize=(9, 10),
        sharex=True,
        gridspec_kw={"height_ratios": (2, 1.5, 1)},
        constrained_layout=True,
    )
    main = results[0]
    zoomed = [np.max(np.abs(r["energy"] / r["energy"][0] - 1)) < 0.02 for r in results]
    if len(results) == 1 or not any(zoomed):
        zoomed = [True] * len(results)
    # the main run first and wide, the others over it, so that close curves all show
    for i, result in enumerate(results):
        colour = COLOURS[schemes[i]]
        t, energy, energy_theta = result["t"], result["energy"], result["energy_theta"]
        width = 2.6 if i == 0 else 1.2
        top.plot(t, energy, color=colour, lw=width, label=result["label"])
        bottom.plot(t, result["contact_force"], color=colour, lw=0.8 * width)
        if zoomed[i]:
            middle.plot(t, energy / energy[0] - 1, color=colour, lw=0.6, alpha=0.6)
            middle.plot(
                t,
                energy_theta / energy_theta[0] - 1,
                color=colour,
                lw=width + 0.4,
                label=rf"$E_\Theta^h$, {result['label']}",
            )
    if len(results) == 1:
        for name, label, style in (
            ("energy_theta", r"$E_\Theta^h$", {"color": "tab:cyan", "ls": "--"}),
            ("kinetic", "kinetic", {"color": "tab:purple", "lw": 1}),
            ("elastic", "elastic", {"color": "tab:brown", "lw": 1}),
            ("potential", "potential (gravity)", {"color": "tab:gray", "lw": 1}),
        ):
            top.plot(main["t"], main[name], label=label, **style)
    top.set_ylabel("energy $E^h$")
    top.legend(loc="lower left", fontsize="small")
    middle.set_ylabel("relative change")
    which = ", runs within 2 %" if not all(zoomed) else ""
    middle.set_title(
        rf"$E^h / E^h(0) - 1$ (thin) and $E_\Theta^h / E_\Theta^h(0) - 1$ (thick){which}",
        fontsize="small",
    )
    middle.axhline(0.0, color="black", lw=0.5)
    if middle.lines[1:]:
        middle.legend(loc="lower left", fontsize="small")
    bottom.set_ylabel("contact force")
    bottom.set_xlabel("time $t$")
    for ax in (top, middle, bottom):
        ax.grid(alpha=0.3)
    what = "Energy $E^h$ for different methods" if len(results) > 1 else "Energies"
    fig.suptitle(
        rf"{what}: {body}, Nitsche $\Theta = {args.nitsche_theta:g}$, "
        rf"$\gamma_0 = {latex_number(args.gamma0)}$, P{args.degree}, $h = {args.mesh_size:g}$, "
        rf"$\tau = {latex_number(args.dt)}$",
        fontsize="medium",
    )
    fig.savefig(path, dpi=120)
    plt.close(fig)
    print(f"figure: {path}")


# -- the picture of the deformed body ------------------------------------------------


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
        topology, cell_types, points = compat.vtk_mesh(W)
        index_map = W.dofmap.index_map
        owned = index_map.size_local
        global_index = np.concatenate(
            [np.arange(*index_map.local_range, dtype=np.int64), index_map.ghosts.astype(np.int64)]
        )
        cells = np.asarray(topology, dtype=np.int64).reshape(len(cell_types), -1)
        cells[:, 1:] = global_index[cells[:, 1:]]
        values = np.stack(values, axis=1)
        local = (cells, cell_types, global_index[:owned], points[:owned], values[:owned])
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
        print(f"no picture: this run did not compute the time level t = {snapshot.at:g}")
        return
    with compat.own_symbols():
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
    # the curved (quadratic) faces, subdivided 3 times so that the body looks curved,
    # and the cell edges, sampled at the same points, so that they lie on that surface
    surface = _surface(deformed, 3)
    edges = _curved_edges(pyvista, cells, deformed.points, samples=8)
    top = 5.0 * np.ceil(np.max(von_mises) / 5.0)  # a round top for the colour scale
    colours = {"scalars": "von Mises", "cmap": "jet", "clim": (0.0, top)}
    bar = {
        "title": "von Mises stress",
        "n_labels": int(round(top / 5.0)) + 1,
        "fmt": "%.0f",
        "position_x": 0.3,
        "position_y": 0.04,
        "width": 0.4,
        "height": 0.06,
    }
    text = f"{title}, t = {snapshot.t:.4g}"
    if dim == 3:
        plotter = pyvista.Plotter(off_screen=True, window_size=(1600, 800), shape=(1, 2))
        ground = pyvista.Plane(center=(0, 0, 0), direction=(0, 0, 1), i_size=110, j_size=110)
        camera = [(80.0, -100.0, 38.0), (0.0, 0.0, 13.0), (0.0, 0.0, 1.0)]
        plotter.subplot(0, 0)
        plotter.add_mesh(surface, show_scalar_bar=False, **colours)
        plotter.add_mesh(edges, color="black", line_width=1, opacity=0.5)
        plotter.add_mesh(ground, color="lightgray")
        plotter.camera_position = camera
        plotter.add_text(text, font_size=11)
        # the far half of the surface and the cut through the centre, y = 0
        plotter.subplot(0, 1)
        far_half = surface.clip(normal=(0, -1, 0), origin=(0, 0, 0))
        plotter.add_mesh(far_half, show_scalar_bar=False, **colours)
        cut = deformed.slice(normal=(0, 1, 0), origin=(0, 0, 0))
        plotter.add_mesh(cut, scalar_bar_args=bar, **colours)
        plotter.add_mesh(ground, color="lightgray")
        plotter.camera_position = camera
        plotter.add_text("cut through the centre, y = 0", font_size=11)
    else:
        plotter = pyvista.Plotter(off_screen=True, window_size=(1200, 900))
        plotter.add_mesh(surface, scalar_bar_args=bar, **colours)
        plotter.add_mesh(edges, color="black", line_width=1, opacity=0.5)
        ground = pyvista.Line((-32.0, 0.0, 0.0), (32.0, 0.0, 0.0))
        plotter.add_mesh(ground, color="black", line_width=4)
        plotter.view_xy()
        plotter.camera.zoom(1.35)
        plotter.add_text(text, font_size=11)
    plotter.screenshot(path)
    plotter.close()


def _surface(grid, subdivision: int):
    """The boundary of ``grid``, its curved faces cut ``subdivision`` times."""
    try:
        return grid.extract_surface(nonlinear_subdivision=subdivision, algorithm="dataset_surface")
    except TypeError:  # pyvista before the ``algorithm`` keyword
        return grid.extract_surface(nonlinear_subdivision=subdivision)


#: Edges of the VTK (Lagrange) triangles and tetrahedra, by number of nodes per cell:
#: (first vertex, second vertex[, middle node]).
_CELL_EDGES = {
    3: ((0, 1), (1, 2), (2, 0)),
    6: ((0, 1, 3), (1, 2, 4), (2, 0, 5)),
    4: ((0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)),
    10: ((0, 1, 4), (1, 2, 5), (2, 0, 6), (0, 3, 7), (1, 3, 8), (2, 3, 9)),
}


def _curved_edges(pyvista, cells: np.ndarray, points: np.ndarray, samples: int):
    """The edges of all cells as polylines through ``samples + 1`` points each.

    A quadratic edge is the parabola through its two vertices and its middle node.
    Edges inside a 3D body are hidden by its surface.
    """
    nodes = int(cells[0])
    connectivity = cells.reshape(-1, nodes + 1)[:, 1:]
    s = np.linspace(0.0, 1.0, samples + 1)[None, :, None]
    lines = []
    for edge in _CELL_EDGES[nodes]:
        first, second = points[connectivity[:, edge[0]]], points[connectivity[:, edge[1]]]
        line = (1 - s) * first[:, None] + s * second[:, None]
        if len(edge) == 3:  # the quadratic correction through the middle node
            middle = points[connectivity[:, edge[2]]]
            line += 4 * s * (1 - s) * (middle - (first + second) / 2)[:, None]
        lines.append(line.reshape(-1, 3))
    polyline_points = np.concatenate(lines)
    count, length = len(polyline_points) // (samples + 1), samples + 1
    indices = np.arange(count * length).reshape(count, length)
    polylines = np.hstack([np.full((count, 1), length), indices]).ravel()
    return pyvista.PolyData(polyline_points, lines=polylines)


def main(dim: int, body: str, description: str, argv: list[str] | None = None) -> None:
    """The ball (``dim=3``) or disk (``dim=2``) demo: main run, comparison runs, outputs."""
    parser = make_parser(description, default_out=os.path.join("out", f"{body}_{dim}d"))
    args = parser.parse_args(argv)
    schemes = [args.scheme] + compared_runs(args)
    snapshot = Snapshot(at=PICTURE_TIME)  # the time of the talk's picture
    with one_line_errors(parser):
        check_arguments(args)
        results = [
            run(args, dim, args.scheme, args.out, output_every=args.output_every, callback=snapshot)
        ]
        for name in schemes[1:]:
            results.append(run(args, dim, name, os.path.join(args.out, name), compared=True))

    if MPI.COMM_WORLD.rank == 0:
        print_summary(results, args)
        if args.output_every > 0:
            print(f"fields: {os.path.join(args.out, 'solution.xdmf')}")
        if not args.no_plot:
            plot_energies(results, schemes, args, body, os.path.join(args.out, "energy.png"))
            title = f"{body}, {results[0]['label']}"
            render_deformed(snapshot, dim, title, os.path.join(args.out, "deformed_t18.png"))
