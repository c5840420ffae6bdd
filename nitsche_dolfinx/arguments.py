"""Command-line pieces shared by the demos and the ``nitsche-dolfinx`` command: the method
flags of docs/method.md section 6, the checkpoint flags, early checks, and errors reported
as one line.

Every demo takes the same scheme and Nitsche flags (``--scheme``, ``--theta``,
``--beta``, ``--gamma``, ``--nitsche-theta``, ``--gamma0``, ``--gamma0-scaling``,
``--degree``, ``--dt``, ``--t-end``, ``--max-step-cuts``); :func:`add_method_arguments`
adds them with the demo's defaults and :func:`method_parameters` turns them into the
validated parameter objects of :mod:`nitsche_dolfinx.parameters` before anything is
computed. A bad value is reported under the flag that gave it (``--gamma0 0: ...``).
:func:`add_run_arguments` adds ``--checkpoint-every`` and ``--restart``;
:func:`add_terminal_arguments` the flags every demo has: ``--output-every``, ``--quiet``
and ``--version``.

:func:`one_line_errors` stops a demo with one line naming the problem, never a
traceback, and an exit status that says what happened:

- 2: a bad parameter (out of range, a file that cannot be read or written, wrong
  PETSc options), found before computing;
- 1: the run failed (Newton did not converge; the last converged state is saved);
- 130 or 143: the run was interrupted by SIGINT or SIGTERM (its state is saved).

Under MPI, an error that every rank raises (as validation does) is printed once,
by rank 0. An error raised on some ranks only would leave the others waiting
forever in their next collective operation: the failing rank then prints it
with its rank number and aborts the whole job (``MPI_Abort``).
"""

from __future__ import annotations

import argparse
import contextlib
import sys
import traceback
from typing import NamedTuple

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from .agreement import ERROR_AGREEMENT_SECONDS, FailureChannel
from .output import ensure_directory
from .parameters import (
    GAMMA0_SCALINGS,
    Discretisation,
    NitscheParameters,
    OutputParameters,
    ParameterError,
    TimeStepping,
)
from .schemes import SCHEMES, TimeScheme, make_scheme
from .signals import RunInterrupted
from .solver import SolverError

__all__ = [
    "MethodParameters",
    "add_method_arguments",
    "add_output_every_argument",
    "add_run_arguments",
    "add_terminal_arguments",
    "add_version_argument",
    "check_output_folder",
    "finite_float",
    "method_parameters",
    "one_line_errors",
    "petsc_option",
    "version_text",
]

#: Flags whose destination is not the parameter's name.
_DESTINATIONS = {"friction": "mu"}


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


def add_method_arguments(
    parser: argparse.ArgumentParser,
    *,
    gamma0: float,
    degree: int,
    dt: float,
    t_end: float,
    beta: float = 0.25,
    gamma: float = 0.5,
) -> None:
    """Add the scheme and Nitsche flags of docs/method.md section 6 with the given defaults."""
    parser.add_argument("--scheme", choices=SCHEMES, default="hybrid", help="time scheme")
    parser.add_argument("--theta", type=finite_float, default=1.0, help="theta of the theta-scheme")
    parser.add_argument("--beta", type=finite_float, default=beta, help="Newmark beta")
    parser.add_argument("--gamma", type=finite_float, default=gamma, help="Newmark gamma")
    parser.add_argument(
        "--nitsche-theta",
        type=finite_float,
        default=1.0,
        help="Nitsche variant Theta: 1 symmetric, 0 non-symmetric, -1 skew-symmetric",
    )
    parser.add_argument(
        "--gamma0", type=finite_float, default=gamma0, help="Nitsche parameter, gamma_h = gamma0 h"
    )
    parser.add_argument(
        "--gamma0-scaling",
        choices=GAMMA0_SCALINGS,
        default="absolute",
        help="absolute: gamma_h = gamma0 h (gamma0 in 1/stress, the paper's); E: gamma_h = "
        "gamma0 h / E (gamma0 without units, about 1e-3)",
    )
    parser.add_argument("--degree", type=int, default=degree, help="Lagrange degree (1 or 2)")
    parser.add_argument("--dt", type=finite_float, default=dt, help="time step tau")
    parser.add_argument("--t-end", type=finite_float, default=t_end, help="final time T")
    parser.add_argument(
        "--max-step-cuts",
        type=int,
        default=5,
        metavar="N",
        help="a step whose Newton fails is halved, down to dt/2^N, before the run stops",
    )


def add_run_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``--checkpoint-every K`` and ``--restart``."""
    parser.add_argument(
        "--checkpoint-every",
        type=int,
        default=0,
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
    return make_scheme(name or args.scheme, theta=args.theta, beta=args.beta, gamma=args.gamma)


class MethodParameters(NamedTuple):
    """The validated parameters of a demo's flags."""

    scheme: TimeScheme
    time: TimeStepping
    nitsche: NitscheParameters
    discretisation: Discretisation
    output: OutputParameters


def add_output_every_argument(parser: argparse.ArgumentParser, default: int = 10) -> None:
    """Add ``--output-every N`` (checked by :func:`check_method_arguments`)."""
    parser.add_argument(
        "--output-every",
        type=int,
        default=default,
        help="write solution.xdmf every this many steps (0: never)",
    )


def version_text(prog: str) -> str:
    """``prog`` with the versions of nitsche-dolfinx and of the dolfinx it runs on."""
    import dolfinx

    from . import __version__

    versions = f"nitsche-dolfinx {__version__} (dolfinx {dolfinx.__version__})"
    return versions if prog == "nitsche-dolfinx" else f"{prog}, {versions}"


