"""The worker's default fitter: load a run file, analyse it, draw its figures, build the report.

`fit_run(job)` returns, as soon as PEM is done, `Pending`: an `ok` report with the transfer
functions and `pending: [diagnosis, figures]`, and the callable that runs those (the worker
runs it on its finisher thread). It never raises for a bad run: a file that cannot be read, a run
too short or without motion, or fits that all fail give a report with status `failed` and
the reason; whatever was computed still goes in. Figures go to `job.fit_dir` (PNG + SVG).
"""

from __future__ import annotations

import time
from datetime import UTC, datetime

import ident
from ident.errors import IdentError
from ident.io import load
from ident.report import figures as figs
from ident.report.analysis import RunAnalysis, analyse_fits, warm_up, with_diagnosis
from ident.report.records import to_fit_report
from ident.worker.finisher import FitOutcome, Pending
from ident.worker.service import FitJob
from schemas.fit import FitReport, FitTimings

# The worker imports this module at start: pay scipy/control/matplotlib's imports (seconds)
# then, not at the first run's fit.
warm_up()


def fit_run(job: FitJob) -> FitOutcome:
    """Load and fit (simple ID, PEM): `Pending` with those results and the rest (diagnosis,
    figures) to run, or a failed report when nothing could be fitted."""
    started = time.perf_counter()
    try:
        data = load(job.run_file)
        loaded = time.perf_counter()
        analysis = analyse_fits(data)
    except (IdentError, ValueError, OSError) as exc:
        return _failed(job, f"{type(exc).__name__}: {exc}", time.perf_counter() - started)
    load_s = loaded - started
    if analysis.failed_reason is not None:
        return finish_run(job, analysis, load_s, started)
    partial = _report(job, analysis, [], load_s, 0.0, time.perf_counter() - started,
                      pending=["diagnosis", "figures"])
    return Pending(partial, lambda: finish_run(job, analysis, load_s, started))


def finish_run(job: FitJob, analysis: RunAnalysis, load_s: float, started: float) -> FitReport:
    """The second stage: the diagnosis, every figure, the complete report."""
    analysis = with_diagnosis(analysis)
    analysed = time.perf_counter()
    drawn = figs.figures_of(analysis)
    names: list[str] = []
    for stem, fig in drawn.items():
        names += figs.save(fig, job.fit_dir, stem)
    figs.close(drawn)
    done = time.perf_counter()
    return _report(job, analysis, names, load_s, done - analysed, done - started)


def fit_to_completion(job: FitJob) -> FitReport:
    """Both stages, here and now (for tools that do not publish early results)."""
    outcome = fit_run(job)
    return outcome.finish() if isinstance(outcome, Pending) else outcome


def _report(job: FitJob, analysis: RunAnalysis, figures: list[str], load_s: float,
            figures_s: float, total_s: float, pending: list[str] | None = None) -> FitReport:
    stages = analysis.timings_s
    timings = FitTimings(load_s=load_s, simple_s=stages.get("simple", 0.0),
                         pem_s=stages.get("pem", 0.0), diagnose_s=stages.get("diagnose", 0.0),
                         figures_s=figures_s, total_s=total_s)
    report = to_fit_report(analysis, bench=job.finished.bench, run_id=job.finished.run_id,
                           worker=job.worker, figures=figures, timings=timings,
                           software_version=ident.__version__)
    return report.model_copy(update={"pending": pending}) if pending else report


def _failed(job: FitJob, reason: str, elapsed_s: float) -> FitReport:
    return FitReport(bench=job.finished.bench, run_id=job.finished.run_id, worker=job.worker,
                     status="failed", reason=reason, release_time_s=job.finished.release_time_s,
                     timings=FitTimings(total_s=elapsed_s),
                     fitted_utc=datetime.now(UTC).isoformat(timespec="seconds"))


__all__ = ["finish_run", "fit_run", "fit_to_completion"]
