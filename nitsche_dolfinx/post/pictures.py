"""Pictures of the deformed body coloured by von Mises or by the contact pressure, from any
MPI run (pyvista, optional), and of bars in space and time (matplotlib).

:class:`Snapshot` is a :meth:`Simulation.run <nitsche_dolfinx.simulation.Simulation.run>`
callback that gathers the fields of one time level on rank 0;
:func:`render_deformed` draws them off screen: the curved (P2-geometry) cells are
drawn curved, with their edges. Used by the impact demos::

    snapshot = Snapshot(at=18.0)
    simulation.run(out=out, callback=snapshot)
    render_deformed(snapshot, dim=3, title="ball", path="deformed_t18.png")

:func:`render_contact_pressure` draws the contact pressure on Gamma_C of a level of a
written ``solution.xdmf`` (docs/method.md section 6), from the file alone::

    render_contact_pressure("out/ball_3d/solution.xdmf", 18.0, "contact_pressure_t18.png")

In 1D, :class:`Worldlines` keeps every time level and :func:`render_worldlines` draws
the bars where they are (x + u) against t, coloured by their velocity.
"""

from __future__ import annotations

import contextlib

import numpy as np
from dolfinx import fem

from ..common import compat
from ..output.series import read_solution
from .plotting import pyplot, save

__all__ = [
    "Snapshot",
    "Worldlines",
    "render_contact_pressure",
    "render_deformed",
    "render_worldlines",
]


class Snapshot:
    """A ``Simulation.run`` callback that keeps the fields at the time level closest to ``at``.

    The displacement and the von Mises stress are interpolated into the Lagrange
    space of the mesh's geometric degree and gathered on rank 0 with the cells
    (owned cells of each rank, dofs numbered globally), so that the picture of an
    MPI run is the same as a serial one.
    """

    def __init__(self, at: float):
        self.at = at
        self.t = None
        self.grid = None  # on rank 0: (cells, cell types, points, displacement, von Mises)

    def __call__(self, simulation) -> None:
        if simulation.step_index != int(round(self.at / simulation.dt)):
            return
        mesh = simulation.problem.mesh
        gdim = mesh.geometry.dim
        W = compat.function_space(mesh, "Lagrange", compat.geometry_degree(mesh))
        expressions = [simulation.u[i] for i in range(gdim)] + [
            simulation.problem.von_mises(simulation.u)
        ]
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


def _with_pyvista(draw, path: str) -> None:
    """Call ``draw(pyvista)``, pyvista imported off screen; one line if pyvista is missing or
    rendering fails (a picture is never worth a failed run)."""
    with compat.own_symbols():
        try:
            import pyvista
        except ImportError:
            print("pyvista is not installed: no picture")
            return
        try:
            with contextlib.suppress(ImportError):  # no "bad X server connection" warnings
                from vtkmodules.vtkCommonCore import vtkLogger

                vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_ERROR)
            pyvista.OFF_SCREEN = True
            draw(pyvista)
        except Exception as error:
            print(f"no picture: rendering failed ({type(error).__name__}: {error})")
            return
    print(f"picture: {path}")


def render_deformed(
    snapshot: Snapshot, dim: int, title: str, path: str, ground: bool = True
) -> None:
    """Draw the deformed body coloured by von Mises into ``path`` (rank 0).

    ``ground``: the body of the impact test on the rigid plane (drawn, and the camera
    set for it); False: whatever bodies the mesh holds, framed by their bounds (two
    bodies colliding, a ball on a slab). pyvista is optional and renders off screen; if
    it is missing or rendering fails, one line says so and the demo goes on.
    """
    if snapshot.grid is None:
        print(f"no picture: this run did not compute the time level t = {snapshot.at:g}")
        return
    _with_pyvista(lambda pyvista: _render(pyvista, snapshot, dim, title, path, ground), path)


