"""The worker's default fitter: load a run file, analyse it, draw its figures, build the report.

`fit_run(job) -> FitReport` never raises for a bad run: a file that cannot be read, a run
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
from ident.report.analysis import analyse, warm_up
from ident.report.records import to_fit_report
from ident.worker.service import FitJob
from schemas.fit import FitReport, FitTimings

# The worker imports this module at start: pay scipy/control/matplotlib's imports (seconds)
# then, not at the first run's fit.
warm_up()


def fit_run(job: FitJob) -> FitReport:
    started = time.perf_counter()
    try:
        data = load(job.run_file)
        loaded = time.perf_counter()
        analysis = analyse(data)
    except (IdentError, ValueError, OSError) as exc:
        return _failed(job, f"{type(exc).__name__}: {exc}", time.perf_counter() - started)
    analysed = time.perf_counter()
    drawn = figs.figures_of(analysis)
    names: list[str] = []
    for stem, fig in drawn.items():
        names += figs.save(fig, job.fit_dir, stem)
    figs.close(drawn)
    done = time.perf_counter()
    stages = analysis.timings_s
    timings = FitTimings(load_s=loaded - started, simple_s=stages.get("simple", 0.0),
                         pem_s=stages.get("pem", 0.0), diagnose_s=stages.get("diagnose", 0.0),
                         figures_s=done - analysed, total_s=done - started)
    return to_fit_report(analysis, bench=job.finished.bench, run_id=job.finished.run_id,
                         worker=job.worker, figures=names, timings=timings,
                         software_version=ident.__version__)


def _failed(job: FitJob, reason: str, elapsed_s: float) -> FitReport:
    return FitReport(bench=job.finished.bench, run_id=job.finished.run_id, worker=job.worker,
                     status="failed", reason=reason, release_time_s=job.finished.release_time_s,
                     timings=FitTimings(total_s=elapsed_s),
                     fitted_utc=datetime.now(UTC).isoformat(timespec="seconds"))


__all__ = ["fit_run"]
