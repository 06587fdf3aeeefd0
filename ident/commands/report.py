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
from ident.data import FloatArray, IdData
from ident.errors import DataFileError, IdentError
from ident.fitrun import RunFileOptions, RunIdentity, fit_file, load_run, with_run_drive
from ident.fitrun.analysis import case_samples, diagnosis_columns, on_one_grid
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
from schemas.fit import FitReport

#: MCAP runs need no reading options; text exports may (columns, scale).
_READ_AS_IS = RunFileOptions()


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
    parser.add_argument("--time", dest="time_col", default=None,
                        help="time column name (text exports)")
    parser.add_argument("--pos", dest="pos_cols", nargs="+", action="extend", default=None,
                        help="position column name(s), cart 1 first (text exports; repeat or list them)")
    parser.add_argument("--scale", type=float, default=None,
                        help="metres per unit of the position columns (text exports)")
    parser.add_argument("--release-s", dest="release_s", type=float, default=None,
                        help="release time (s) of a text export, if known")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ident.errors import IdentError
    from ident.report.content import summary_rows

    try:
        options = RunFileOptions(time_col=args.time_col, scale=args.scale,
                                 release_time_s=args.release_s,
                                 pos_cols=None if args.pos_cols is None else tuple(args.pos_cols))
        results = write_lab_report(list(args.runs), args.out, options=options)
    except IdentError as exc:
        print(f"ident report: {exc}", file=sys.stderr)
        return 2
    for row in summary_rows(results):
        print("  ".join(row))
    print(f"ident report: wrote {args.out / 'index.html'} and {args.out / 'report.md'} "
          f"({len(results)} of 3 lab cases)")
    return 0 if results else 1


def fit_here(path: Path, fit_dir: Path, options: RunFileOptions = _READ_AS_IS) -> FitReport:
    """Fit a run file with the use case, its figures into `fit_dir`; write report.json."""
    finished = read_finished(path) if path.suffix == topics.RUN_SUFFIX else None
    who = RunIdentity(bench=finished.bench if finished else "local",
                      run_id=finished.run_id if finished else run_id_of(path),
                      worker="ident-report")
    fit_dir.mkdir(parents=True, exist_ok=True)
    report = fit_file(path, who, options=options,
                      draw=partial(write_figures, directory=fit_dir)).report
    write_report(fit_dir, report)
    return report


def fitted_samples(run_file: Path, report: FitReport,
                   options: RunFileOptions = _READ_AS_IS) -> tuple[IdData, FloatArray, bool] | None:
    """The samples the report's fits used (its carts' columns), the other carts' positions
    (N, k) its diagnosis took as inputs (a held cart; k may be 0, `diagnosis_columns`) and
    whether the input is a recorded force (a run begun by the rig's drive: `with_run_drive`),
    or None without the file."""
    if report.status != "ok" or not run_file.is_file():
        return None
    outputs = report.pem.outputs if report.pem else [s.output for s in report.simple[:1]]
    options = with_run_drive(run_file, options)
    try:
        data = on_one_grid(load_run(run_file, options))
    except (IdentError, OSError):
        return None
    numbers = data.cart_numbers()          # the report names carts; the data has columns
    if not outputs or not set(outputs) <= set(numbers):
        return None
    columns = [numbers.index(c) for c in outputs]
    fitted = case_samples(data, tuple(c + 1 for c in columns))
    return fitted, diagnosis_columns(data, fitted, columns)[:, len(columns):], options.input_col is not None


def gather(paths: list[Path], work_dir: Path,
           options: RunFileOptions = _READ_AS_IS) -> list[FittedRun]:
    """The final report of each RUN, fitting those that have none (into `work_dir`), with
    the samples each fit used when the run file is at hand."""
    runs = []
    progress.set_total(len(paths))   # the terminal shows runs done of all
    for k, path in enumerate(paths):
        if k:
            progress.advance()
        runs.append(_gather_one(path, work_dir, options))
    return [FittedRun(r.report, r.fit_dir, r.source,
                      *(fitted_samples(_run_file(r), r.report, options) or (None, None, False))) for r in runs]


def _run_file(run: FittedRun) -> Path:
    """A fit folder `<run_id>.fit/` sits beside its run `<run_id>.mcap`."""
    if run.source.is_file() and run.source.name != REPORT_NAME:
        return run.source
    return run.fit_dir.with_name(run.fit_dir.name.removesuffix(FIT_SUFFIX) + topics.RUN_SUFFIX)


def _gather_one(path: Path, work_dir: Path, options: RunFileOptions) -> FittedRun:
    if path.is_dir() or path.name == REPORT_NAME:
        fit_dir = path if path.is_dir() else path.parent
        report = read_report(fit_dir)
        if report is None:
            raise DataFileError(f"expected a final {REPORT_NAME} in {fit_dir}, got none")
        return FittedRun(report, fit_dir, path)
    if not path.is_file():
        raise DataFileError(f"expected a run file, fit directory or report, got {str(path)!r}")
    beside = path.with_name(path.name.removesuffix(topics.RUN_SUFFIX) + FIT_SUFFIX)
    report = read_report(beside) if path.suffix == topics.RUN_SUFFIX else None
    if report is not None:
        return FittedRun(report, beside, path)
    fit_dir = work_dir / f"{run_id_of(path)}{FIT_SUFFIX}"
    return FittedRun(fit_here(path, fit_dir, options), fit_dir, path)


def write_lab_report(paths: list[Path], out_dir: Path, run_notebook: bool = True,
                     options: RunFileOptions = _READ_AS_IS) -> list[CaseResult]:
    """Gather (fitting where needed, into `out_dir/fits/`, text exports read with
    `options`) and write the report."""
    return write_report_dir(gather(paths, out_dir / "fits", options), out_dir, run_notebook)
