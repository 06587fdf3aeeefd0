"""`ident report RUN... -o DIR`: the lab report (Markdown + self-contained HTML + figures)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any


def add_parser(sub: Any) -> None:
    parser: argparse.ArgumentParser = sub.add_parser(
        "report", help="write the lab report of the three lab cases",
        description="Write report.md, index.html and the figures for the lab cases (cart 1 "
                    "with cart 2 pinned, cart 2 with cart 1 pinned, both carts). A RUN is a "
                    "daq run file (its <run_id>.fit/ beside it is reused when present), a "
                    "fit directory or report.json, or a text export.")
    parser.add_argument("runs", nargs="+", type=Path, metavar="RUN")
    parser.add_argument("-o", "--out", type=Path, required=True, metavar="DIR",
                        help="output directory")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ident.errors import IdentError
    from ident.report.content import summary_rows
    from ident.report.writer import write_lab_report

    try:
        results = write_lab_report(list(args.runs), args.out)
    except IdentError as exc:
        print(f"ident report: {exc}", file=sys.stderr)
        return 2
    for row in summary_rows(results):
        print("  ".join(row))
    print(f"ident report: wrote {args.out / 'index.html'} and {args.out / 'report.md'} "
          f"({len(results)} of 3 lab cases)")
    return 0 if results else 1
