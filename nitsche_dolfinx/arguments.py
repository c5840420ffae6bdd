"""Command-line pieces shared by the demos: the method flags of SPEC section 6, and errors
reported as one line.

Every demo takes the same scheme and Nitsche flags (``--scheme``, ``--theta``,
``--beta``, ``--gamma``, ``--nitsche-theta``, ``--gamma0``, ``--degree``, ``--dt``,
``--t-end``); :func:`add_method_arguments` adds them with the demo's defaults and
:func:`scheme_from_arguments` turns them into a scheme. :func:`one_line_errors`
stops a demo whose parameter is out of range, whose Newton fails or whose PETSc
options are wrong with one line on rank 0 and exit status 2, never a traceback.
"""

from __future__ import annotations

import argparse
import contextlib
import sys

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from .schemes import SCHEMES, TimeScheme, make_scheme
from .solver import SolverError

__all__ = [
    "add_method_arguments",
    "finite_float",
    "one_line_errors",
    "petsc_option",
    "scheme_from_arguments",
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
    """Add the scheme and Nitsche flags of SPEC section 6 with the given defaults."""
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
    parser.add_argument("--degree", type=int, default=degree, help="Lagrange degree (1 or 2)")
    parser.add_argument("--dt", type=finite_float, default=dt, help="time step tau")
    parser.add_argument("--t-end", type=finite_float, default=t_end, help="final time T")


def scheme_from_arguments(args: argparse.Namespace, name: str | None = None) -> TimeScheme:
    """The scheme ``name`` (``args.scheme`` by default) with the parameters of ``args``."""
    return make_scheme(name or args.scheme, theta=args.theta, beta=args.beta, gamma=args.gamma)


@contextlib.contextmanager
def one_line_errors(parser: argparse.ArgumentParser):
    """Turn a bad parameter, a Newton failure or a PETSc error into one line and exit status 2."""
    try:
        yield
    except (ValueError, SolverError, PETSc.Error) as error:
        if MPI.COMM_WORLD.rank == 0:
            print(f"{parser.prog}: error: {_one_line(error)}", file=sys.stderr, flush=True)
        sys.exit(2)


def _one_line(error: Exception) -> str:
    """The message of ``error`` on one line; for PETSc, its code and its most precise line."""
    if isinstance(error, PETSc.Error):
        lines = [line.split("] ", 1)[-1] for line in str(error).strip().splitlines()]
        return f"PETSc {lines[0]}: {lines[-1]}" if len(lines) > 1 else f"PETSc {lines[0]}"
    return " ".join(str(error).split()) or type(error).__name__
