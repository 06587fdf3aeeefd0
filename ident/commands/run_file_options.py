"""The options every `ident` subcommand on a run file shares: the path and how to read it."""

from __future__ import annotations

import argparse

from ident.commands.aliases import add_deprecated_alias


def add_run_file_options(parser: argparse.ArgumentParser, carts_help: str | None) -> None:
    """`PATH`, `--carts` (unless `carts_help` is None), `--time`, `--pos`, `--scale`, `--rate-hz`
    (dests `path`, `carts`, `time_col`, `pos_cols`, `scale`, `rate_hz`)."""
    parser.add_argument("path", help="a run file: .mcap from daq, or a CSV/TSV export")
    if carts_help is not None:
        parser.add_argument("--carts", type=int, choices=(1, 2), default=None, help=carts_help)
    parser.add_argument("--time", dest="time_col", default=None, help="time column name (text exports)")
    parser.add_argument("--pos", dest="pos_cols", nargs="+", action="extend", default=None,
                        help="position column name(s), cart 1 first (text exports; repeat or list them)")
    parser.add_argument("--scale", type=float, default=None, help="metres per unit of the position columns")
    parser.add_argument("--rate-hz", dest="rate_hz", type=float, default=None,
                        help="sample rate (Hz) of an export without a time column")
    add_deprecated_alias(parser, "--rate", "--rate-hz", "rate_hz", float)


def add_release_options(parser: argparse.ArgumentParser) -> None:
    """`--release K` (dest `release_number`) and `--all` (dest `all`): which release of a raw
    record (see `ident releases`)."""
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--release", dest="release_number", type=int, default=None, metavar="K",
                       help="release K of the record (1-based, as `ident releases` lists them); "
                            "default: the first complete release")
    group.add_argument("--all", action="store_true",
                       help="every release of the record, one result each (a JSON array with --json)")