def _colour_scale(largest: float) -> tuple[float, float]:
    """A round top for a colour scale from 0 to ``largest`` and the step of its labels
    (1, 2 or 5 times a power of ten, at most 8 steps: 5 for the talk's ball, 5e8 for a
    steel part in Pa; 2 for a largest value of 8.4)."""
    if not largest > 0.0:
        return 1.0, 1.0
    power = 10.0 ** (np.floor(np.log10(largest)) - 1)  # largest / power in [10, 100)
    multiples = (1.0, 2.0, 5.0, 10.0, 20.0)  # 20: at most 5 steps, whatever largest is
    step = next(m * power for m in multiples if np.ceil(largest / (m * power)) <= 8)
    return step * np.ceil(largest / step), step


def _render(pyvista, snapshot: Snapshot, dim: int, title: str, path: str, ground: bool) -> None:
    cells, cell_types, points, displacement, von_mises = snapshot.grid
    grid = pyvista.UnstructuredGrid(cells, cell_types, points)
    grid.point_data["displacement"] = displacement
    grid.point_data["von Mises"] = von_mises
    deformed = grid.warp_by_vector("displacement", factor=1.0)
    # the curved (quadratic) faces, subdivided 3 times so that the body looks curved,
    # and the cell edges, sampled at the same points, so that they lie on that surface
    surface = _surface(deformed, 3)
    edges = _curved_edges(pyvista, cells, deformed.points, samples=8)
    top, step = _colour_scale(float(np.max(von_mises)))
    colours = {"scalars": "von Mises", "cmap": "jet", "clim": (0.0, top)}
    bar = {
        "title": "von Mises stress",
        "n_labels": int(round(top / step)) + 1,
        "fmt": "%.0f" if step >= 1.0 and top < 1e6 else "%.3g",
        "position_x": 0.3,
        "position_y": 0.04,
        "width": 0.4,
        "height": 0.06,
    }
    text = f"{title}, t = {snapshot.t:.4g}"
    if dim == 3:
        plotter = _plot_3d(
            pyvista, grid.bounds, surface, deformed, edges, colours, bar, text, ground
        )
    else:
        plotter = _plot_2d(pyvista, surface, edges, colours, bar, text, ground)
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


#: The half-diagonal of the impact test ball's bounding box (radius 20), the size its view
#: of the ground is made for.
_BALL_SIZE = 20.0 * np.sqrt(3.0)


def _ground_scale(bounds) -> float:
    """The size of the body of ``bounds`` over the impact test ball's."""
    low, high = np.array(bounds[0::2]), np.array(bounds[1::2])
    return float(np.linalg.norm(high - low) / 2 / _BALL_SIZE)


def _camera(bounds, ground: bool) -> list:
    """The view of a body on the ground, the impact test's ball's scaled to its size
    (``ground``), or one from the same side framing ``bounds`` (xmin, xmax, ymin, ymax,
    zmin, zmax)."""
    if ground:
        scale = _ground_scale(bounds)
        return [(80.0 * scale, -100.0 * scale, 38.0 * scale), (0.0, 0.0, 13.0 * scale),
                (0.0, 0.0, 1.0)]  # fmt: skip
    low, high = np.array(bounds[0::2]), np.array(bounds[1::2])
    centre, radius = (low + high) / 2, np.linalg.norm(high - low) / 2
    side = np.array([80.0, -100.0, 25.0])  # the direction of the ball's view
    return [tuple(centre + 3.75 * radius * side / np.linalg.norm(side)), tuple(centre), (0, 0, 1)]


