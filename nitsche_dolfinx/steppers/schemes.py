"""Time-marching schemes of docs/method.md section 3, as small classes with one interface.

Every step solves one nonlinear system for an acceleration-like unknown ``w``;
each scheme says how the new displacement, velocity and acceleration follow
from ``w`` (:meth:`TimeScheme.kinematics`, the same code for UFL expressions
and for numpy arrays) and which equation ``w`` solves
(:meth:`TimeScheme.residual`). Taking an acceleration as the unknown keeps the
explicit members (theta = 0, beta = 0) in the same mould.

- :class:`ThetaScheme`: ``u^{n+1} = u^n + tau v^{n+theta}``,
  ``v^{n+1} = v^n + tau a^{n+theta}``, equation at t^{n+1}; ``w = a^{n+1}``.
- :class:`NewmarkScheme`: ``u^{n+1} = u^n + tau v^n + tau^2/2 a^{n+2 beta}``,
  ``v^{n+1} = v^n + tau a^{n+gamma}``, equation at t^{n+1}; ``w = a^{n+1}``.
- :class:`CrankNicolson`: the theta-scheme with theta = 1/2.
- :class:`HybridScheme`: ``u^{n+1} = u^n + tau v^{n+1/2}``,
  ``v^{n+1} = v^n + tau a^{n+1/2}``, bulk terms and load at the midpoint, contact
  term Phi switching per quadrature point
  (:func:`~nitsche_dolfinx.contact.nitsche.hybrid_contact_force`);
  ``w = a^{n+1/2}``. With friction, the slip velocity is ``(u^{n+1} - u^n) / tau = v^{n+1/2}``
  and the threshold ``mu_f Phi``, consistent with the midpoint.
- :class:`VerletScheme`: explicit, ``u^{n+1} = u^n + tau v^n + tau^2/2 a^n``,
  ``v^{n+1} = v^n + tau/2 (a^n + a^{n+1})``, stepped without a solve
  (:mod:`~nitsche_dolfinx.steppers.explicit`).
"""

from __future__ import annotations

from typing import Protocol

from ..common.keys import Key
from ..common.parameters import require, require_choice, require_real

__all__ = [
    "CrankNicolson",
    "HybridScheme",
    "Model",
    "NewmarkScheme",
    "ThetaScheme",
    "TimeScheme",
    "VerletScheme",
    "SCHEMES",
    "make_scheme",
    "scheme_parameters",
]


class Model(Protocol):
    """What a time scheme asks of a model to write a step's equation (UFL forms).

    Implemented by :class:`~nitsche_dolfinx.model.problem.ContactProblem` and, for single
    contact quantities, by the classes of :mod:`nitsche_dolfinx.contact.terms`.
    """

    def inertia(self, acceleration, v):
        """<rho a, v> (zero for a diagonal mass, which the solver adds as a matrix)."""

    def operator(self, u, v, velocity=None):
        """The bulk and contact terms at one time level; ``velocity`` is u' there (for
        the friction term)."""

    def hybrid_operator(self, u_old, u_new, v, velocity=None):
        """The hybrid scheme's terms: the bulk at the midpoint and the contact term with
        the switch Phi; ``velocity`` is the step's mean velocity (u_new - u_old) / tau."""

    def load(self, v):
        """L(t)(v), the loads at the time the scheme has set."""

    def damping_force(self, velocity, v):
        """(C velocity, v), Rayleigh damping (docs/method.md section 14), or None without it."""


