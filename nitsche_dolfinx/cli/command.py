"""The command line: ``nitsche-dolfinx run CONFIG.toml`` (also under ``mpirun``),
``nitsche-dolfinx schema`` (or ``--help-config``), which prints every key of a
configuration with its kind, default and meaning, and ``nitsche-dolfinx parameters``,
which prints the run parameters under their API, TOML and flag names (the markdown of
``docs/parameters.md``).

A bad configuration stops the run before anything is computed, with one line
on rank 0 that names the problem and a non-zero exit status, never a traceback.
A solver failure, SIGINT or SIGTERM stops it after the last complete step with
its state saved in ``OUT/checkpoint``; ``--restart`` continues from there. The
exit statuses are those of :mod:`nitsche_dolfinx.cli.errors`: 2 for a bad
configuration, 1 for a failed run, 130/143 for an interrupted one.
"""

from __future__ import annotations

import argparse
import sys

from mpi4py import MPI

from ..common.parameters import OutputParameters
from ..config.builder import build_simulation
from ..config.parameter_table import markdown
from ..config.reader import history_columns, load_config, output_parameters
from ..config.schema import describe
from ..post.reports import written_to
from .arguments import (
    add_parameter_argument,
    add_version_argument,
    check_output_folder,
    petsc_option,
)
from .errors import one_line_errors

__all__ = ["argument_parser", "main"]


def argument_parser() -> argparse.ArgumentParser:
    """The parser of the ``nitsche-dolfinx`` command (its reference in the documentation
    site is made from it)."""
    return _parser()[0]


def _parser() -> tuple[argparse.ArgumentParser, argparse.ArgumentParser]:
    """The command's parser and that of ``run`` (whose flags name parameters)."""
    parser = argparse.ArgumentParser(
        prog="nitsche-dolfinx",
        description="Dynamic contact in elastodynamics by Nitsche's method (FEniCSx).",
    )
    add_version_argument(parser)
    parser.add_argument(
        "--help-config",
        action="store_true",
        help="print every key of a TOML configuration (as the schema command) and exit",
    )
    commands = parser.add_subparsers(dest="command")
    run = commands.add_parser("run", help="run the simulation a TOML file describes")
    commands.add_parser("schema", help="print every key of a TOML configuration and exit")
    commands.add_parser(
        "parameters",
        help="print the run parameters under their API, TOML and flag names (markdown: "
        "docs/parameters.md) and exit",
    )
    add_version_argument(run)
    run.add_argument("config", help="the TOML configuration (keys: nitsche-dolfinx schema)")
    run.add_argument("--out", help="output folder (overrides [output] dir)")
    run.add_argument("--quiet", action="store_true", help="no progress on the terminal")
    run.add_argument(
        "--check", action="store_true", help="validate the configuration and the mesh, then stop"
    )
    # None: the configuration's value
    add_parameter_argument(
        run, "--output-every", None, metavar="N",
        help="write the fields every N steps (overrides [output] every; 0: never)",
    )  # fmt: skip
    add_parameter_argument(
        run, "--checkpoint-every", None, metavar="K",
        help="save the state in OUT/checkpoint every K steps and at the end "
        "(overrides [output] checkpoint_every; 0: only when the run stops early)",
    )  # fmt: skip
    run.add_argument(
        "--restart",
        action="store_true",
        help="continue from the checkpoint in OUT/checkpoint",
    )
    run.add_argument(
        "--petsc", type=petsc_option, action="append", default=[], metavar="KEY=VALUE",
        help="a PETSc option of the step's solver (repeatable; wins over [petsc])",
    )  # fmt: skip
    return parser, run


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``nitsche-dolfinx`` console script."""
    parser, run_parser = _parser()
    args = parser.parse_args(argv)
    if args.help_config or args.command == "schema":
        print(describe())
        return 0
    if args.command == "parameters":
        print(markdown(), end="")
        return 0
    if args.command is None:
        parser.error("choose a command: run, schema or parameters")
    return _run(args, run_parser)


def _run(args: argparse.Namespace, run_parser: argparse.ArgumentParser) -> int:
    comm = MPI.COMM_WORLD
    with one_line_errors("nitsche-dolfinx", comm, flags=run_parser):
        config = load_config(args.config)
        if args.petsc:
            config["petsc"] = {**config.get("petsc", {}), **dict(args.petsc)}
        # [output] named as in the TOML file, then the flags named as flags
        output = output_parameters(config, args.config)
        flags = (args.output_every, args.checkpoint_every)
        if flags != (None, None):
            output = OutputParameters(
                output.output_every if flags[0] is None else flags[0],
                output.checkpoint_every if flags[1] is None else flags[1],
            )
        out = args.out or config["output"]["dir"]
        if not args.check:
            check_output_folder(out, comm, "--out" if args.out else f"{args.config}: [output] dir")
        simulation = build_simulation(
            config, comm=comm, progress=not args.quiet, source=args.config,
            petsc_flags=dict(args.petsc),
        )  # fmt: skip
        if args.check:
            if comm.rank == 0:
                print(f"{args.config}: valid")
            return 0
        if flags[0] is None and config["scheme"].get("dt") == "auto":  # the steps are known now
            every = output_parameters(config, args.config, num_steps=simulation.num_steps)
            output = OutputParameters(every.output_every, output.checkpoint_every)
        simulation.run(
            out=out,
            columns=history_columns(config, simulation),
            output_every=output.output_every,
            checkpoint_every=output.checkpoint_every,
            restart=args.restart,
        )
    if comm.rank == 0 and not args.quiet:
        print(written_to(out, output.output_every))
    return 0


if __name__ == "__main__":
    sys.exit(main())
