"""The options every `ident` subcommand on a run file shares: the path and how to read it."""

from __future__ import annotations

import argparse


def add_run_file_options(parser: argparse.ArgumentParser, carts_help: str | None) -> None:
    """`PATH`, `--carts` (unless `carts_help` is None), `--time`, `--pos`, `--scale` (dests
    `path`, `carts`, `time_col`, `pos_cols`, `scale`)."""
    parser.add_argument("path", help="a run file: .mcap from daq, or a CSV/TSV export")
    if carts_help is not None:
        parser.add_argument("--carts", type=int, choices=(1, 2), default=None, help=carts_help)
    parser.add_argument("--time", dest="time_col", default=None, help="time column name (text exports)")
    parser.add_argument("--pos", dest="pos_cols", nargs="+", default=None,
                        help="position column name(s), cart 1 first (text exports)")
    parser.add_argument("--scale", type=float, default=None, help="metres per unit of the position columns")
