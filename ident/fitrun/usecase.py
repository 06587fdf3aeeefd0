"""Fit a run: load, analyse, `FitReport`. The one use case behind `ident fit`, `ident report`
and the worker (`ident/worker/pipeline.py`).

Two stages, so a caller can publish early results:
1. `fit_first(path, who)`: load the run (`ident.io.load`), pick release K when asked
   (`select`; a raw record without a known release: its first complete release), detect the
   case, simple identification and PEM (`analyse_fits`): well under a second. A run that
   cannot be read or fitted gives a `failed` report naming the reason; nothing is raised
   for bad input.
2. `complete(first, who, draw)`: the diagnosis (`ident.diagnose`, seconds), then `draw`
   (injected: the caller's renderer, which returns the names of the figure files it wrote;
   this module draws nothing), then the complete report.

`fit_file` runs both. Apart from reading the run file and what `draw` does, no I/O.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from ident import __version__
from ident.data import IdData, from_release
from ident.errors import IdentError
from ident.fitrun.analysis import FitSettings, RunAnalysis, analyse_fits, with_diagnosis
from ident.fitrun.records import to_fit_report
from ident.io import DEFAULT_STEP_M, load, run_drive
from ident.releases import FIRST_COMPLETE, select_or_whole
from schemas.fit import FitReport, FitTimings

#: Picks release K (1-based) of a loaded run: the run cut to that release's free response.
ReleaseSelector = Callable[[IdData, int], IdData]
#: Draws the figures of an analysis and returns the file names it wrote.
Renderer = Callable[[RunAnalysis], list[str]]


@dataclass(frozen=True)
class RunFileOptions:
    """How to read a run file. MCAP runs need none; text exports may name columns.

    `time_col`/`pos_cols` column names, `scale` metres per file unit, `release_time_s` the
    release when known (s), `step_m` the pull (m; None: a daq run's own, a raw record's
    release's own signed pull, else `DEFAULT_STEP_M`), `input_col` a recorded input column
    (e.g. a motor's control effort) instead of the release step, `rate_hz` the sample rate
    of an export without a time column.
    """

    time_col: str | None = None
    pos_cols: tuple[str, ...] | None = None
    scale: float | None = None
    release_time_s: float | None = None
    step_m: float | None = None
    input_col: str | None = None
    rate_hz: float | None = None


@dataclass(frozen=True)
class RunIdentity:
    """Whose run this is and who fits it: the names the `FitReport` carries."""

    bench: str = "local"
    run_id: str = "run"
    worker: str = "ident"


@dataclass(frozen=True)
class RunFit:
    """A run's analysis (None when nothing could be loaded or fitted) and its report."""

    analysis: RunAnalysis | None
    report: FitReport


def with_run_drive(path: str | Path, options: RunFileOptions, release: int | None = None) -> RunFileOptions:
    """`options` with the drive as the input for a `daq` run begun by the rig's drive
    (`ident.io.run_drive`: its response is to that drive), unless a release or an input is
    given; `options` as they are otherwise."""
    if release is not None or options.input_col is not None or options.release_time_s is not None:
        return options
    drive = run_drive(path)
    return options if drive is None else dataclasses.replace(options, input_col=drive)


def load_run(path: str | Path, options: RunFileOptions = RunFileOptions(),
             release: int | None = None, select: ReleaseSelector = select_or_whole) -> IdData:
    """Load a run file; with `release` K, the run cut to its K-th release by `select`
    (`FIRST_COMPLETE`: the first complete one). A `daq` run begun by the rig's drive is loaded
    with the drive as its input (`with_run_drive`). Without `release`: a motor input or a known
    release time (a daq run's metadata, a `daq export`'s comments, `options.release_time_s`)
    gives the run as loaded; a raw record whose release is not known is cut to its first
    complete release, as `ident fit` and `ident diagnose` do (the release finder decides)."""
    options = with_run_drive(path, options, release)
    # raw: a record of several releases, or one that starts in motion, has no single
    # release to build the step from
    step_m = DEFAULT_STEP_M if options.step_m is None else options.step_m
    data = load(path, options.time_col, None if options.pos_cols is None else list(options.pos_cols),
                options.scale, options.release_time_s, step_m, options.input_col,
                options.rate_hz, raw=True)
    if options.input_col is not None and release is None:
        return data
    if release is not None or data.release_time_s is None:
        return _stepped(select(data, FIRST_COMPLETE if release is None else release), options.step_m)
    return _stepped(data, step_m)


def _stepped(data: IdData, step_m: float | None) -> IdData:
    """`data` with its input a step of `step_m` (m) at its release; as it is when None (the
    selector's step: the release's own pull)."""
    if step_m is None or data.release_time_s is None:
        return data
    stepped = from_release(data.t, data.y, data.release_time_s, step_m, data.pulled_cart, data.name)
    return dataclasses.replace(stepped, notes=data.notes, columns=data.columns)


def fit_first(path: str | Path, who: RunIdentity = RunIdentity(), *,
              options: RunFileOptions = RunFileOptions(), settings: FitSettings | None = None,
              release: int | None = None, select: ReleaseSelector = select_or_whole) -> RunFit:
    """Stage 1: load and fit (simple identification, PEM); a failed report for a bad run. A
    `daq` run begun by the rig's drive is fitted as the response to it (`ident.io.run_drive`)
    unless a release or an input is given."""
    options = with_run_drive(path, options, release)
    settings = settings or FitSettings(step_input=options.input_col is None)
    started = time.perf_counter()
    try:
        data = load_run(path, options, release, select)
    except (IdentError, ValueError, OSError) as exc:
        return RunFit(None, failed_report(who, _reason(exc), time.perf_counter() - started))
    loaded = time.perf_counter()
    try:
        analysis = analyse_fits(data, settings)
    except (IdentError, ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
        return RunFit(None, failed_report(who, _reason(exc), time.perf_counter() - started))
    done = time.perf_counter()
    return RunFit(analysis, report_of(analysis, who, load_s=loaded - started, total_s=done - started))


def complete(first: RunFit, who: RunIdentity = RunIdentity(),
             draw: Renderer | None = None) -> RunFit:
    """Stage 2: the diagnosis, the figures (`draw`), the complete report."""
    if first.analysis is None or first.analysis.failed_reason is not None:
        return first
    started = time.perf_counter()
    analysis = with_diagnosis(first.analysis)
    analysed = time.perf_counter()
    figures = draw(analysis) if draw is not None else []
    done = time.perf_counter()
    before = first.report.timings
    return RunFit(analysis, report_of(analysis, who, figures=figures, load_s=before.load_s,
                                      figures_s=done - analysed,
                                      total_s=before.total_s + done - started))


def fit_file(path: str | Path, who: RunIdentity = RunIdentity(), *,
             options: RunFileOptions = RunFileOptions(), settings: FitSettings | None = None,
             release: int | None = None, select: ReleaseSelector = select_or_whole,
             diagnose: bool = True, draw: Renderer | None = None) -> RunFit:
    """Both stages (the diagnosis and `draw` only when `diagnose`)."""
    first = fit_first(path, who, options=options, settings=settings, release=release,
                      select=select)
    return complete(first, who, draw) if diagnose else first


def report_of(analysis: RunAnalysis, who: RunIdentity, *, figures: list[str] | None = None,
              load_s: float = 0.0, figures_s: float = 0.0, total_s: float = 0.0) -> FitReport:
    """The `FitReport` of an analysis (status `failed` when nothing could be fitted)."""
    stages = analysis.timings_s
    timings = FitTimings(load_s=load_s, simple_s=stages.get("simple", 0.0),
                         pem_s=stages.get("pem", 0.0), diagnose_s=stages.get("diagnose", 0.0),
                         figures_s=figures_s, total_s=total_s)
    return to_fit_report(analysis, bench=who.bench, run_id=who.run_id, worker=who.worker,
                         figures=list(figures or []), timings=timings,
                         software_version=__version__)


def failed_report(who: RunIdentity, reason: str, elapsed_s: float,
                  release_time_s: float | None = None) -> FitReport:
    """A `failed` report for a run that could not be loaded or fitted."""
    return FitReport(bench=who.bench, run_id=who.run_id, worker=who.worker, status="failed",
                     reason=reason, release_time_s=release_time_s,
                     timings=FitTimings(total_s=elapsed_s),
                     fitted_utc=datetime.now(UTC).isoformat(timespec="seconds"),
                     software_version=__version__)


def with_pending(fit: RunFit, pending: list[str]) -> RunFit:
    """The report marked as an early result with `pending` stages still to run."""
    return dataclasses.replace(fit, report=fit.report.model_copy(update={"pending": pending}))


def _reason(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}"


__all__ = [
    "ReleaseSelector",
    "Renderer",
    "RunFileOptions",
    "RunFit",
    "RunIdentity",
    "complete",
    "failed_report",
    "fit_file",
    "fit_first",
    "load_run",
    "report_of",
    "with_pending",
    "with_run_drive",
]
