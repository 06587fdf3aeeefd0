"""The `ident` console script: `ident fit|diagnose|worker|report ...`."""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from collections.abc import Sequence

# The fits here are small dense problems: a multi-threaded BLAS only adds contention
# (2-5x slower measured on a loaded 2-core bench PC). Must be set before numpy loads.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

#: Subcommand modules under `ident.commands`, in the order `--help` lists them.
COMMANDS: tuple[str, ...] = (
    "fit",
    "diagnose",
    "releases",
    "worker",
    "report",
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="ident", description="Identify spring-cart runs: physical models, PEM, diagnosis.")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMANDS:
        importlib.import_module(f"ident.commands.{name}").add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    code: int = args.func(args)
    return code


if __name__ == "__main__":
    sys.exit(main())
