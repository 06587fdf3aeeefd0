"""The `ident` console script: `ident fit|diagnose|worker|report ...`."""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

# One BLAS thread for the small fits: set by `ident/__init__.py`, which runs before this module.

#: Commands that show progress on stderr (a terminal only; `-q/--quiet` turns it off).
WITH_PROGRESS: tuple[str, ...] = ("fit", "diagnose", "report")

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
    for name in WITH_PROGRESS:
        sub.choices[name].add_argument("-q", "--quiet", action="store_true",
                                       help="no progress display (it is off anyway when stderr is not a terminal)")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.command not in WITH_PROGRESS:
        code: int = args.func(args)
        return code
    from ident.progress import progress

    target = getattr(args, "path", None) or " ".join(str(p) for p in getattr(args, "runs", []))
    with progress(f"ident {args.command} {target}".strip(), quiet=args.quiet):
        code = args.func(args)
    return code


if __name__ == "__main__":
    sys.exit(main())
