"""The worker's default fitter: the "fit a run" use case (`ident.fitrun`) with its figures.

`fit_run(job)` returns, as soon as PEM is done, `Pending`: an `ok` report with the transfer
functions and `pending: [diagnosis, figures]`, and the callable that runs those (the worker
runs it in its fit process, right after sending the first results). It never raises for a bad
run: a file that cannot be read, a run too short or without motion, or fits that all fail give
a report with status `failed` and the reason; whatever was computed still goes in. Figures go
to `job.fit_dir` (PNG + SVG).
"""

from __future__ import annotations

import importlib
from functools import partial

from ident.fitrun import RunFit, RunIdentity, complete, fit_first, with_pending
from ident.report.figures import write_figures
from ident.worker.fitproc import FitOutcome, Pending
from ident.worker.job import FitJob
from schemas.fit import FitReport

# The worker imports this module at start: pay matplotlib's imports (seconds) then, not at
# the first run's figures (scipy and control came with ident.fitrun).
importlib.import_module("matplotlib.backends.backend_agg")


def _identity(job: FitJob) -> RunIdentity:
    return RunIdentity(bench=job.finished.bench, run_id=job.finished.run_id, worker=job.worker)


def fit_run(job: FitJob) -> FitOutcome:
    """Load and fit (simple ID, PEM): `Pending` with those results and the rest (diagnosis,
    figures) to run, or a failed report when nothing could be fitted."""
    first = fit_first(job.run_file, _identity(job))
    if first.analysis is None:
        failed = first.report
        if failed.release_time_s is None and job.finished.release_time_s is not None:
            failed = failed.model_copy(update={"release_time_s": job.finished.release_time_s})
        return failed
    if first.analysis.failed_reason is not None:
        return finish_run(job, first)
    return Pending(with_pending(first, ["diagnosis", "figures"]).report,
                   partial(finish_run, job, first))


def finish_run(job: FitJob, first: RunFit) -> FitReport:
    """The second stage: the diagnosis, every figure, the complete report."""
    return complete(first, _identity(job), partial(write_figures, directory=job.fit_dir)).report


def fit_to_completion(job: FitJob) -> FitReport:
    """Both stages, here and now (for tools that do not publish early results)."""
    outcome = fit_run(job)
    return outcome.finish() if isinstance(outcome, Pending) else outcome


__all__ = ["finish_run", "fit_run", "fit_to_completion"]
