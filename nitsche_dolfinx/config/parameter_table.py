"""Every run parameter under its three names: the API's keyword, the TOML key, the demo flag.

:data:`PARAMETERS` is the one source of what a parameter is called where, its kind, its
default and its meaning. The TOML schema (:mod:`~nitsche_dolfinx.config.schema`) takes the keys
of ``[scheme]``, ``[nitsche]``, ``[solver]``, ``[material]``, ``[output]`` and the
elements of ``[mesh]`` from it, the demos' shared flags
(:mod:`~nitsche_dolfinx.cli.arguments`) are made from it, and an error of a parameter
(:class:`~nitsche_dolfinx.common.parameters.ParameterError`, which knows the API's name) is
named by it under the TOML key or the flag that set the value. Where the names differ
(``nitsche_theta``, ``[nitsche] theta``, ``--nitsche-theta``; ``friction``, ``--mu``) the
table lists them side by side. :func:`markdown` prints it: ``docs/parameters.md``, made
by ``nitsche-dolfinx parameters``.

The API's defaults are read from the signatures of the classes and functions that take
the keywords; the TOML defaults are the table's; a demo's flag has the TOML default
unless the demo gives its own (``flag_default``).
"""

from __future__ import annotations

import inspect
import re
from dataclasses import dataclass, replace

from ..common.keys import REQUIRED, Key, toml_text
from ..common.parameters import CONTACT_METHODS, GAMMA0_SCALINGS, MASS_MATRICES
from ..model.problem import ContactProblem
from ..physics.hyperelastic import LAWS
from ..physics.material import Material
from ..post.reports import markdown_table
from ..simulation import Simulation
from ..solvers.linear_solvers import LINEAR_SOLVERS
from ..steppers.schemes import SCHEMES, make_scheme, scheme_parameters

__all__ = [
    "OWNERS",
    "PARAMETERS",
    "Parameter",
    "by_flag",
    "by_name",
    "in_words_of",
    "markdown",
    "toml_keys",
]

#: The classes and functions that take the parameters as keywords, by name.
OWNERS = {
    "ContactProblem": ContactProblem,
    "Simulation": Simulation,
    "Simulation.run": Simulation.run,
    "make_scheme": make_scheme,
    "Material": Material,
    "Material.from_lame": Material.from_lame,
    "ContactProblem.set_initial_conditions": ContactProblem.set_initial_conditions,
    "ContactProblem.set_damping": ContactProblem.set_damping,
}

#: A flag's default that is the demo's own (given to :func:`~nitsche_dolfinx.cli.arguments.
#: add_method_arguments` and its kin), not the TOML default.
DEMO_DEFAULT = "the demo's"


@dataclass(frozen=True)
class Parameter:
    """One run parameter: its keyword ``name`` in the API (also the name its
    :class:`~nitsche_dolfinx.common.parameters.ParameterError` carries) and the callable that
    takes it (a key of :data:`OWNERS`), its TOML key (``"[nitsche] theta"``; ``"[petsc]"``
    for a whole table; None: not in TOML), its demo flag (None: no flag), and its kind,
    TOML default and meaning (``key``). ``aliases``: the names under which the library's
    checks of the state it sets report an error, besides ``name``."""

    name: str
    owner: str
    toml: str | None
    flag: str | None
    key: Key
    flag_default: str | None = None  # in words; None: the TOML default
    api_default: str | None = None  # the API's default in words, when not a plain value
    aliases: tuple[str, ...] = ()  # other names its errors carry
    keyword: str | None = None  # the owner's keyword, when not ``name``

    @property
    def argument(self) -> str:
        """The owner's keyword: :attr:`keyword`, or ``name``."""
        return self.keyword or self.name

    @property
    def table(self) -> str | None:
        """The TOML table: ``"nitsche"`` for ``"[nitsche] theta"``."""
        return None if self.toml is None else self.toml.split("]")[0].lstrip("[")

    @property
    def toml_key(self) -> str | None:
        """The key in its table: ``"theta"`` for ``"[nitsche] theta"`` (None: the table)."""
        if self.toml is None or "] " not in self.toml:
            return None
        return self.toml.split("] ", 1)[1]

    @property
    def dest(self) -> str | None:
        """The attribute of the parsed flags: ``"nitsche_theta"`` for ``--nitsche-theta``."""
        return None if self.flag is None else self.flag.lstrip("-").replace("-", "_")

    def api(self) -> str:
        """The keyword with what takes it: ``ContactProblem(nitsche_theta=)``."""
        return f"{self.owner}({self.argument}=)"

    def api_default_text(self) -> str:
        """The API's default, read from the owner's signature."""
        if self.api_default is not None:
            return self.api_default
        default = inspect.signature(OWNERS[self.owner]).parameters[self.argument].default
        if default is inspect.Parameter.empty:
            return "required"
        return "none" if default is None else toml_text(default)

    def flag_default_text(self) -> str:
        """The flag's default in words (empty: no flag)."""
        if self.flag is None:
            return ""
        if self.flag_default is None:
            return self.key.default_text()
        return str(self.flag_default)