def _plot_3d(pyvista, bounds, surface, deformed, edges, colours, bar, text, ground):
    """The body from aside (on the ground), and its far half with the cut through the
    centre (of the reference ``bounds``)."""
    plotter = pyvista.Plotter(off_screen=True, window_size=(1600, 800), shape=(1, 2))
    size = 110 * _ground_scale(bounds)
    plane = pyvista.Plane(center=(0, 0, 0), direction=(0, 0, 1), i_size=size, j_size=size)
    camera = _camera(bounds, ground)
    middle = np.array(camera[1])
    plotter.subplot(0, 0)
    plotter.add_mesh(surface, show_scalar_bar=False, **colours)
    plotter.add_mesh(edges, color="black", line_width=1, opacity=0.5)
    if ground:
        plotter.add_mesh(plane, color="lightgray")
    plotter.camera_position = camera
    plotter.add_text(text, font_size=11)
    # the far half of the surface and the cut through the centre
    plotter.subplot(0, 1)
    cut_at = (0, 0, 0) if ground else (0, middle[1], 0)
    far_half = surface.clip(normal=(0, -1, 0), origin=cut_at)
    plotter.add_mesh(far_half, show_scalar_bar=False, **colours)
    cut = deformed.slice(normal=(0, 1, 0), origin=cut_at)
    plotter.add_mesh(cut, scalar_bar_args=bar, **colours)
    if ground:
        plotter.add_mesh(plane, color="lightgray")
    plotter.camera_position = camera
    plotter.add_text(f"cut through the centre, y = {cut_at[1] + 0.0:.4g}", font_size=11)
    return plotter


def _plot_2d(pyvista, surface, edges, colours, bar, text, ground):
    """The body on the ground line (or the bodies), seen along z."""
    plotter = pyvista.Plotter(off_screen=True, window_size=(1200, 900))
    plotter.add_mesh(surface, scalar_bar_args=bar, **colours)
    plotter.add_mesh(edges, color="black", line_width=1, opacity=0.5)
    if ground:
        line = pyvista.Line((-32.0, 0.0, 0.0), (32.0, 0.0, 0.0))
        plotter.add_mesh(line, color="black", line_width=4)
    plotter.view_xy()
    plotter.camera.zoom(1.35 if ground else 0.9)  # clear of the colour bar
    plotter.add_text(text, font_size=11)
    return plotter


#: VTK cell types of the XDMF topologies of this package's meshes (same node order).
_VTK_CELLS = {"Triangle": 5, "Triangle_6": 22, "Tetrahedron": 10, "Tetrahedron_10": 24}


def render_contact_pressure(solution: str, t: float, path: str, title: str = "ball") -> None:
    """Draw the contact pressure lambda_h (<= 0) on Gamma_C at the level of ``solution`` (an
    XDMF series of :class:`~nitsche_dolfinx.output.writers.SolutionWriter`) nearest ``t`` into
    ``path``: the deformed body from aside and, in 3D, its contact zone seen from below.

    Reads the file with h5py (call it on one rank); pyvista is optional and renders off
    screen; if it is missing or rendering fails, one line says so.
    """
    (level,) = read_solution(solution, t)
    if "contact_pressure" not in level.fields:
        print(f"no picture: {solution} has no contact_pressure")
        return
    _with_pyvista(lambda pyvista: _render_pressure(pyvista, level, title, path), path)


def _render_pressure(pyvista, level, title: str, path: str) -> None:
    points = np.zeros((len(level.points), 3))
    points[:, : level.points.shape[1]] = level.points
    count = level.cells.shape[1]
    cells = np.hstack([np.full((len(level.cells), 1), count), level.cells]).ravel()
    types = np.full(len(level.cells), _VTK_CELLS[level.cell_type], dtype=np.uint8)
    grid = pyvista.UnstructuredGrid(cells, types, points)
    grid.point_data["displacement"] = level.fields["displacement"]
    pressure = level.fields["contact_pressure"][:, 0]
    grid.point_data["contact pressure"] = pressure
    deformed = grid.warp_by_vector("displacement", factor=1.0)
    surface = _surface(deformed, 3)
    edges = _curved_edges(pyvista, cells, deformed.points, samples=8)
    low = min(float(pressure.min()), -1e-300)
    colours = {"scalars": "contact pressure", "cmap": "viridis", "clim": (low, 0.0)}
    bar = {
        "title": "contact pressure lambda_h",
        "n_labels": 5,
        "fmt": "%.2g",
        "position_x": 0.3,
        "position_y": 0.04,
        "width": 0.4,
        "height": 0.06,
    }
    text = f"{title}, t = {level.t:.4g}: contact pressure on Gamma_C"
    if level.points.shape[1] == 2 or not np.any(points[:, 2]):
        plotter = _plot_2d(pyvista, surface, edges, colours, bar, text, ground=True)
    else:
        plotter = _plot_contact_zone(pyvista, surface, edges, colours, bar, text)
    plotter.screenshot(path)
    plotter.close()