class TimeScheme:
    """Interface of a time scheme (see the module docstring).

    A scheme says how ``(u^{n+1}, v^{n+1}, a^{n+1})`` follow from the unknown
    (:meth:`kinematics`) and writes the step's equation with a :class:`Model`
    (:meth:`residual`): by default the equation at t^{n+1},
    ``<rho a^{n+1}, v> + B(u^{n+1}; v) = L^{n+1}(v)``.
    """

    name = "scheme"
    #: Whether the scheme is stepped without a solve (:class:`VerletScheme`).
    explicit = False
    #: Whether the step's equation holds at the step's middle t^{n+1/2}, so that the forces
    #: its energy identity sees are those of the middle (:class:`HybridScheme`), not the
    #: trapezoid of the two levels' (docs/method.md section 13).
    midpoint = False
    #: The constructor's parameters (the keys :func:`make_scheme` passes): their kind,
    #: default and meaning, for ``[scheme]`` in TOML and the demos' flags.
    parameters: dict[str, Key] = {}

    def kinematics(self, u, v, a, w, dt):
        """``(u^{n+1}, v^{n+1}, a^{n+1})`` from the state at t^n and the unknown ``w``."""
        raise NotImplementedError

    def residual(self, model: Model, w, u, v, a, dt, test):
        """The residual form whose root is ``w``: the equation at t^{n+1}."""
        u1, v1, a1 = self.kinematics(u, v, a, w, dt)
        form = model.inertia(a1, test) + model.operator(u1, test, v1) - model.load(test)
        return self.damped(form, model, u, v, a, w, dt, test)

    def damping_velocity(self, u, v, a, w, dt):
        """The velocity of the step's damping force C v (docs/method.md section 14): that of
        the equation's time level, v^{n+1}."""
        return self.kinematics(u, v, a, w, dt)[1]

    def damped(self, form, model: Model, u, v, a, w, dt, test):
        """``form`` plus the model's damping force at :meth:`damping_velocity` (``form``
        itself without damping: no term is added)."""
        damping = model.damping_force(self.damping_velocity(u, v, a, w, dt), test)
        return form if damping is None else form + damping

    def equation_time(self, t: float, dt: float) -> float:
        """The time at which the loads of the step's equation are evaluated."""
        return t + dt

    def displacement_coefficient(self, dt: float) -> float:
        """d u^{n+1} / d w: how Dirichlet values of u become values of w."""
        return self.kinematics(0.0, 0.0, 0.0, 1.0, dt)[0]

    def describe(self) -> str:
        """Short human-readable description, e.g. ``"newmark(beta=0.25, gamma=0.5)"``."""
        return self.name


class ThetaScheme(TimeScheme):
    """The theta-scheme; theta = 1/2 is Crank-Nicolson, theta = 1 backward Euler.

    Args:
        theta: In [0, 1].
    """

    name = "theta"
    parameters = {"theta": Key("number", 1.0, "theta of the theta scheme, in [0, 1]")}

    def __init__(self, theta: float = 1.0):
        require_real(theta, "theta", "theta")
        require(0.0 <= theta <= 1.0, "theta", theta, "theta must lie in [0, 1]")
        self.theta = float(theta)

    def kinematics(self, u, v, a, w, dt):
        th = self.theta
        u1 = u + dt * v + th * (1 - th) * dt**2 * a + th**2 * dt**2 * w
        v1 = v + (1 - th) * dt * a + th * dt * w
        return u1, v1, w

    def describe(self):
        return f"theta(theta={self.theta:g})"


class CrankNicolson(ThetaScheme):
    """Crank-Nicolson: the theta-scheme with theta = 1/2."""

    name = "cn"
    parameters = {}

    def __init__(self):
        super().__init__(0.5)

    def describe(self):
        return "cn"


class NewmarkScheme(TimeScheme):
    """Newmark's scheme; (beta, gamma) = (1/4, 1/2) is algebraically Crank-Nicolson.

    Args:
        beta: In [0, 1/2].
        gamma: In [0, 1].
    """

    name = "newmark"
    parameters = {
        "beta": Key("number", 0.25, "beta of the Newmark scheme, in [0, 1/2]"),
        "gamma": Key("number", 0.5, "gamma of the Newmark scheme, in [0, 1]"),
    }

    def __init__(self, beta: float = 0.25, gamma: float = 0.5):
        require_real(beta, "beta", "Newmark beta")
        require_real(gamma, "gamma", "Newmark gamma")
        require(0.0 <= beta <= 0.5, "beta", beta, "Newmark beta must lie in [0, 1/2]")
        require(0.0 <= gamma <= 1.0, "gamma", gamma, "Newmark gamma must lie in [0, 1]")
        self.beta = float(beta)
        self.gamma = float(gamma)

    def kinematics(self, u, v, a, w, dt):
        u1 = u + dt * v + (0.5 - self.beta) * dt**2 * a + self.beta * dt**2 * w
        v1 = v + (1 - self.gamma) * dt * a + self.gamma * dt * w
        return u1, v1, w

    def describe(self):
        return f"newmark(beta={self.beta:g}, gamma={self.gamma:g})"


class HybridScheme(TimeScheme):
    """The hybrid Crank-Nicolson/midpoint scheme of Chouly, Hild & Renard.

    The unknown is ``w = a^{n+1/2}``; ``a^{n+1} = 2 w - a^n`` is kept for output only.
    """

    name = "hybrid"
    midpoint = True

    def kinematics(self, u, v, a, w, dt):
        u1 = u + dt * v + dt**2 / 2 * w
        v1 = v + dt * w
        return u1, v1, 2 * w - a

    def residual(self, model, w, u, v, a, dt, test):
        u1, _, _ = self.kinematics(u, v, a, w, dt)
        # (u1 - u) / dt, without the round-off of subtracting u (amplified by 1/gamma_h
        # in the friction term, it would be the floor of the residual once sticking)
        mean_velocity = v + dt / 2 * w
        form = (
            model.inertia(w, test)
            + model.hybrid_operator(u, u1, test, mean_velocity)
            - model.load(test)
        )
        return self.damped(form, model, u, v, a, w, dt, test)

    def damping_velocity(self, u, v, a, w, dt):
        """The step's mean velocity v^{n+1/2} = (u^{n+1} - u^n) / tau = v^n + tau/2 w: the
        damping force C v^{n+1/2} keeps the energy identity (docs/method.md section 14)."""
        return v + dt / 2 * w

    def equation_time(self, t, dt):
        return t + dt / 2


