"""Command-line pieces shared by the demos and the ``nitsche-dolfinx`` command: the method
flags of docs/method.md section 6, the run and terminal flags, and early checks.

Every demo takes the same scheme and Nitsche flags (``--scheme``, ``--theta``,
``--beta``, ``--gamma``, ``--nitsche-theta``, ``--gamma0``, ``--gamma0-scaling``,
``--degree``, ``--dt``, ``--t-end``, ``--max-step-cuts``); :func:`add_method_arguments`
adds them with the demo's defaults and :func:`method_parameters` turns them into the
validated parameter objects of :mod:`nitsche_dolfinx.common.parameters` before anything is
computed. Each flag is made by :func:`add_parameter_argument` from its row of
:data:`~nitsche_dolfinx.config.parameter_table.PARAMETERS` (its kind, default and meaning), so
that a flag, its TOML key and its API keyword cannot drift apart.
:func:`add_run_arguments` adds ``--checkpoint-every`` and ``--restart``;
:func:`add_terminal_arguments` the flags every demo has: ``--output-every``, ``--quiet``
and ``--version``. A bad value is reported under the flag that gave it (``--gamma0 0:
...``) by :func:`nitsche_dolfinx.cli.errors.one_line_errors`.
"""

from __future__ import annotations

import argparse
from dataclasses import fields
from typing import NamedTuple

import dolfinx
import numpy as np
from mpi4py import MPI

from .. import __version__
from ..common.parameters import Discretisation, NitscheParameters, OutputParameters, TimeStepping
from ..config.parameter_table import DEMO_DEFAULT, by_flag, by_name
from ..output.writers import ensure_directory
from ..steppers.schemes import SCHEMES, TimeScheme, make_scheme

__all__ = [
    "METHOD_FLAGS",
    "TOML_DEFAULT",
    "MethodParameters",
    "add_method_arguments",
    "add_output_every_argument",
    "add_parameter_argument",
    "add_run_arguments",
    "add_terminal_arguments",
    "add_version_argument",
    "check_output_folder",
    "finite_float",
    "method_parameters",
    "petsc_option",
    "scheme_from_arguments",
    "step_taken",
    "version_text",
]