def _scheme_rows() -> list[Parameter]:
    """The parameters of the schemes, as the scheme classes describe them."""
    return [
        Parameter(name, "make_scheme", f"[scheme] {name}", "--" + name.replace("_", "-"),
                  replace(key, checked_by_library=True))
        for name, key in scheme_parameters().items()
    ]  # fmt: skip


def _key(kind, default, meaning, choices=(), shown=None) -> Key:
    # the parameter objects and classes check these values, in their own words
    return Key(kind, default, meaning, tuple(choices), shown, checked_by_library=True)


#: The default of gamma0 in words: gamma0 E = 1e-3 in any units
#: (:data:`~nitsche_dolfinx.common.parameters.DEFAULT_GAMMA0_E`).
_GAMMA0_DEFAULT = "gamma0 E = 1e-3, any units (gamma0_scaling E: gamma0 = 1e-3)"

#: Every run parameter, in the order of the docs: scheme and steps, contact, elements,
#: material, initial values, solver, output.
PARAMETERS: tuple[Parameter, ...] = (
    Parameter("scheme", "Simulation", "[scheme] name", "--scheme",
              _key("string", "hybrid", "the time scheme (API: a TimeScheme, e.g. "
                   "make_scheme(name))", SCHEMES)),
    Parameter("dt", "Simulation", "[scheme] dt", "--dt",
              _key("step", REQUIRED, "time step tau (verlet: \"auto\", the safety share of "
                   "its estimated stable step)"), DEMO_DEFAULT),
    Parameter("t_end", "Simulation", "[scheme] t_end", "--t-end",
              _key("number", REQUIRED, "final time T (a shorter last step reaches it)"),
              DEMO_DEFAULT),
    *_scheme_rows(),
    Parameter("max_step_cuts", "Simulation", "[scheme] max_step_cuts", "--max-step-cuts",
              _key("integer", 5, "a step whose Newton fails is halved, down to dt / 2^N, "
                   "before the run stops")),
    Parameter("method", "ContactProblem", "[nitsche] method", "--method",
              _key("string", "nitsche", "contact method (mixed: a Lagrange multiplier, one "
                   "obstacle, scheme cn)", CONTACT_METHODS)),
    Parameter("gamma0", "ContactProblem", "[nitsche] gamma0", "--gamma0",
              _key("number", None, "Nitsche parameter: gamma_h = gamma0 h (penalty: eps = "
                   "gamma0 h)", shown=_GAMMA0_DEFAULT), DEMO_DEFAULT,
              api_default=_GAMMA0_DEFAULT),
    Parameter("gamma0_scaling", "ContactProblem", "[nitsche] gamma0_scaling",
              "--gamma0-scaling",
              _key("string", "absolute", "absolute: gamma_h = gamma0 h (gamma0 in 1/stress, "
                   "the paper's); E: gamma_h = gamma0 h / E (gamma0 without units, about "
                   "1e-3)", GAMMA0_SCALINGS)),
    Parameter("nitsche_theta", "ContactProblem", "[nitsche] theta", "--nitsche-theta",
              _key("number", 1.0, "the Nitsche variant Theta: 1 symmetric, 0 non-symmetric, "
                   "-1 skew-symmetric")),
    Parameter("friction", "ContactProblem", "[nitsche] friction", "--mu",
              _key("number", None, "Coulomb coefficient mu_f >= 0", shown="frictionless"),
              DEMO_DEFAULT),
    Parameter("degree", "ContactProblem", "[mesh] degree", "--degree",
              _key("integer", 1, "Lagrange degree of the displacement: 1 or 2"), DEMO_DEFAULT),
    Parameter("mass", "ContactProblem", "[mesh] mass", "--mass",
              _key("string", "consistent",
                   "mass matrix (lumped: P1 row sums, P2 HRZ with verlet; redistributed: P1)",
                   MASS_MATRICES)),
    Parameter("quadrature_degree", "ContactProblem", "[mesh] quadrature_degree", None,
              _key("integer", None, "quadrature degree of every integral",
                   shown="2 degree (+ 2 on curved cells)")),
    Parameter("E", "Material", "[material] E", "--E",
              _key("number", None, "Young's modulus (give E and nu, or lmbda and mu)"),
              DEMO_DEFAULT),
    Parameter("nu", "Material", "[material] nu", None,
              _key("number", None, "Poisson's ratio, in (-1, 1/2)")),
    Parameter("lmbda", "Material.from_lame", "[material] lmbda", None,
              _key("number", None, "first Lame coefficient")),
    Parameter("mu", "Material.from_lame", "[material] mu", None,
              _key("number", None, "shear modulus (not the friction coefficient, --mu)")),
    Parameter("rho", "Material", "[material] rho", None, _key("number", 1.0, "density")),
    Parameter("law", "Material", "[material] law", "--law",
              _key("string", "linear", "the material law: linear elasticity (small strains) "
                   "or hyperelastic at finite strains, St Venant-Kirchhoff (svk) or "
                   "compressible neo-Hookean, with E and nu their small-strain values",
                   ("linear", *LAWS))),
    Parameter("damping_alpha", "ContactProblem.set_damping", "[damping] alpha", None,
              _key("number", 0.0, "Rayleigh damping C = alpha M + beta K: alpha >= 0 "
                   "[1/time], the mass-proportional part"), keyword="alpha"),
    Parameter("damping_beta", "ContactProblem.set_damping", "[damping] beta", None,
              _key("number", 0.0, "Rayleigh damping: beta >= 0 [time], the part "
                   "proportional to the bulk stiffness"), keyword="beta"),
    Parameter("displacement", "ContactProblem.set_initial_conditions", "[initial] displacement",
              None, _key("value in x", None, "u0", shown="0"),
              aliases=("initial_displacement", "initial displacement")),
    Parameter("velocity", "ContactProblem.set_initial_conditions", "[initial] velocity", None,
              _key("value in x", None, "v0 (or per body: [[body]])", shown="0"),
              aliases=("initial_velocity", "initial velocity")),
    Parameter("linear_solver", "Simulation", "[solver] linear_solver", None,
              _key("string", "auto", "linear solver preset (auto: chosen from the problem)",
                   LINEAR_SOLVERS)),
    Parameter("reuse_jacobian", "Simulation", "[solver] reuse_jacobian", None,
              _key("boolean", True, "assemble the bulk Jacobian once")),
    Parameter("preconditioner_lag", "Simulation", "[solver] preconditioner_lag", None,
              _key("integer", 0, "keep a factorisation as GMRES preconditioner up to this "
                   "many iterations (0: never)")),
    Parameter("guard_friction", "Simulation", "[solver] guard_friction", None,
              _key("boolean", True, "solve friction by the guarded Newton")),
    Parameter("petsc_options", "Simulation", "[petsc]", "--petsc",
              _key("options", None, "PETSc options of the step's solver, flat: snes_rtol = "
                   "1e-8 (flag: KEY=VALUE, repeatable, nitsche-dolfinx run only)")),
    Parameter("progress", "Simulation", None, "--quiet",
              _key("boolean", None, "show the progress of the run (the flag: do not)"),
              flag_default="false"),
    Parameter("out", "Simulation.run", "[output] dir", "--out",
              _key("string", None, "output folder (API: none, nothing is written)",
                   shown="out/<TOML name>"), DEMO_DEFAULT),
    Parameter("output_every", "Simulation.run", "[output] every", "--output-every",
              _key("integer", None, "write the fields every N steps (0: never)",
                   shown="about 50 outputs"), DEMO_DEFAULT),
    Parameter("checkpoint_every", "Simulation.run", "[output] checkpoint_every",
              "--checkpoint-every",
              _key("integer", 0, "save the state every N steps (0: only when the run stops "
                   "early)")),
    Parameter("columns", "Simulation.run", "[output] columns", None,
              _key("strings", None, "the columns of history.csv, any of the run's: those of "
                   "the demos, dt, step_cuts, momentum_x, ... and centre_of_mass_x, ... (1D: "
                   "momentum, centre_of_mass), contact_force_k and contact_area_k (the k-th "
                   "obstacle; a contact pair counts two), friction_dissipation, "
                   "energy_balance_residual, damping_dissipation, the probes' names",
                   shown="those of the 2D/3D demos that the run gives, then the probes"),
              api_default="HISTORY_COLUMNS"),
    Parameter("restart", "Simulation.run", None, "--restart",
              _key("boolean", None, "continue from the checkpoint in OUT/checkpoint"),
              flag_default="false"),
)  # fmt: skip

