"""The command line: ``nitsche-dolfinx run CONFIG.toml`` (also under ``mpirun``).

A bad configuration stops the run before anything is computed, with one line
on rank 0 that names the problem and a non-zero exit status, never a traceback.
"""

from __future__ import annotations

import argparse
import os
import sys

__all__ = ["main"]


def _parser() -> argparse.ArgumentParser:
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
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``nitsche-dolfinx`` console script."""
    args = _parser().parse_args(argv)
    from mpi4py import MPI

    from .config import ConfigError, build_simulation, load_config
    from .solver import SolverError

    comm = MPI.COMM_WORLD

    def fail(message: str, status: int) -> int:
        if comm.rank == 0:
            print(f"nitsche-dolfinx: error: {message}", file=sys.stderr, flush=True)
        return status

    try:
        config = load_config(args.config)
        simulation = build_simulation(
            config, comm=comm, progress=not args.quiet, source=args.config
        )
    except ConfigError as error:
        return fail(str(error), 2)
    if args.check:
        if comm.rank == 0:
            print(f"{args.config}: valid")
        return 0
    output = config.get("output", {})
    out = args.out or output.get("dir") or os.path.join("out", "run")
    try:
        simulation.run(out=out, output_every=output.get("every", 0))
    except SolverError as error:
        return fail(str(error), 1)
    if comm.rank == 0 and not args.quiet:
        print(f"history: {os.path.join(out, 'history.csv')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