def finite_float(text: str) -> float:
    """A float flag; ``nan`` and ``inf`` are refused here, range checks are the library's."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not np.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text!r}")
    return value


def time_step(text: str) -> float | str:
    """A time step flag: a finite number, or ``auto`` (the verlet scheme's stable step)."""
    return "auto" if text == "auto" else finite_float(text)


def petsc_option(text: str) -> tuple[str, str | None]:
    """``KEY=VALUE`` (or ``KEY`` alone, for a switch such as ``ksp_monitor``) as a pair."""
    key, has_value, value = text.partition("=")
    key = key.strip().lstrip("-")
    if not key:
        raise argparse.ArgumentTypeError(f"expected KEY=VALUE, got {text!r}")
    return key, (value.strip() if has_value and value.strip() else None)


class _TomlDefault:
    def __repr__(self):
        return "the TOML default"


#: The default of :func:`add_parameter_argument`: the parameter's TOML default.
TOML_DEFAULT = _TomlDefault()


def add_parameter_argument(
    parser: argparse.ArgumentParser, flag: str, default=TOML_DEFAULT, **kwargs
) -> argparse.Action:
    """Add the flag ``flag`` of a run parameter (``"--gamma0"``), of the type of its kind,
    with its choices and meaning; ``default`` (by default the TOML default of the
    parameter) and ``kwargs`` (``metavar``, ``help``...) as for ``parser.add_argument``."""
    parameter = by_flag(flag)
    key = parameter.key
    if default is TOML_DEFAULT:
        if parameter.flag_default == DEMO_DEFAULT:
            raise TypeError(f"{flag} has no default of its own: give the demo's")
        default = key.default
    if key.kind == "boolean":  # a switch: the flag sets what the default does not
        return parser.add_argument(flag, action="store_true", help=key.meaning, **kwargs)
    kind = {"number": finite_float, "integer": int, "string": str, "step": time_step}[key.kind]
    options = {"type": kind, "default": default, "help": key.meaning}
    if key.choices:
        options["choices"] = key.choices
    return parser.add_argument(flag, **{**options, **kwargs})


#: The flags of :func:`add_method_arguments`, in their order.
METHOD_FLAGS = ("--scheme", "--theta", "--beta", "--gamma", "--safety", "--force-dt",
                "--mass-solver",
                "--nitsche-theta", "--gamma0", "--gamma0-scaling", "--degree", "--dt",
                "--t-end", "--max-step-cuts")  # fmt: skip


class _Given(argparse._StoreAction):
    """A flag stored and remembered as given (an explicit ``--scheme`` keeps it)."""

    def __call__(self, parser, namespace, values, option_string=None):
        namespace._given = getattr(namespace, "_given", set()) | {self.dest}
        super().__call__(parser, namespace, values, option_string)


#: What an explicit scheme changes among the defaults of a demo's flags (docs/method.md
#: section 12): the step is its estimated stable step, the mass the lumped one.
EXPLICIT_DEFAULTS = {"dt": "auto", "mass": "lumped"}


class _Scheme(argparse._StoreAction):
    """``--scheme``: stored; an explicit scheme (verlet) makes ``--dt`` default to
    ``auto``, its estimated stable step (docs/method.md section 12), ``--mass`` (where the
    demo has it) to ``lumped`` and ``--gamma0`` to the demo's explicit default (where it
    has one), unless they are given, before or after it."""

    def __init__(self, *args, explicit_gamma0: float | None = None, **kwargs):
        super().__init__(*args, **kwargs)
        self.explicit_defaults = dict(EXPLICIT_DEFAULTS)
        if explicit_gamma0 is not None:
            self.explicit_defaults["gamma0"] = explicit_gamma0

    def __call__(self, parser, namespace, values, option_string=None):
        super().__call__(parser, namespace, values, option_string)
        if SCHEMES[values].explicit:
            given = getattr(namespace, "_given", set())
            for name, value in self.explicit_defaults.items():
                if hasattr(namespace, name) and name not in given:
                    setattr(namespace, name, value)


def add_mass_argument(parser: argparse.ArgumentParser, default: str = "consistent") -> None:
    """Add ``--mass`` (the verlet scheme makes its default ``lumped``)."""
    add_parameter_argument(parser, "--mass", default, action=_Given)


def scheme_mass(args: argparse.Namespace) -> str:
    """The mass of a demo without ``--mass``: lumped for an explicit scheme, else
    consistent."""
    return "lumped" if SCHEMES[args.scheme].explicit else "consistent"


def step_taken(simulation, quiet: bool = False) -> float:
    """The step ``simulation`` takes: ``--dt``, or with ``--dt auto`` the verlet scheme's
    share of its estimated stable step (docs/method.md section 12).

    A demo makes it its ``args.dt`` once its main simulation is built, so that what
    follows, the compared runs, the refinement levels, the summaries, the figures, takes
    the step of the run. An explicit run says at its start (on rank 0) its estimated stable
    step when its run will not say it (a run without progress): with ``quiet`` that line
    alone, else also the step and how many steps it makes."""
    stable = getattr(simulation.stepper, "stable_dt", None)
    if stable is None or simulation.comm.rank != 0:
        return simulation.dt
    estimate = "" if simulation.progress else f"stable dt = {stable:.6g} (estimated)"
    if quiet:
        if estimate:
            print(estimate, flush=True)
        return simulation.dt
    steps = f"dt = {simulation.dt:.6g}, {simulation.num_steps} steps to T = {simulation.t_end:g}"
    print(f"{simulation.scheme.describe()}: {', '.join(filter(None, [estimate, steps]))}",
          flush=True)  # fmt: skip
    return simulation.dt


def add_method_arguments(
    parser: argparse.ArgumentParser,
    *,
    gamma0: float,
    degree: int,
    dt: float,
    t_end: float,
    beta: float = 0.25,
    gamma: float = 0.5,
    explicit_gamma0: float | None = None,
) -> None:
    """Add the scheme and Nitsche flags of docs/method.md section 6 with the given defaults
    (the others: the TOML defaults); ``explicit_gamma0``: the default of ``--gamma0`` with
    an explicit scheme, where the implicit one would make the stable step tiny (docs/method.md
    section 12)."""
    given = {"--gamma0": gamma0, "--degree": degree, "--dt": dt, "--t-end": t_end,
             "--beta": beta, "--gamma": gamma}  # fmt: skip
    actions = {"--max-step-cuts": {"metavar": "N"}, "--dt": {"action": _Given},
               "--gamma0": {"action": _Given},
               "--scheme": {"action": _Scheme, "explicit_gamma0": explicit_gamma0}}  # fmt: skip
    for flag in METHOD_FLAGS:
        add_parameter_argument(parser, flag, given.get(flag, TOML_DEFAULT), **actions.get(flag, {}))


def add_run_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``--checkpoint-every K`` and ``--restart``."""
    add_parameter_argument(
        parser,
        "--checkpoint-every",
        metavar="K",
        help="save the state in OUT/checkpoint every K steps and at the end (0: only when "
        "the run stops early, on a solver failure or SIGINT/SIGTERM)",
    )
    parser.add_argument(
        "--restart",
        action="store_true",
        help="continue from the checkpoint in OUT/checkpoint: the history keeps its rows up "
        "to it and goes on, the fields are appended to solution.xdmf",
    )


def scheme_from_arguments(args: argparse.Namespace, name: str | None = None) -> TimeScheme:
    """The scheme ``name`` (``args.scheme`` by default) with the parameters of ``args``."""
    return make_scheme(
        name or args.scheme, theta=args.theta, beta=args.beta, gamma=args.gamma,
        safety=args.safety, force_dt=args.force_dt,
        mass_solver=args.mass_solver,
    )  # fmt: skip


class MethodParameters(NamedTuple):
    """The validated parameters of a demo's flags."""

    scheme: TimeScheme
    time: TimeStepping
    nitsche: NitscheParameters
    discretisation: Discretisation
    output: OutputParameters


def add_output_every_argument(parser: argparse.ArgumentParser, default: int = 10) -> None:
    """Add ``--output-every N`` (checked by :func:`method_parameters`)."""
    add_parameter_argument(
        parser,
        "--output-every",
        default,
        help="write solution.xdmf every this many steps (0: never)",
    )


def version_text(prog: str) -> str:
    """``prog`` with the versions of nitsche-dolfinx and of the dolfinx it runs on."""
    versions = f"nitsche-dolfinx {__version__} (dolfinx {dolfinx.__version__})"
    return versions if prog == "nitsche-dolfinx" else f"{prog}, {versions}"


class _Version(argparse.Action):
    """``--version``: print :func:`version_text` on rank 0 and exit."""

    def __init__(self, option_strings, dest, **kwargs):
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None):
        if MPI.COMM_WORLD.rank == 0:
            print(version_text(parser.prog), flush=True)
        parser.exit()