#: The share of the estimated stable step that ``dt = "auto"`` takes. The estimate is the
#: linear bound with every contact point active; the switching of the contact status pumps
#: energy below it (the bar, gamma0 = 0.1, 4 impacts: +0.4% at 0.5, +26% at 0.6, +120% at
#: 0.8 of the bound), so half of it.
DEFAULT_SAFETY = 0.5
#: What the verlet scheme solves a consistent mass with (none: a diagonal mass only).
MASS_SOLVERS = ("none", "cg")


class VerletScheme(TimeScheme):
    """The explicit Verlet (central difference) scheme: Newmark with beta = 0 and
    gamma = 1/2, stepped without a solve by
    :class:`~nitsche_dolfinx.steppers.explicit.ExplicitStepper`
    (a diagonal mass, or the consistent one with ``mass_solver="cg"``); ``w = a^{n+1}``.

    Args:
        safety: The share of the estimated stable step that ``dt = "auto"`` takes, in (0, 1].
        force_dt: Take a given dt above the estimated stable step (else refused).
        mass_solver: How a step solves with the consistent mass: ``"none"`` (only a
            diagonal mass is taken) or ``"cg"`` (conjugate gradients with Jacobi).
    """

    name = "verlet"
    explicit = True
    parameters = {
        "safety": Key("number", DEFAULT_SAFETY, "verlet: the share of the stable step that "
                      "dt = auto takes, in (0, 1]"),
        "force_dt": Key("boolean", False, "verlet: take a dt above the estimated "
                                 "stable step"),
        "mass_solver": Key("string", "none", "verlet: the solve a step makes with the "
                           "consistent mass (none: a diagonal mass only; cg: conjugate "
                           "gradients with Jacobi)", choices=MASS_SOLVERS),
    }  # fmt: skip

    def __init__(self, safety: float = DEFAULT_SAFETY, force_dt: bool = False,
                 mass_solver: str = "none"):  # fmt: skip
        require_real(safety, "safety", "the safety factor")
        require(0.0 < safety <= 1.0, "safety", safety, "the safety factor must lie in (0, 1]")
        require(isinstance(force_dt, bool), "force_dt", force_dt,
                "true or false")  # fmt: skip
        require_choice(mass_solver, MASS_SOLVERS, "mass_solver", "the mass solver")
        self.safety = float(safety)
        self.force_dt = force_dt
        self.mass_solver = mass_solver

    def kinematics(self, u, v, a, w, dt):
        u1 = u + dt * v + dt**2 / 2 * a
        v1 = v + dt / 2 * (a + w)
        return u1, v1, w

    def describe(self):
        solver = "" if self.mass_solver == "none" else f", mass_solver={self.mass_solver}"
        return f"verlet(safety={self.safety:g}{solver})"


#: The schemes by name: the demos' ``--scheme`` flag and ``[scheme] name`` in TOML. A
#: scheme's ``parameters`` are its keys in ``[scheme]`` and its flags.
SCHEMES: dict[str, type[TimeScheme]] = {
    "hybrid": HybridScheme,
    "theta": ThetaScheme,
    "newmark": NewmarkScheme,
    "cn": CrankNicolson,
    "verlet": VerletScheme,
}


def scheme_parameters() -> dict[str, Key]:
    """The parameters of every scheme of :data:`SCHEMES`, by name (one key per name)."""
    keys: dict[str, Key] = {}
    for cls in SCHEMES.values():
        keys.update(cls.parameters)
    return keys


def make_scheme(
    name: str, theta: float = 1.0, beta: float = 0.25, gamma: float = 0.5,
    safety: float = DEFAULT_SAFETY, force_dt: bool = False, mass_solver: str = "none",
) -> TimeScheme:  # fmt: skip
    """The scheme called ``name`` (a key of :data:`SCHEMES`) with the parameters it takes
    (the others are ignored)."""
    require_choice(name, SCHEMES, "scheme", "scheme")
    cls = SCHEMES[name]
    given = {"theta": theta, "beta": beta, "gamma": gamma, "safety": safety,
             "force_dt": force_dt, "mass_solver": mass_solver}  # fmt: skip
    return cls(**{key: given[key] for key in cls.parameters})
