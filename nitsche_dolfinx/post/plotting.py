"""Figures of histories with matplotlib (optional): the guard every figure goes through,
the energy figure of the impact demos, the figures of the 1D bar (its four panels, the
comparison of methods, the convergence study) and of two bars colliding.

Every function here is called on rank 0 with the histories returned by
:meth:`Simulation.run <nitsche_dolfinx.simulation.Simulation.run>` (or read back
with :func:`~nitsche_dolfinx.output.writers.read_history`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..cases.exact import BAR_ENERGY, bar_contact_values

__all__ = [
    "BAR_METHOD_STYLES",
    "BAR_PANELS",
    "SCHEME_COLOURS",
    "bar_figure",
    "bar_panels",
    "comparison_figure",
    "convergence_figure",
    "energy_figure",
    "latex_number",
    "pyplot",
    "save",
    "slope_triangle",
    "two_bars_figure",
]


def pyplot():
    """matplotlib's ``pyplot`` on the file-only Agg backend, or None (with one line saying
    so) when matplotlib is not installed: a figure is never worth a failed demo."""
    try:
        import matplotlib
    except ImportError:
        print("matplotlib is not installed: no figure")
        return None
    matplotlib.use("Agg")  # no display needed
    import matplotlib.pyplot as plt  # optional: matplotlib is imported only to draw

    return plt


def save(fig, path: str, dpi: int = 120) -> None:
    """Write the figure to ``path``, close it and say where it went."""
    import matplotlib.pyplot as plt  # optional: matplotlib is imported only to draw

    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    print(f"figure: {path}")


def latex_number(x: float) -> str:
    """``x`` for a LaTeX title: ``1e-06`` becomes ``10^{-6}``, ``0.015`` stays ``0.015``."""
    mantissa, _, exponent = f"{x:.3g}".partition("e")
    if not exponent:
        return mantissa
    power = f"10^{{{int(exponent)}}}"
    return power if mantissa == "1" else rf"{mantissa} \cdot {power}"


def figure_title(subject: str, theta=None, gamma0=None, degree=None, h=None, dt=None) -> str:
    """A figure's title: ``subject``, then those of the Nitsche parameters (``theta``,
    ``gamma0``) and the discretisation (``degree``, ``h``, ``dt``) that are given; ``h``
    and ``dt`` are numbers, or LaTeX."""
    parts = [] if theta is None else [rf"Nitsche $\Theta = {theta:g}$"]
    if gamma0 is not None:
        parts.append(rf"$\gamma_0 = {latex_number(gamma0)}$")
    if degree is not None:
        parts.append(f"P{degree}")
    for symbol, value in (("h", h), (r"\tau", dt)):
        if value is not None:
            parts.append(
                rf"${symbol} = {value if isinstance(value, str) else latex_number(value)}$"
            )
    return ": ".join([subject, ", ".join(parts)]) if parts else subject


#: A colour per time scheme (:data:`~nitsche_dolfinx.steppers.schemes.SCHEMES`), the same in every
#: figure that compares schemes.
SCHEME_COLOURS = {
    "hybrid": "tab:blue",
    "cn": "tab:red",
    "theta": "tab:green",
    "newmark": "tab:orange",
    "verlet": "tab:purple",
}

#: The parts of E^h drawn with a single run's energy.
_PARTS = (
    ("energy_theta", r"$E_\Theta^h$", {"color": "tab:cyan", "ls": "--"}),
    ("kinetic", "kinetic", {"color": "tab:purple", "lw": 1}),
    ("elastic", "elastic", {"color": "tab:brown", "lw": 1}),
    ("potential", "potential (gravity)", {"color": "tab:gray", "lw": 1}),
)


def energy_figure(
    histories: Sequence, labels: Sequence[str], colours: Sequence[str], title: str, path: str
) -> None:
    """The talk's "Energy E^h for different methods", or one run's energies.

    Top: E^h of every run (of one run: E^h, E_Theta^h and the kinetic, elastic and
    gravity parts; with a column ``pairing_energy`` E_Theta^h less it, with
    ``friction_dissipation`` plus the friction's work so far: what never rises, also in
    the middle). Middle, zoomed on the runs that keep E^h within 2 %: the relative
    changes of E^h (thin) and E_Theta^h (thick), where the increases of E_Theta^h
    show. Bottom: the contact force. The first history is the main run.
    """
    plt = pyplot()
    if plt is None:
        return
    fig, (top, middle, bottom) = plt.subplots(
        3, 1, figsize=(9, 10), sharex=True, constrained_layout=True,
        gridspec_kw={"height_ratios": (2, 1.5, 1)},
    )  # fmt: skip
    zoomed = [np.max(np.abs(h["energy"] / h["energy"][0] - 1)) < 0.02 for h in histories]
    if len(histories) == 1 or not any(zoomed):
        zoomed = [True] * len(histories)
    # the main run first and wide, the others over it, so that close curves all show
    for i, (history, label, colour) in enumerate(zip(histories, labels, colours)):
        t, energy, energy_theta = history["t"], history["energy"], history["energy_theta"]
        width = 2.6 if i == 0 else 1.2
        top.plot(t, energy, color=colour, lw=width, label=label)
        bottom.plot(t, history["contact_force"], color=colour, lw=0.8 * width)
        if zoomed[i]:
            middle.plot(t, energy / energy[0] - 1, color=colour, lw=0.6, alpha=0.6)
            change = energy_theta / energy_theta[0] - 1
            middle.plot(t, change, color=colour, lw=width + 0.4, label=rf"$E_\Theta^h$, {label}")
    if len(histories) == 1:
        history = histories[0]
        for name, label, style in _PARTS:
            top.plot(history["t"], history[name], label=label, **style)
        paired = "pairing_energy" in history and np.any(history["pairing_energy"] != 0)
        friction = "friction_dissipation" in history
        if paired or friction:  # pairs that follow the sliding, friction: what never rises
            controlled, label = np.array(history["energy_theta"]), r"$E_\Theta^h$"
            if paired:
                controlled -= history["pairing_energy"]
                label += " - pairing_energy"
            if friction:
                controlled += np.cumsum(history["friction_dissipation"])
                label += r" + $\sum D^n$"
            top.plot(history["t"], controlled, label=label, color="tab:olive", ls=":")
            middle.plot(history["t"], controlled / controlled[0] - 1, color="tab:olive",
                        ls=":", lw=2, label=label)  # fmt: skip
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
    what = "Energy $E^h$ for different methods" if len(histories) > 1 else "Energies"
    fig.suptitle(f"{what}: {title}", fontsize="medium")
    save(fig, path)


def work_figure(history, title: str, path: str, forces: dict[str, str] | None = None) -> None:
    """Where the work of loads, supports and moving obstacles goes (docs/method.md section
    13): top, E_Theta, the kinetic and elastic energies, the work W (``work``) and what
    contact and damping dissipated; middle, ``energy_balance`` (zero to the solver's
    tolerance for the hybrid scheme and Crank-Nicolson); bottom, the contact forces
    ``forces`` ({column: label}; default: each contact's, or their sum)."""
    plt = pyplot()
    if plt is None:
        return
    fig, (top, middle, bottom) = plt.subplots(
        3, 1, figsize=(9, 10), sharex=True, constrained_layout=True,
        gridspec_kw={"height_ratios": (2, 1, 1.5)},
    )  # fmt: skip
    t = history["t"]
    top.plot(t, history["work"], color="black", lw=2.6, label="work $W$")
    top.plot(t, history["energy_theta"], color="tab:blue", lw=1.8, label=r"$E_\Theta^h$")
    for name, label, style in _PARTS[1:3]:
        top.plot(t, history[name], label=label, **style)
    dissipated = {"contact_dissipation": ("tab:red", "contact dissipation"),
                  "damping_dissipation": ("tab:orange", "damping dissipation")}  # fmt: skip
    for name, (colour, label) in dissipated.items():
        if name in history.columns:
            top.plot(t, history[name], color=colour, lw=1, label=label)
    top.set_ylabel("energy")
    top.legend(loc="upper left", fontsize="small")
    middle.plot(t, history["energy_balance"], color="tab:green")
    middle.set_ylabel("energy balance")
    middle.set_title(r"the change of $E_\Theta$ without the loads' potential, plus what was "
                     "dissipated, less $W$", fontsize="small")  # fmt: skip
    middle.axhline(0.0, color="black", lw=0.5)
    if forces is None:
        names = [c for c in history.columns if c.startswith("contact_force_")] or ["contact_force"]
        forces = {name: name.replace("_", " ") for name in names}
    for name, label in forces.items():
        bottom.plot(t, history[name], label=label)
    bottom.set_ylabel("force")
    bottom.set_xlabel("time $t$")
    bottom.legend(loc="upper left", fontsize="small")
    for ax in (top, middle, bottom):
        ax.grid(alpha=0.3)
    fig.suptitle(f"Work and energies: {title}", fontsize="medium")
    save(fig, path)


#: The talk's panels of the 1D bar: (history column, title), values at x = 0.
BAR_PANELS = (
    ("u_contact", "displacement $u_h(t, 0)$"),
    ("v_contact", r"velocity $\dot u_h(t, 0)$"),
    ("sigma_contact", "contact pressure at $x = 0$"),
    ("energy", "energy $E^h$"),
)


def bar_panels(axes, histories: Sequence, labels: Sequence[str], styles: Sequence[dict], t_end):
    """Draw the four :data:`BAR_PANELS` of the bar into ``axes``, each run over the exact
    solution (black; docs/method.md section 5): ``styles`` are matplotlib line options."""
    t_exact = np.linspace(0.0, t_end, 4001)  # fine, so that the kinks stay sharp
    exact = dict(zip(("u_contact", "v_contact", "sigma_contact"), bar_contact_values(t_exact)))
    for ax, (name, title) in zip(axes, BAR_PANELS):
        if name == "energy":
            ax.axhline(BAR_ENERGY, color="black", lw=1.4, zorder=10, label="exact")
        else:
            ax.plot(t_exact, exact[name], color="black", lw=1.4, zorder=10, label="exact")
        for history, label, style in zip(histories, labels, styles):
            ax.plot(history["t"], history[name], label=label, **style)
        ax.set_title(title)
        ax.grid(alpha=0.3)


def bar_figure(histories: Sequence, labels: Sequence[str], title: str, path: str, t_end) -> None:
    """The talk's figure of the bar: the four :data:`BAR_PANELS` of every run over the exact
    solution, the first run (blue, on top) with its E_Theta^h, the others in red."""
    plt = pyplot()
    if plt is None:
        return
    styles = [{"color": "tab:blue", "lw": 1.1, "alpha": 0.9, "zorder": 2}]
    styles += [{"color": "tab:red", "lw": 0.9, "alpha": 0.8, "zorder": 1}] * (len(histories) - 1)
    fig, axes = plt.subplots(2, 2, figsize=(12, 7.5), sharex=True, constrained_layout=True)
    bar_panels(axes.flat, histories, labels, styles, t_end)
    # E_Theta of the main run: the hybrid scheme guarantees that it never increases
    main = histories[0]
    axes[1, 1].plot(
        main["t"], main["energy_theta"], color="tab:cyan", lw=1.1, ls="--", zorder=2,
        label=rf"$E_\Theta^h$, {labels[0]}",
    )  # fmt: skip
    for ax in axes[1]:
        ax.set_xlabel("time $t$")
    axes[1, 1].legend(loc="upper left", fontsize="small")
    fig.suptitle(title)
    save(fig, path, dpi=150)


#: Colours, markers and stacking of the methods of
#: :data:`~nitsche_dolfinx.cases.one_body.BAR_METHODS` in the figures (the smooth curves on top of
#: the oscillating ones).
BAR_METHOD_STYLES = {
    "hybrid": {"color": "tab:blue", "marker": "o", "zorder": 3, "ls": "-"},
    "cn": {"color": "tab:red", "marker": "s", "zorder": 2, "ls": "-"},
    "mixed": {"color": "tab:orange", "marker": "^", "zorder": 1, "ls": "-"},
    "modified_mass": {"color": "tab:green", "marker": "D", "zorder": 5, "ls": "-"},
    "penalty": {"color": "tab:purple", "marker": "v", "zorder": 4, "ls": "--"},
}


def comparison_figure(
    methods: dict, histories: Sequence, title: str, path: str, t_end,
    zoom=((3.95, 5.1), (-3e-4, 6.5e-3)),
) -> None:  # fmt: skip
    """The talk's "Mixed(+CN) vs Nitsche(+CN) vs Nitsche-Hybrid": the :data:`BAR_PANELS`
    of the runs of ``methods`` (a key of :data:`BAR_METHOD_STYLES` to a
    :class:`~nitsche_dolfinx.cases.one_body.BarMethod`), each over the exact solution, and a zoom
    (x and y limits) on the displacement during the second contact phase. The velocity of
    a run with the redistributed mass is its mean over each step."""
    plt = pyplot()
    if plt is None:
        return
    fig = plt.figure(figsize=(14, 8.5), constrained_layout=True)
    grid = fig.add_gridspec(2, 6)
    # the displacement, a zoom on it, and the three other panels of the talk
    ax_zoom = fig.add_subplot(grid[0, 2])
    axes = [fig.add_subplot(grid[0, 0:2]), fig.add_subplot(grid[0, 3:])]
    axes += [fig.add_subplot(grid[1, :3]), fig.add_subplot(grid[1, 3:])]
    labels = [
        method.label + (r", $(u^{n+1} - u^n)/\tau$" if method.mass == "redistributed" else "")
        for method in methods.values()
    ]
    styles = []
    for name in methods:
        style = BAR_METHOD_STYLES[name]
        styles.append({"color": style["color"], "ls": style["ls"], "lw": 0.9, "alpha": 0.9,
                       "zorder": style["zorder"]})  # fmt: skip
    bar_panels(axes, histories, labels, styles, t_end)
    for ax in axes:
        ax.set_xlabel("time $t$")
    axes[1].legend(loc="upper left", fontsize="x-small")
    # who stays on the wall during the second contact phase
    bar_panels([ax_zoom], histories, labels, styles, t_end)
    ax_zoom.set_xlim(*zoom[0])
    ax_zoom.set_ylim(*zoom[1])
    ax_zoom.set_title("zoom: second contact", fontsize="medium")
    ax_zoom.set_xlabel("time $t$")
    fig.suptitle(title)
    save(fig, path, dpi=150)


def slope_triangle(ax, x0: float, y0: float, slope: float, label: str, width: float = 2.0):
    """A reference triangle of the given slope with its lower-left corner at (x0, y0)."""
    x1, y1 = x0 * width, y0 * width**slope
    ax.plot([x0, x1, x1, x0], [y0, y0, y1, y0], color="dimgray", lw=0.9)
    ax.text(x1 * 1.05, np.sqrt(y0 * y1), label, fontsize="small", color="dimgray", va="center")


#: The panels of the convergence figure: (errors of
#: :func:`~nitsche_dolfinx.cases.one_body.bar_convergence_level`, solid then dashed; title).
CONVERGENCE_PANELS = (
    (("error_l2_l2",), r"$u$ in $\ell^2(\tau; L^2(0, 1))$"),
    (("error_l2_h1",), r"$u$ in $\ell^2(\tau; H^1(0, 1))$ (seminorm)"),
    (
        ("error_pressure", "error_stress"),
        r"pressure at $x = 0$ in $\ell^2(\tau)$: $\lambda_h$ (solid), $\sigma_n(u_h)$ (dashed)",
    ),
    (("error_energy",), r"energy: $\max_n |E^{h,n} - 1/8|$"),
)


def convergence_figure(results: dict, labels: dict, title: str, path: str) -> None:
    """The talk's error curves: four log-log panels against h (:data:`CONVERGENCE_PANELS`),
    one curve per method (``results``: a key of :data:`BAR_METHOD_STYLES` to the rows of
    :func:`~nitsche_dolfinx.cases.one_body.bar_convergence_level`, ``labels``: the same keys to the
    legend), with reference slopes 1/2 and 1 below the curves."""
    plt = pyplot()
    if plt is None:
        return
    fig, axes = plt.subplots(2, 2, figsize=(12, 9.5))
    fig.subplots_adjust(left=0.07, right=0.97, top=0.92, bottom=0.1, hspace=0.28, wspace=0.2)
    for ax, (names, panel_title) in zip(axes.flat, CONVERGENCE_PANELS):
        low = np.inf
        for name, rows in results.items():
            style = BAR_METHOD_STYLES[name]
            h = np.array([row["h"] for row in rows])
            for error, line in zip(names, ("-", "--")):
                values = np.array([row[error] for row in rows])
                ax.loglog(
                    h, values, color=style["color"], marker=style["marker"], ls=line, ms=5,
                    label=labels[name] if line == "-" else None,
                )  # fmt: skip
                low = min(low, values.min())
        # the reference slopes, below every curve, over the finest levels
        h = np.sort([row["h"] for row in next(iter(results.values()))])
        slope_triangle(ax, h[0] * 1.15, low / 1.8, 0.5, "1/2")
        slope_triangle(ax, h[0] * 1.15 * 2.0**1.6, low / 1.8, 1.0, "1")
        ax.set_xticks(h)
        ax.set_xticks([], minor=True)
        ax.set_xticklabels([f"1/{round(1 / x)}" for x in h])
        ax.set_title(panel_title, fontsize="medium")
        ax.set_xlabel("$h$")
        ax.grid(alpha=0.3, which="both")
    fig.legend(*axes[0, 0].get_legend_handles_labels(), loc="lower center", ncol=len(results))
    fig.suptitle(title)
    save(fig, path, dpi=150)


def two_bars_figure(history, v0: float, gap: float, path: str) -> None:
    """Two bars colliding: the mean velocity of each bar over the exact end states, and the
    contact force over the exact rho c v0 (E = rho = 1)."""
    plt = pyplot()
    if plt is None:
        return
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    t = history["t"]
    start = gap / (2 * v0)
    exact = np.where((t > start) & (t < start + 2), 0.0, np.where(t < start, 1.0, -1.0))
    top.plot(t, history["v_right"], label="right bar")
    top.plot(t, history["v_left"], label="left bar")
    top.plot(t, -v0 * exact, "k:", lw=0.8, label="exact (end states)")
    top.set_ylabel("mean velocity")
    top.legend()
    bottom.plot(t, history["contact_force"], label="contact force")
    bottom.axhline(v0, color="k", ls=":", lw=0.8, label=r"$\rho c v_0$")
    bottom.set_xlabel("t")
    bottom.legend()
    save(fig, path, dpi=110)