def add_version_argument(parser: argparse.ArgumentParser) -> None:
    """Add ``--version``."""
    parser.add_argument(
        "--version", action=_Version, help="print the versions of the package and dolfinx"
    )


def add_terminal_arguments(
    parser: argparse.ArgumentParser, output_every: int = 10, draws: str | None = "the figure"
) -> None:
    """Add the flags of every demo (docs/method.md section 6): ``--output-every N`` (the
    fields every N steps, 0: never), ``--quiet`` (no progress), ``--no-plot`` (no
    ``draws``; a demo that draws nothing, None, accepts it) and ``--version``."""
    add_output_every_argument(parser, output_every)
    parser.add_argument(
        "--quiet", action="store_true", help="no progress on the terminal (bar or line per step)"
    )
    help_text = f"do not draw {draws}" if draws else "accepted; this demo draws nothing"
    parser.add_argument("--no-plot", action="store_true", help=help_text)
    add_version_argument(parser)


def method_parameters(args: argparse.Namespace) -> MethodParameters:
    """The parameter objects of the flags of :func:`add_method_arguments` (and of ``--mu``,
    ``--method``, ``--mass``, :func:`add_run_arguments` and
    :func:`add_output_every_argument`, where the demo has them), checked before anything
    is computed by the library's own checks.

    Raises:
        ParameterError: For the first value out of range
            (:func:`~nitsche_dolfinx.cli.errors.one_line_errors` names its flag).
    """
    return MethodParameters(
        scheme=scheme_from_arguments(args),
        time=_from_flags(TimeStepping, args),
        nitsche=_from_flags(NitscheParameters, args),
        discretisation=_from_flags(Discretisation, args),
        output=_from_flags(OutputParameters, args),
    )


def _from_flags(cls, args: argparse.Namespace):
    """The parameter object ``cls`` with the values of the flags of its fields (the flag
    of ``friction`` is ``--mu``); a field whose flag the demo lacks keeps its default."""
    values = {}
    for field in fields(cls):
        parameter = by_name(field.name)
        if parameter is not None and parameter.dest is not None and hasattr(args, parameter.dest):
            values[field.name] = getattr(args, parameter.dest)
    return cls(**values)


def check_output_folder(path: str, comm=MPI.COMM_WORLD, key: str = "--out") -> str:
    """Create the output folder and check that it can be written (before computing); a
    folder that cannot be is named with ``key``, what gave it (the flag, or a TOML key)."""
    try:
        return ensure_directory(path, comm)
    except ValueError as error:
        raise ValueError(f"{key}: {error}") from None
