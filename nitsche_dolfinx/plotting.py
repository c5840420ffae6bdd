"""Figures of histories with matplotlib (optional): the guard every figure goes through,
the energy figure of the impact demos and the panels of the 1D bar.

Every function here is called on rank 0 with the histories returned by
:meth:`Simulation.run <nitsche_dolfinx.simulation.Simulation.run>` (or read back
with :func:`~nitsche_dolfinx.output.read_history`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ["BAR_PANELS", "bar_panels", "energy_figure", "latex_number", "pyplot", "save"]


def pyplot():
    """matplotlib's ``pyplot`` on the file-only Agg backend, or None (with one line saying
    so) when matplotlib is not installed: a figure is never worth a failed demo."""
    try:
        import matplotlib
    except ImportError:
        print("matplotlib is not installed: no figure")
        return None
    matplotlib.use("Agg")  # no display needed
    import matplotlib.pyplot as plt

    return plt


def save(fig, path: str, dpi: int = 120) -> None:
    """Write the figure to ``path``, close it and say where it went."""
    import matplotlib.pyplot as plt

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
    gravity parts). Middle, zoomed on the runs that keep E^h within 2 %: the relative
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
        for name, label, style in _PARTS:
            top.plot(histories[0]["t"], histories[0][name], label=label, **style)
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
    from .exact import BAR_ENERGY, bar_contact_values

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
