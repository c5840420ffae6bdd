"""The command line: ``nitsche-dolfinx run CONFIG.toml`` (also under ``mpirun``).

A bad configuration stops the run before anything is computed, with one line
on rank 0 that names the problem and a non-zero exit status, never a traceback.
A solver failure, SIGINT or SIGTERM stops it after the last complete step with
its state saved in ``OUT/checkpoint``; ``--restart`` continues from there. The
exit statuses are those of :mod:`nitsche_dolfinx.arguments`: 2 for a bad
configuration, 1 for a failed run, 130/143 for an interrupted one.
"""

from __future__ import annotations

import argparse
import os
import sys

__all__ = ["main"]


def _parser() -> tuple[argparse.ArgumentParser, argparse.ArgumentParser]:
    """The command's parser and that of ``run`` (whose flags name parameters)."""
    parser = argparse.ArgumentParser(
        prog="nitsche-dolfinx",
        description="Dynamic contact in elastodynamics by Nitsche's method (FEniCSx).",
    )
    commands = parser.add_subparsers(dest="command", required=True)
    run = commands.add_parser("run", help="run the simulation a TOML file describes")
    run.add_argument("config", help="the TOML configuration (see nitsche_dolfinx.config)")
    run.add_argument("--out", help="output folder (overrides [output] dir)")
    run.add_argument("--quiet", action="store_true", help="no progress line per step")
    run.add_argument(
        "--check", action="store_true", help="validate the configuration and the mesh, then stop"
    )
    run.add_argument(
        "--checkpoint-every",
        type=int,
        default=None,
        metavar="K",
        help="save the state in OUT/checkpoint every K steps and at the end "
        "(overrides [output] checkpoint_every; 0: only when the run stops early)",
    )
    run.add_argument(
        "--restart",
        action="store_true",
        help="continue from the checkpoint in OUT/checkpoint",
    )
    return parser, run


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``nitsche-dolfinx`` console script."""
    parser, run_parser = _parser()
    args = parser.parse_args(argv)
    from mpi4py import MPI

    from .arguments import check_output_folder, one_line_errors
    from .config import build_simulation, load_config, output_parameters
    from .parameters import OutputParameters

    comm = MPI.COMM_WORLD
    with one_line_errors("nitsche-dolfinx", comm, flags=run_parser):
        config = load_config(args.config)
        # [output] named as in the TOML file, then --checkpoint-every as a flag
        overridden = args.checkpoint_every is not None
        output = output_parameters(config, args.config, 0 if overridden else None)
        if overridden:
            output = OutputParameters(output.output_every, args.checkpoint_every)
        out = args.out or config.get("output", {}).get("dir") or os.path.join("out", "run")
        if not args.check:
            check_output_folder(out, comm)
        simulation = build_simulation(
            config, comm=comm, progress=not args.quiet, source=args.config
        )
        if args.check:
            if comm.rank == 0:
                print(f"{args.config}: valid")
            return 0
        simulation.run(
            out=out,
            output_every=output.output_every,
            checkpoint_every=output.checkpoint_every,
            restart=args.restart,
        )
    if comm.rank == 0 and not args.quiet:
        print(f"history: {os.path.join(out, 'history.csv')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
