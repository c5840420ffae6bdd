"""The parameters of a run, each validated once, here.

The Python API, the demos' flags and the TOML configuration all build these
objects, so that a check and its message exist in one place. A bad value raises
:class:`ParameterError`, which knows the parameter's name and value; each entry
point names the parameter in its own words (:meth:`ParameterError.named`):
``gamma0=0.0`` for the API, ``--gamma0 0`` on the command line,
``[nitsche] gamma0 = 0`` in a TOML file.

The fields carry the names of the keyword arguments of the API
(:class:`~nitsche_dolfinx.model.problem.ContactProblem`,
:class:`~nitsche_dolfinx.simulation.Simulation` and its ``run``), so that
``ContactProblem(mesh, tags, material, **vars(nitsche), **vars(discretisation))``
works.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from .keys import LARGEST, is_integer, is_number, shown

__all__ = [
    "CONTACT_METHODS",
    "DEFAULT_GAMMA0_E",
    "GAMMA0_E_RANGE",
    "GAMMA0_SCALINGS",
    "MASS_MATRICES",
    "MAX_QUADRATURE_DEGREE",
    "MAX_STEPS",
    "Discretisation",
    "NitscheParameters",
    "OutputParameters",
    "ParameterError",
    "SolverParameters",
    "TimeStepping",
    "require",
    "require_choice",
    "require_integer",
    "require_positive",
    "require_real",
]

#: Contact methods: Nitsche, penalty, and the mixed method (a Lagrange multiplier, CN only).
CONTACT_METHODS = ("nitsche", "penalty", "mixed")
#: How gamma0 makes gamma_h: ``"absolute"``, gamma_h = gamma0 h (gamma0 in 1/stress, the
#: paper's), or ``"E"``, gamma_h = gamma0 h / E (gamma0 without units).
GAMMA0_SCALINGS = ("absolute", "E")
#: The range of the dimensionless gamma0 E: beyond it the contact is so soft that the
#: obstacle is hardly there (the contact stiffness 1/gamma_h a hundredth of the body's
#: E/h), or so stiff that the linear solves lose every digit. Its top also bounds
#: abs(Theta) gamma0 E: the weight of the term Theta gamma_h sigma_n(u) sigma_n(v) against
#: the body's stiffness (docs/method.md section 10).
GAMMA0_E_RANGE = (1e-12, 1e2)
#: The default of gamma0 relative to the body's stiffness: gamma0 E = 1e-3 (gamma_h = 1e-3
#: h / E), inside the stable range of P1 and P2 in any units (docs/method.md section 10).
DEFAULT_GAMMA0_E = 1e-3
#: The most steps a run may make: more is a mistake in dt or t_end, not a run.
MAX_STEPS = 10_000_000
#: The highest quadrature degree: the integrands are polynomials of degree at most
#: 2 degree + 2 (6 for P2 on curved cells) or piecewise ones ([x]_+); a higher degree
#: only adds points (about (q/2)^d per cell).
MAX_QUADRATURE_DEGREE = 30
#: Mass matrices: consistent, lumped (P1 row sums, P2 HRZ), redistributed (P1, the modified mass).
MASS_MATRICES = ("consistent", "lumped", "redistributed")


class ParameterError(ValueError):
    """A parameter out of its range: its name, its value and what it must be.

    ``str(error)`` names the parameter as the Python API does (``dt=-0.1: ...``; a long
    value cut to its start and its length, :func:`~nitsche_dolfinx.common.keys.shown`);
    :meth:`named` gives the same error named as another entry point names it.
    """

    def __init__(self, name: str, value, requirement: str, label: str | None = None):
        self.name = name
        self.value = value
        self.requirement = requirement
        #: Whether the label is the error's own words (not ``name=value``).
        self.explicit = label is not None
        self.label = label if label is not None else f"{name}={shown(value)}"
        super().__init__(f"{self.label}: {requirement}")

    def named(self, label: str) -> ParameterError:
        """The same error with ``label`` (e.g. ``"--gamma0 0"``) naming the value."""
        error = ParameterError(self.name, self.value, self.requirement, label)
        error.explicit = self.explicit
        return error


def require(condition: bool, name: str, value, requirement: str) -> None:
    """Raise :class:`ParameterError` unless ``condition``."""
    if not condition:
        raise ParameterError(name, value, requirement)


def require_choice(value, choices, name: str, what: str) -> None:
    """Raise :class:`ParameterError` unless ``value`` is one of ``choices``."""
    known = isinstance(value, str) and value in choices
    require(known, name, value, f"unknown {what}; choose one of {', '.join(choices)}")


def require_real(value, name: str, what: str) -> float:
    """``value`` as a float: a real number (not a string or a bool), finite, of magnitude
    at most :data:`~nitsche_dolfinx.common.keys.LARGEST` (the forms multiply up to three such
    numbers); :class:`ParameterError` naming ``name`` otherwise."""
    require(is_number(value), name, value, f"{what} must be a number, got {type(value).__name__}")
    require(math.isfinite(value), name, value, f"{what} must be finite")
    require(
        abs(value) <= LARGEST,
        name,
        value,
        f"{what} must be at most {LARGEST:g} in magnitude (the forms multiply up to three "
        "such numbers)",
    )
    return float(value)


def require_positive(value, name: str, what: str) -> float:
    """``value`` as a float in [1 / LARGEST, LARGEST] (see :func:`require_real`)."""
    require_real(value, name, what)
    require(
        value >= 1.0 / LARGEST,
        name,
        value,
        f"{what} must be positive, at least {1.0 / LARGEST:g} (the forms multiply up to "
        "three such numbers)",
    )
    return float(value)


def require_integer(value, name: str, what: str, low: int, high: int | None = None) -> int:
    """``value`` as an int from ``low`` to ``high`` (None: no upper bound)."""
    fits = is_integer(value) and low <= value and (high is None or value <= high)
    span = f"from {low} to {high}" if high is not None else f">= {low}"
    require(fits, name, value, f"{what} must be an integer {span}")
    return int(value)


@dataclass(frozen=True)
class TimeStepping:
    """The time step tau and the final time T: 0 < dt <= t_end, both finite. T is reached
    exactly: when it is not a multiple of tau, the last step is shorter. A step whose
    Newton solve fails is halved, down to tau / 2^max_step_cuts, before the run stops
    (docs/method.md section 8). The schemes multiply by dt^2: dt lies in
    [1 / LARGEST, LARGEST], where dt^2 is a normal double."""

    dt: float
    t_end: float
    max_step_cuts: int = 5

    def __post_init__(self):
        if self.automatic:  # the verlet scheme's stable step, known with the problem
            require_positive(self.t_end, "t_end", "the final time")
            require(self.t_end <= LARGEST, "t_end", self.t_end, f"at most {LARGEST:g}")
            require_integer(self.max_step_cuts, "max_step_cuts", "the number of step cuts", 0, 30)
            return
        require_positive(self.dt, "dt", "the time step")
        require_real(self.t_end, "t_end", "the final time")
        require(
            self.t_end >= self.dt,
            "t_end",
            self.t_end,
            f"the final time must be finite and at least one time step (dt={self.dt!r})",
        )
        steps = self.t_end / self.dt
        require(
            steps <= MAX_STEPS,
            "t_end",
            self.t_end,
            f"t_end / dt = {steps:.3g} steps, more than {MAX_STEPS:.0e}: check dt={self.dt!r}",
        )
        require_integer(self.max_step_cuts, "max_step_cuts", "the number of step cuts", 0, 30)

    @property
    def automatic(self) -> bool:
        """Whether dt is ``"auto"`` (the verlet scheme's stable step, found with the problem)."""
        return isinstance(self.dt, str) and self.dt == "auto"

    @property
    def num_steps(self) -> int:
        """The number of steps to t_end: t_end / dt rounded up (a shorter last step), but
        for the round-off of t_end / dt (6 / 0.015 is 400 steps)."""
        if self.automatic:
            raise ValueError("dt='auto': the number of steps is the Simulation's (num_steps)")
        return max(1, math.ceil(self.t_end / self.dt - 1e-9))


@dataclass(frozen=True)
class NitscheParameters:
    """The contact terms: gamma_h = gamma0 h_T (or gamma0 h_T / E, see ``gamma0_scaling``),
    the variant Theta, Coulomb's mu_f and the method (see docs/method.md sections 2 and 10).

    gamma0 and Theta are checked against the body's Young modulus by :meth:`check_scale`
    (:class:`~nitsche_dolfinx.model.problem.ContactProblem` calls it). ``gamma0=None`` (the
    default) is :data:`DEFAULT_GAMMA0_E` relative to the body's stiffness, whatever the
    units: gamma0 = 1e-3 / E, or 1e-3 with ``gamma0_scaling="E"`` (:meth:`resolved`)."""

    gamma0: float | None = None
    nitsche_theta: float = 1.0
    friction: float | None = None
    method: str = "nitsche"
    gamma0_scaling: str = "absolute"

    def __post_init__(self):
        if self.gamma0 is not None:
            require_positive(self.gamma0, "gamma0", "the Nitsche parameter")
        require_choice(self.gamma0_scaling, GAMMA0_SCALINGS, "gamma0_scaling", "scaling of gamma0")
        theta = self.nitsche_theta
        require(
            is_number(theta) and math.isfinite(theta),
            "nitsche_theta",
            theta,
            "the Nitsche variant must be a finite number (1 symmetric, 0 non-symmetric, -1 skew)",
        )
        if self.friction is not None:
            require_real(self.friction, "friction", "the friction coefficient")
            require(
                self.friction >= 0,
                "friction",
                self.friction,
                "the friction coefficient must be >= 0 (or None: frictionless)",
            )
        require_choice(self.method, CONTACT_METHODS, "method", "contact method")
        require(
            self.method != "mixed" or self.friction is None,
            "friction",
            self.friction,
            "the mixed method is frictionless",
        )

    def resolved(self, E: float) -> NitscheParameters:
        """These parameters with gamma0 a number: as given, or by default
        :data:`DEFAULT_GAMMA0_E` / E (``"absolute"``; ``E`` the largest Young modulus of the
        body, the stiffest material's) or :data:`DEFAULT_GAMMA0_E` (``"E"``)."""
        if self.gamma0 is not None:
            return self
        absolute = self.gamma0_scaling == "absolute"
        return replace(self, gamma0=DEFAULT_GAMMA0_E / E if absolute else DEFAULT_GAMMA0_E)

    def check_scale(self, E: float) -> float:
        """The dimensionless gamma0 E (``gamma0_scaling`` ``"absolute"``) or gamma0
        (``"E"``), checked against :data:`GAMMA0_E_RANGE`, and abs(Theta) times it against
        the range's top; ``E`` is the body's Young modulus (docs/method.md section 10)."""
        gamma0 = self.resolved(E).gamma0
        absolute = self.gamma0_scaling == "absolute"
        dimensionless = gamma0 * E if absolute else gamma0
        low, high = GAMMA0_E_RANGE
        in_words = f"gamma0 * E = {dimensionless:.3g}" if absolute else "gamma0"
        require(
            low <= dimensionless <= high,
            "gamma0",
            self.gamma0,
            f"{in_words} is outside [{low:g}, {high:g}]: above, the contact is a hundred times "
            f"softer than the body (the obstacle is hardly there); below, the linear solves "
            f"lose every digit (about 1e-3 suits P1 and P2, docs/method.md section 10)",
        )
        weight = abs(self.nitsche_theta) * dimensionless
        require(
            weight <= high,
            "nitsche_theta",
            self.nitsche_theta,
            f"|Theta| gamma0{' E' * absolute} = {weight:.3g} is above {high:g}: the term "
            "Theta gamma_h sigma_n(u) sigma_n(v) would outweigh the body's stiffness a(u, v) "
            f"more than {high:g}-fold (Theta > 0: A_Theta no longer coercive; Theta < 0: the "
            "body lost in round-off, overflow further on); the variants are Theta in [-1, 1] "
            "(docs/method.md section 10)",
        )
        return dimensionless


@dataclass(frozen=True)
class Discretisation:
    """The displacement space (Lagrange of ``degree`` 1 or 2), the mass matrix and the
    quadrature degree of every integral (None: chosen from the degrees)."""

    degree: int = 1
    mass: str = "consistent"
    quadrature_degree: int | None = None

    def __post_init__(self):
        require(
            is_integer(self.degree) and self.degree in (1, 2),
            "degree",
            self.degree,
            "the degree must be 1 or 2",
        )
        require_choice(self.mass, MASS_MATRICES, "mass", "mass")
        require(
            self.mass != "redistributed" or self.degree == 1,
            "mass",
            self.mass,
            f"this mass needs P1 elements, got degree={self.degree!r}",
        )
        if self.quadrature_degree is not None:
            require_integer(
                self.quadrature_degree,
                "quadrature_degree",
                "the quadrature degree",
                0,
                MAX_QUADRATURE_DEGREE,
            )


@dataclass(frozen=True)
class OutputParameters:
    """What a run writes: fields every ``output_every`` steps (0: never) and a checkpoint
    every ``checkpoint_every`` steps (0: only when the run stops early)."""

    output_every: int = 0
    checkpoint_every: int = 0

    def __post_init__(self):
        for name in ("output_every", "checkpoint_every"):
            value = getattr(self, name)
            require(is_integer(value) and value >= 0, name, value, "must be an integer >= 0")


@dataclass(frozen=True)
class SolverParameters:
    """How a step's Newton solver works (see :class:`~nitsche_dolfinx.simulation.Simulation`):
    the bulk Jacobian assembled once, a factorisation kept as GMRES preconditioner for up
    to ``preconditioner_lag`` iterations, the guarded Newton for friction."""

    reuse_jacobian: bool = True
    preconditioner_lag: int = 0
    guard_friction: bool = True

    def __post_init__(self):
        for name in ("reuse_jacobian", "guard_friction"):
            value = getattr(self, name)
            require(isinstance(value, bool), name, value, "must be True or False")
        require_integer(
            self.preconditioner_lag, "preconditioner_lag", "the preconditioner's lag", 0
        )