_BY_NAME = {
    name: parameter for parameter in PARAMETERS for name in (parameter.name, *parameter.aliases)
}


def by_name(name: str) -> Parameter | None:
    """The parameter whose API keyword (or one of its aliases) is ``name``, or None."""
    return _BY_NAME.get(name)


def by_flag(flag: str) -> Parameter:
    """The parameter of the flag ``flag`` (``"--nitsche-theta"``)."""
    return next(parameter for parameter in PARAMETERS if parameter.flag == flag)


#: ``name=value`` in the API's words: a name, ``=`` (not ``==``), a quoted or plain value.
_API_ASSIGNMENT = re.compile(r"(?<![\w.\[])([A-Za-z_]\w*)=(?!=)('[^']*'|[^\s,;)]+)")


def in_words_of(text: str, entry: str) -> str:
    """``text`` (what a value must be, shared by the entry points) with each ``name=value``
    of a run parameter, the API's words, written as the entry point ``entry`` writes it:
    ``"toml"``, ``[table] key = value``; ``"flag"``, ``--flag value``. A name that is
    not a run parameter of that entry point is left as it is."""

    def spoken(match: re.Match) -> str:
        parameter, value = by_name(match[1]), match[2]
        switch = parameter is not None and parameter.key.kind == "boolean"
        if parameter is not None and entry == "toml" and parameter.toml_key:
            return f"{parameter.toml} = {value.lower() if switch else value}"
        if parameter is not None and entry == "flag" and parameter.flag:
            if switch:  # a switch: the flag alone sets it
                return parameter.flag if value == "True" else f"no {parameter.flag}"
            return f"{parameter.flag} {value.strip(chr(39))}"
        return match[0]

    return _API_ASSIGNMENT.sub(spoken, text)


