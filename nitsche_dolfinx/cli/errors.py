"""How the front ends (the demos, ``nitsche-dolfinx``) end on an error: one line and an exit
status, never a traceback for a mistake of the user.

:func:`one_line_errors` stops a program with one line naming the problem and an exit
status that says what happened:

- 2: a bad parameter (out of range, a file that cannot be read or written, wrong
  PETSc options), found before computing;
- 1: the run failed (Newton did not converge; the last converged state is saved), or an
  unexpected error (then with its traceback);
- 130 or 143: the run was interrupted by SIGINT or SIGTERM (its state is saved).

A :class:`~nitsche_dolfinx.common.parameters.ParameterError` is named by the flag that set the
value (``--nitsche-theta 1e+300: ...``), the flag of the parameter in
:data:`~nitsche_dolfinx.config.parameter_table.PARAMETERS` (``friction`` is ``--mu``), or for a
demo's own parameter (``nx``) the flag of that name.

Under MPI, an error that every rank raises (as validation does) is printed once, by rank
0. An error raised on some ranks only would leave the others waiting forever in their
next collective operation: the failing rank then prints it with its rank number and
aborts the whole job (``MPI_Abort``); :class:`~nitsche_dolfinx.common.agreement.FailureChannel`
tells the two apart.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
import traceback

from mpi4py import MPI
from petsc4py import PETSc

from ..common.agreement import ERROR_AGREEMENT_SECONDS, FailureChannel, one_line
from ..common.keys import cut
from ..common.parameters import ParameterError
from ..common.signals import RunInterrupted
from ..config.parameter_table import by_name, in_words_of
from ..solvers.solver import SolverError

__all__ = ["EXIT_BAD_INPUT", "EXIT_FAILED", "exit_status_and_message", "one_line_errors"]

#: The exit status of a bad parameter or file, found before computing.
EXIT_BAD_INPUT = 2
#: The exit status of a failed run (or of an unexpected error).
EXIT_FAILED = 1
#: Errors in the user's input or files: one line, exit status :data:`EXIT_BAD_INPUT`.
_INPUT_ERRORS = (ValueError, PETSc.Error)


@contextlib.contextmanager
def one_line_errors(
    parser, comm=MPI.COMM_WORLD, grace: float = ERROR_AGREEMENT_SECONDS, flags=None
):
    """Report an error of the block as one line and exit (see the module docstring).

    Args:
        parser: The program's parser (its ``prog`` starts the line), or the program name.
        comm: The communicator of the run.
        grace: Seconds a failing rank waits for the others to fail too before it
            decides that the error is its own and aborts the job.
        flags: The parser whose flags name the parameters (default: ``parser``); a
            :class:`~nitsche_dolfinx.common.parameters.ParameterError` is reported under the
            flag that set the value.
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
            error = under_its_flag(error, flags)
        status, message = exit_status_and_message(error)
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


def under_its_flag(error: ParameterError, parser: argparse.ArgumentParser) -> ParameterError:
    """The error named by the flag of ``parser`` that set the parameter: the parameter's
    flag in the table of parameters, or for a name outside it (a demo's own ``nx``) the
    flag of that destination; unchanged if the parser has no such flag."""
    parameter = by_name(error.name)
    for action in parser._actions:
        if parameter is not None:
            found = parameter.flag in action.option_strings
        else:
            found = action.dest == error.name and bool(action.option_strings)
        if found:
            value = error.value
            shown = f"{value:g}" if isinstance(value, float) else cut(str(value))
            return _in_flag_words(error).named(f"{action.option_strings[0]} {shown}")
    return _in_flag_words(error)


def _in_flag_words(error: ParameterError) -> ParameterError:
    """The error with the other run parameters its requirement names in the API's words
    (``degree=2``) named by their flags (``--degree 2``)."""
    requirement = in_words_of(error.requirement, "flag")
    renamed = ParameterError(error.name, error.value, requirement, error.label)
    renamed.explicit = error.explicit
    return renamed


def exit_status_and_message(error: BaseException) -> tuple[int, str]:
    """The exit status and the line (with a traceback for an unexpected error) for ``error``."""
    if isinstance(error, RunInterrupted):
        return error.exit_status, one_line(error) + " (continue with --restart)"
    if isinstance(error, KeyboardInterrupt):
        return 130, "interrupted (KeyboardInterrupt)"
    if isinstance(error, SolverError):
        saved = getattr(error, "checkpoint", None)
        extra = (
            f"; {saved} (continue with --restart; a smaller dt or gamma0 is allowed there)"
            if saved is not None
            else ""
        )
        return EXIT_FAILED, one_line(error) + extra
    if isinstance(error, _INPUT_ERRORS):
        return EXIT_BAD_INPUT, one_line(error)
    if isinstance(error, OSError):
        return EXIT_FAILED, one_line(error)
    text = "".join(traceback.format_exception(type(error), error, error.__traceback__))
    return EXIT_FAILED, f"unexpected {type(error).__name__}: {one_line(error)}\n{text.rstrip()}"
