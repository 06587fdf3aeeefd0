"""The slow second stage of fits (diagnosis, figures) on one background thread.

A fitter may return `Pending`: the first results (published at once by the worker loop)
and a `finish` callable for the rest. The loop hands `finish` to the `Finisher`, which runs
the callables one at a time, in order, and puts each outcome back on the loop's event queue
as a `Completed`; the loop writes, publishes and records it. So the loop keeps claiming and
fitting new runs (their transfer functions come out within a second) while earlier runs are
still being diagnosed. Nothing here touches Zenoh or the scheduler.
"""

from __future__ import annotations

import logging
import queue
import threading
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from schemas.fit import FitReport

log = logging.getLogger("ident.worker")


@dataclass(frozen=True)
class Pending:
    """First results of a fit (`partial`, an `ok` report with `pending` stages) and the rest."""

    partial: FitReport
    finish: Callable[[], FitReport]


FitOutcome = FitReport | Pending


@dataclass(frozen=True)
class Completed:
    """A finished second stage, for the worker loop: the complete report and where it goes."""

    fit_dir: Path
    report: FitReport


@dataclass(frozen=True)
class _Job:
    fit_dir: Path
    finish: Callable[[], FitReport]
    on_error: Callable[[str], FitReport]


class Finisher:
    """One daemon thread; `backlog` counts jobs submitted and not yet completed."""

    def __init__(self, out: queue.Queue[Any]) -> None:
        self._out = out
        self._jobs: queue.Queue[_Job | None] = queue.Queue()
        self._lock = threading.Lock()
        self._backlog = 0
        self._thread = threading.Thread(target=self._run, name="fit-finisher", daemon=True)
        self._thread.start()

    @property
    def backlog(self) -> int:
        with self._lock:
            return self._backlog

    def submit(self, fit_dir: Path, finish: Callable[[], FitReport],
               on_error: Callable[[str], FitReport]) -> None:
        with self._lock:
            self._backlog += 1
        self._jobs.put(_Job(fit_dir, finish, on_error))

    def done(self) -> None:
        """Called by the loop when it has handled a `Completed`."""
        with self._lock:
            self._backlog -= 1

    def close(self, timeout_s: float = 1.0) -> None:
        self._jobs.put(None)
        self._thread.join(timeout=timeout_s)

    def _run(self) -> None:
        while True:
            job = self._jobs.get()
            if job is None:
                return
            try:
                report = job.finish()
            except Exception as exc:
                log.exception("second stage of a fit failed")
                report = job.on_error(f"{type(exc).__name__}: {exc}")
            self._out.put(Completed(job.fit_dir, report))


__all__ = ["Completed", "Finisher", "FitOutcome", "Pending"]