class _Version(argparse.Action):
    """``--version``: print :func:`version_text` on rank 0 and exit (dolfinx is imported
    only then)."""

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


def add_terminal_arguments(parser: argparse.ArgumentParser, output_every: int = 10) -> None:
    """Add the flags of every demo (docs/method.md section 6): ``--output-every N`` (the
    fields every N steps, 0: never), ``--quiet`` (no progress) and ``--version``."""
    add_output_every_argument(parser, output_every)
    parser.add_argument(
        "--quiet", action="store_true", help="no progress on the terminal (bar or line per step)"
    )
    add_version_argument(parser)


def method_parameters(args: argparse.Namespace) -> MethodParameters:
    """The parameter objects of the flags of :func:`add_method_arguments` (and of ``--mu``,
    ``--method``, ``--mass``, :func:`add_run_arguments` and
    :func:`add_output_every_argument`, where the demo has them), checked before anything
    is computed by the library's own checks.

    Raises:
        ParameterError: For the first value out of range (:func:`one_line_errors` names
            its flag).
    """
    return MethodParameters(
        scheme=scheme_from_arguments(args),
        time=TimeStepping(args.dt, args.t_end, args.max_step_cuts),
        nitsche=NitscheParameters(
            args.gamma0,
            args.nitsche_theta,
            getattr(args, "mu", None),
            getattr(args, "method", "nitsche"),
            args.gamma0_scaling,
        ),
        discretisation=Discretisation(args.degree, getattr(args, "mass", "consistent")),
        output=OutputParameters(
            getattr(args, "output_every", 0), getattr(args, "checkpoint_every", 0)
        ),
    )


def check_output_folder(path: str, comm=MPI.COMM_WORLD) -> str:
    """Create the output folder and check that it can be written (before computing)."""
    return ensure_directory(path, comm)


@contextlib.contextmanager
def one_line_errors(
    parser, comm=MPI.COMM_WORLD, grace: float = ERROR_AGREEMENT_SECONDS, flags=None
):
    """Report an error of the block as one line and exit (see the module docstring).

    Args:
        parser: The demo's parser (its ``prog`` starts the line), or the program name.
        flags: The parser whose flags name the parameters (default: ``parser``); a
            :class:`~nitsche_dolfinx.parameters.ParameterError` is reported under the
            flag that set the value.
        comm: The communicator of the run.
        grace: Seconds a failing rank waits for the others to fail too before it
            decides that the error is its own and aborts the job.
    """
    prog = parser if isinstance(parser, str) else parser.prog
    if flags is None and not isinstance(parser, str):
        flags = parser
    failures = FailureChannel(comm)
    try:
        yield
    except SystemExit:
        raise
    except BaseException as error:  # noqa: BLE001 - every error ends the run, one way or another
        if isinstance(error, ParameterError) and flags is not None:
            error = _under_its_flag(error, flags)
        status, message = _status_and_message(error)
        if failures.every_rank_failed(grace):
            if comm.rank == 0:
                print(f"{prog}: error: {message}", file=sys.stderr, flush=True)
            sys.exit(status)
        print(
            f"{prog}: error on rank {comm.rank} of {comm.size} (aborting all ranks): {message}",
            file=sys.stderr,
            flush=True,
        )
        comm.Abort(status)
    failures.free()


def _under_its_flag(error: ParameterError, parser: argparse.ArgumentParser) -> ParameterError:
    """The error named by the flag that set the parameter, if the parser has one."""
    dest = _DESTINATIONS.get(error.name, error.name)
    for action in parser._actions:
        if action.dest == dest and action.option_strings:
            value = error.value
            shown = f"{value:g}" if isinstance(value, float) else str(value)
            return error.named(f"{action.option_strings[0]} {shown}")
    return error


#: Errors in the user's input or files: one line, exit status 2.
_INPUT_ERRORS = (ValueError, PETSc.Error)


def _status_and_message(error: BaseException) -> tuple[int, str]:
    """The exit status and the line (with a traceback for an unexpected error) for ``error``."""
    if isinstance(error, RunInterrupted):
        return error.exit_status, _one_line(error) + " (continue with --restart)"
    if isinstance(error, KeyboardInterrupt):
        return 130, "interrupted (KeyboardInterrupt)"
    if isinstance(error, SolverError):
        saved = getattr(error, "checkpoint", None)
        extra = (
            f"; {saved} (continue with --restart; a smaller dt or gamma0 is allowed there)"
            if saved is not None
            else ""
        )
        return 1, _one_line(error) + extra
    if isinstance(error, _INPUT_ERRORS):
        return 2, _one_line(error)
    if isinstance(error, OSError):
        return 1, _one_line(error)
    text = "".join(traceback.format_exception(type(error), error, error.__traceback__))
    return 1, f"unexpected {type(error).__name__}: {_one_line(error)}\n{text.rstrip()}"


def _one_line(error: BaseException) -> str:
    """The message of ``error`` on one line; for PETSc, its code and its most precise line."""
    if isinstance(error, PETSc.Error):
        lines = [line.split("] ", 1)[-1] for line in str(error).strip().splitlines()]
        return f"PETSc {lines[0]}: {lines[-1]}" if len(lines) > 1 else f"PETSc {lines[0]}"
    return " ".join(str(error).split()) or type(error).__name__
