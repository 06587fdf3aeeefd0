"""`ident report RUN... -o DIR`: the lab report (Markdown + self-contained HTML + figures).

Gathers one fit per RUN: a `daq` run file (`<run_id>.mcap`; its `<run_id>.fit/` beside it is
reused when a worker already fitted it, else it is fitted here by the "fit a run" use case,
`ident.fitrun`, with the figures of `ident.report.figures`), a fit directory or its
`report.json`, or a text export (fitted here). Then `ident.report.writer` renders them.
"""

from __future__ import annotations

import argparse
import sys
from functools import partial
from pathlib import Path
from typing import Any

from ident import progress
from ident.commands.fit import run_id_of
from ident.errors import DataFileError
from ident.fitrun import RunIdentity, fit_file
from ident.report.content import CaseResult
from ident.report.figures import write_figures
from ident.report.writer import FittedRun, write_report_dir
from ident.worker.runs_dir import (
    FIT_SUFFIX,
    REPORT_NAME,
    read_finished,
    read_report,
    write_report,
)
from schemas import topics


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


def fit_here(path: Path, fit_dir: Path) -> Any:
    """Fit a run file with the use case, its figures into `fit_dir`; write report.json."""
    finished = read_finished(path) if path.suffix == topics.RUN_SUFFIX else None
    who = RunIdentity(bench=finished.bench if finished else "local",
                      run_id=finished.run_id if finished else run_id_of(path),
                      worker="ident-report")
    fit_dir.mkdir(parents=True, exist_ok=True)
    report = fit_file(path, who, draw=partial(write_figures, directory=fit_dir)).report
    write_report(fit_dir, report)
    return report


def gather(paths: list[Path], work_dir: Path) -> list[FittedRun]:
    """The final report of each RUN, fitting those that have none (into `work_dir`)."""
    runs = []
    progress.set_total(len(paths))   # the terminal shows runs done of all
    for k, path in enumerate(paths):
        if k:
            progress.advance()
        if path.is_dir() or path.name == REPORT_NAME:
            fit_dir = path if path.is_dir() else path.parent
            report = read_report(fit_dir)
            if report is None:
                raise DataFileError(f"expected a final {REPORT_NAME} in {fit_dir}, got none")
            runs.append(FittedRun(report, fit_dir, path))
            continue
        if not path.is_file():
            raise DataFileError(f"expected a run file, fit directory or report, got {str(path)!r}")
        beside = path.with_name(path.name.removesuffix(topics.RUN_SUFFIX) + FIT_SUFFIX)
        report = read_report(beside) if path.suffix == topics.RUN_SUFFIX else None
        if report is not None:
            runs.append(FittedRun(report, beside, path))
            continue
        fit_dir = work_dir / f"{run_id_of(path)}{FIT_SUFFIX}"
        runs.append(FittedRun(fit_here(path, fit_dir), fit_dir, path))
    return runs


def write_lab_report(paths: list[Path], out_dir: Path) -> list[CaseResult]:
    """Gather (fitting where needed, into `out_dir/fits/`) and write the report."""
    return write_report_dir(gather(paths, out_dir / "fits"), out_dir)
