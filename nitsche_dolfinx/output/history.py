"""The history of a run: one row of diagnostics per time level, and its summary figures.

:meth:`Simulation.run <nitsche_dolfinx.simulation.Simulation.run>` returns a
:class:`History`. Indexed by a column name it gives that column as an array;
by an integer, that row as a dict; iterated, the rows::

    history = simulation.run(out="out/bar")
    history["energy"]             # numpy array, one value per time level
    history[-1]["energy"]         # the final row
    history.energy_drift()        # E(T) / E(0) - 1

The column names are those of ``history.csv`` (docs/method.md section 6).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence

import numpy as np

__all__ = [
    "BALANCE_COLUMNS",
    "DAMPING_COLUMNS",
    "PAIRING_COLUMNS",
    "added_columns",
    "angular_momentum_columns",
    "body_columns",
    "centre_of_mass_columns",
    "contact_columns",
    "momentum_columns",
    "FRICTION_HISTORY_COLUMNS",
    "HISTORY_COLUMNS",
    "OBSTACLE_COLUMNS",
    "FINITE_COLUMNS",
    "WORK_COLUMNS",
    "STATE_COLUMNS",
    "STEP_COLUMNS",
    "History",
]

#: The physical quantities of ``history.csv``: energies and contact (reduced over MPI).
STATE_COLUMNS = (
    "energy",
    "energy_theta",
    "kinetic",
    "elastic",
    "potential",
    "contact_force",
    "contact_area",
    "penetration_max",
)
#: The steps: the size of the step that reached the level (0 at t = 0), and how many times
#: it was halved from the nominal step (docs/method.md section 8).
STEP_COLUMNS = ("dt", "step_cuts")
#: Columns of ``history.csv`` for the 2D/3D demos (docs/method.md section 6): the
#: listed ones of the output contract, then the steps.
HISTORY_COLUMNS = ("t", *STATE_COLUMNS, "newton_iterations", "step_seconds", *STEP_COLUMNS)
#: The energy balance of a step: D^n, the work of the friction term on the step's
#: increment, and E_Theta^{n+1} - E_Theta^n + D^n (both 0 at t = 0).
BALANCE_COLUMNS = ("friction_dissipation", "energy_balance_residual")
#: With Rayleigh damping: the energy damping dissipated since t = 0, the sum of the steps'
#: tau (v_m, C v_m) (docs/method.md section 14); a step's share also enters
#: ``energy_balance_residual``.
DAMPING_COLUMNS = ("damping_dissipation",)
#: With contact pairs that follow the sliding: the change of E_Theta the pairings made since
#: t = 0 (docs/method.md section 11): E_Theta less it is what the steps control.
PAIRING_COLUMNS = ("pairing_energy",)
#: Columns of ``history.csv`` for the friction demos: the balance after the listed ones.
FRICTION_HISTORY_COLUMNS = (*HISTORY_COLUMNS, *BALANCE_COLUMNS)
#: The columns of a run with a moving obstacle: the work the obstacles did since t = 0 and
#: the energy the contact terms dissipated since t = 0 (docs/method.md section 13).
OBSTACLE_COLUMNS = ("obstacle_work", "contact_dissipation")
#: With a hyperelastic material: the smallest det F over the mesh (> 0: no element is
#: inverted; docs/method.md section 15).
FINITE_COLUMNS = ("det_F_min",)
#: The work of loads, supports and moving obstacles since t = 0, and the energy balance:
#: the internal energy's change plus what was dissipated, less that work
#: (docs/method.md section 13).
WORK_COLUMNS = ("work", "energy_balance")


def _by_component(name: str, gdim: int) -> tuple[str, ...]:
    return (name,) if gdim == 1 else tuple(f"{name}_{c}" for c in "xyz"[:gdim])


def momentum_columns(gdim: int) -> tuple[str, ...]:
    """The total linear momentum: ``momentum`` in 1D, else ``momentum_x``, ``momentum_y``
    (, ``momentum_z``): the rows of M v summed by component."""
    return _by_component("momentum", gdim)


def centre_of_mass_columns(gdim: int) -> tuple[str, ...]:
    """The centre of mass of the deformed body, ``centre_of_mass`` in 1D, else
    ``centre_of_mass_x``, ...: the rows of M (x + u) summed by component over the mass
    (x the nodes' positions: exact for a space that holds the geometry)."""
    return _by_component("centre_of_mass", gdim)


def angular_momentum_columns(gdim: int, reference: bool = False) -> tuple[str, ...]:
    """The total angular momentum about the origin, sum_i (x_i + u_i) x (M v)_i over the
    nodes (docs/method.md section 4): ``angular_momentum_z`` in 2D, ``angular_momentum_x``,
    ``angular_momentum_y``, ``angular_momentum_z`` in 3D, none in 1D. ``reference``: that
    about the nodes' reference positions, sum_i x_i x (M v)_i, which linear elasticity
    keeps (``angular_momentum_reference_z``, ...)."""
    name = "angular_momentum_reference" if reference else "angular_momentum"
    return {1: (), 2: (f"{name}_z",)}.get(gdim, _by_component(name, 3))


def body_columns(tag: int, gdim: int) -> tuple[str, ...]:
    """The columns of the body of cell tag ``tag``: its momentum, its centre of mass and its
    angular momentum about the origin, the sums over its nodes only (``momentum_<tag>_x``,
    ..., ``centre_of_mass_<tag>_x``, ..., ``angular_momentum_<tag>_z``, ...; in 1D
    ``momentum_<tag>``, ``centre_of_mass_<tag>``)."""
    return tuple(
        name.replace(quantity, f"{quantity}_{tag}", 1)
        for quantity, names in (
            ("momentum", momentum_columns(gdim)),
            ("centre_of_mass", centre_of_mass_columns(gdim)),
            ("angular_momentum", angular_momentum_columns(gdim)),
        )
        for name in names
    )


def contact_columns(count: int) -> tuple[str, ...]:
    """The contact totals of each contact term, in the order they were added (an obstacle
    is one, a contact pair two: its halves): ``contact_force_1``, ``contact_area_1``,
    ``contact_force_2``, ... (``contact_force`` and ``contact_area`` are their sums)."""
    return tuple(
        f"{name}_{k}" for k in range(1, count + 1) for name in ("contact_force", "contact_area")
    )


def added_columns(previous: Sequence[str], columns: Sequence[str]) -> list[str]:
    """The columns a restarted run adds to a history that had ``previous`` ones (its rows
    before the restart get ``nan`` there).

    Raises:
        ValueError: The run does not write some of the history's columns: their values
            after the restart could not be given.
    """
    missing = [name for name in previous if name not in columns]
    if missing:
        raise ValueError(
            f"its history columns {','.join(missing)} are not among this run's "
            f"({','.join(columns)}): a restart may add columns, not leave any out"
        )
    return [name for name in columns if name not in previous]


class History:
    """The rows of a run (dicts of numbers, one per time level), with column access.

    Args:
        rows: The rows, in time order.
        columns: The column names (default: those of the last row).
    """

    def __init__(self, rows=(), columns=None):
        self.rows: list[dict] = list(rows)
        self._columns = None if columns is None else list(columns)

    def append(self, row: dict) -> None:
        """Add the row of the next time level."""
        self.rows.append(row)

    def extend(self, rows) -> None:
        """Add the rows of the next time levels, in time order."""
        self.rows.extend(rows)

    @property
    def columns(self) -> list[str]:
        """The column names: those given, else those of the last row (a restart may
        continue older rows)."""
        if self._columns is not None:
            return list(self._columns)
        return list(self.rows[-1]) if self.rows else []

    def __len__(self) -> int:
        return len(self.rows)

    def __iter__(self) -> Iterator[dict]:
        return iter(self.rows)

    def __contains__(self, name: str) -> bool:
        return name in self.columns

    def __getitem__(self, key):
        """A column by name (an array), a row by index (a dict), rows by slice (a list)."""
        if isinstance(key, str):
            if key not in self:
                raise KeyError(f"no column {key!r} in the history (its columns: {self.columns})")
            return np.array([row.get(key, np.nan) for row in self.rows])
        return self.rows[key]

    # -- summary figures -----------------------------------------------------------------

    def energy_drift(self, column: str = "energy") -> float:
        """The relative change of an energy over the run: E(T) / E(0) - 1."""
        energy = self[column]
        return energy[-1] / energy[0] - 1

    def largest_rise(self, column: str = "energy_theta") -> float:
        """The largest one-step rise of an energy, relative to its initial value (E_Theta
        never rises for the hybrid scheme with Theta = 1, docs/method.md section 4)."""
        energy = self[column]
        if len(energy) < 2:
            return 0.0
        return float(np.max(np.diff(energy)) / abs(energy[0]))

    def mean_newton_iterations(self) -> float:
        """The mean Newton iterations per step (the row at t = 0 has no solve)."""
        iterations = self["newton_iterations"][1:]
        return float(np.mean(iterations)) if iterations.size else 0.0

    def cut_steps(self) -> int:
        """How many steps were cut (halved at least once) to let Newton converge."""
        return int(np.count_nonzero(self["step_cuts"] > 0)) if "step_cuts" in self else 0

    def contact_interval(self, column: str = "contact_force") -> tuple[float, float] | None:
        """The first and the last time level with a positive contact force, or None."""
        t, force = self["t"], self[column]
        touching = t[force > 0]
        return (float(touching[0]), float(touching[-1])) if touching.size else None

    def summary(self) -> dict[str, float]:
        """The figures every demo reports: drifts of E and E_Theta, the largest rise of
        E_Theta, the mean Newton iterations, the cut steps and the contact interval (NaN:
        no contact)."""
        interval = self.contact_interval() if "contact_force" in self else None
        first, last = interval if interval is not None else (np.nan, np.nan)
        return {
            "energy_drift": self.energy_drift("energy"),
            "energy_theta_drift": self.energy_drift("energy_theta"),
            "largest_rise": self.largest_rise(),
            "mean_newton_iterations": self.mean_newton_iterations(),
            "cut_steps": self.cut_steps(),
            "first_contact": first,
            "last_contact": last,
        }