def toml_keys(table: str) -> dict[str, Key]:
    """The keys of the TOML table ``table`` that the table of parameters describes."""
    return {p.toml_key: p.key for p in PARAMETERS if p.table == table and p.toml_key}


_BAR = " \\| "  # a | inside a cell of a markdown table


def _cell(text: str | None) -> str:
    return f"`{text}`" if text else ""


def markdown() -> str:
    """``docs/parameters.md``: the table of :data:`PARAMETERS`, with the names that differ
    between the entry points listed after it."""
    lines = [
        "# Run parameters",
        "",
        "<!-- Generated by `nitsche-dolfinx parameters > docs/parameters.md` from",
        "nitsche_dolfinx/config/parameter_table.py; do not edit by hand. -->",
        "",
        "Every parameter of a run under its three names: the keyword of the Python API, the",
        "key of a TOML configuration (`nitsche-dolfinx run`; every key: `nitsche-dolfinx",
        "schema`) and the flag of the demos. Defaults: the API's (from the signatures), the",
        "TOML file's, and the flag's where a demo has it (*the demo's*: each demo sets its",
        "own). A bad value is refused before anything is computed, named as the entry point",
        "names it: `nitsche_theta=1e+300`, `[nitsche] theta = 1e+300`, `--nitsche-theta",
        "1e+300` (docs/method.md section 10).",
        "",
    ]
    rows = []
    for p in PARAMETERS:
        choices = f" ({_BAR.join(p.key.choices)})" if p.key.choices else ""
        defaults = " / ".join(
            text or "-"
            for text in (p.api_default_text(), p.key.default_text() * bool(p.toml),
                         p.flag_default_text())
        )  # fmt: skip
        rows.append([_cell(p.api()), _cell(p.toml), _cell(p.flag), p.key.kind, defaults,
                     p.key.meaning + choices])  # fmt: skip
    header = ["API", "TOML", "flag", "kind", "default: API / TOML / flag", "meaning"]
    lines.append(markdown_table(header, rows))
    lines += ["", "Names that differ between the entry points:", ""]
    for p in PARAMETERS:
        names = [p.name, p.toml_key or p.toml, p.dest]
        if len({name for name in names if name}) > 1:
            lines.append(f"- {_cell(p.api())}, {_cell(p.toml) or 'no TOML key'}, "
                         f"{_cell(p.flag) or 'no flag'}")  # fmt: skip
    return "\n".join(lines) + "\n"