def _plot_contact_zone(pyvista, surface, edges, colours, bar, text):
    """The ball from aside and below, and seen from below, the ground removed."""
    centre = surface.points.mean(axis=0)
    edges = edges.copy()  # lifted off the surface by 0.2 %, so that no face hides them
    edges.points = centre + 1.002 * (edges.points - centre)
    plotter = pyvista.Plotter(off_screen=True, window_size=(1600, 800), shape=(1, 2))
    views = [
        ([(70.0, -90.0, -25.0), (0.0, 0.0, 10.0), (0.0, 0.0, 1.0)], text),
        ([(0.0, -4.0, -88.0), (0.0, -4.0, 0.0), (0.0, 1.0, 0.0)], "seen from below"),
    ]
    for column, (camera, label) in enumerate(views):
        plotter.subplot(0, column)
        if column:
            plotter.add_mesh(surface, scalar_bar_args=bar, **colours)
        else:
            plotter.add_mesh(surface, show_scalar_bar=False, **colours)
        plotter.add_mesh(edges, color="black", line_width=1, opacity=0.5)
        plotter.camera_position = camera
        plotter.add_text(label, font_size=11)
    return plotter


class Worldlines:
    """A ``Simulation.run`` callback that keeps, on rank 0, the position x + u and the
    velocity of every node of a 1D mesh at every time level (the nodes sorted by x)."""

    def __init__(self):
        self.t, self.position, self.velocity = [], [], []
        self._x = None

    def __call__(self, simulation) -> None:
        V = simulation.problem.V
        if self._x is None:
            self._x = compat.node_coordinates(V)[:, 0]
        owned = V.dofmap.index_map.size_local
        bs = V.dofmap.index_map_bs
        u, v = (f.x.array.reshape(-1, bs)[:owned, 0] for f in (simulation.u, simulation.v))
        parts = V.mesh.comm.gather((self._x[:owned], u, v), root=0)
        if V.mesh.comm.rank != 0:
            return
        x, u, v = (np.concatenate(column) for column in zip(*parts))
        order = np.argsort(x, kind="stable")
        self.t.append(simulation.t)
        self.position.append((x + u)[order])
        self.velocity.append(v[order])
        self.x = x[order]


def render_worldlines(worldlines: Worldlines, title: str, path: str) -> None:
    """Draw the bars of ``worldlines`` where they are (x + u) against t, coloured by their
    velocity, into ``path`` (rank 0); a bar ends where two neighbouring nodes are farther
    apart in the reference configuration than twice the median spacing."""
    plt = pyplot()
    if plt is None or not worldlines.t:
        return
    t = np.asarray(worldlines.t)
    position, velocity = np.array(worldlines.position), np.array(worldlines.velocity)
    spacing = np.diff(worldlines.x)
    ends = np.flatnonzero(spacing > 2 * np.median(spacing)) + 1
    fig, ax = plt.subplots(figsize=(7, 5), constrained_layout=True)
    top = np.abs(velocity).max()
    for nodes in np.split(np.arange(len(worldlines.x)), ends):
        X, T = position[:, nodes], np.repeat(t[:, None], len(nodes), axis=1)
        image = ax.pcolormesh(X, T, velocity[:, nodes], shading="gouraud", cmap="coolwarm",
                              vmin=-top, vmax=top)  # fmt: skip
    fig.colorbar(image, ax=ax, label="velocity")
    ax.set_xlabel("position $x + u$")
    ax.set_ylabel("time $t$")
    ax.set_title(title, fontsize="medium")
    save(fig, path)
