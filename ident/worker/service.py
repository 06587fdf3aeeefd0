"""The worker's main loop: drain events, claim, fit, report.

Zenoh callbacks (`ident.worker.bus`) only enqueue `BusEvent`s; this loop parses them,
updates the `Scheduler`, runs the fitter (a plug-in: `FitJob -> FitReport | Pending`) and
publishes. A `Pending` outcome's first results are published at once and its second stage
runs on the `Finisher` thread, whose `Completed` comes back through the same queue: only
this loop publishes, writes reports and touches the scheduler. Waits are bounded by the
injected clock; the loop ends when `stop` is set.
"""

from __future__ import annotations

import importlib
import logging
import queue
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

from ident.worker.bus import BusEvent, WorkerBus
from ident.worker.finisher import Completed, Finisher, FitOutcome, Pending
from ident.worker.runs_dir import find_run_file, fit_dir_for, read_report, scan_runs, write_report
from ident.worker.schedule import RunRef, Scheduler
from schemas import keys
from schemas.bus import BusConfig
from schemas.daq import RunFinished
from schemas.errors import SchemaError
from schemas.fit import FitReport

log = logging.getLogger("ident.worker")

DEFAULT_FITTER = "ident.worker.pipeline:fit_run"


@dataclass(frozen=True)
class FitJob:
    """One run to fit: its finished record, the local MCAP, and where figures go."""

    finished: RunFinished
    run_file: Path
    fit_dir: Path
    worker: str


#: A fitter returns the complete report, or `Pending` (first results + the slow rest).
Fitter = Callable[[FitJob], FitOutcome]
Event = BusEvent | Completed


@dataclass
class WorkerOptions:
    """Settings of one worker. `settle_s` is how long a claim waits for rival claims."""

    name: str
    runs_dir: Path
    bus: BusConfig = field(default_factory=BusConfig.connector)
    fitter: str = DEFAULT_FITTER
    settle_s: float = 0.2
    sync_s: float = 0.3
    poll_s: float = 0.05
    max_backlog: int = 4


def load_fitter(spec: str) -> Fitter:
    """`"package.module:function"` -> the function."""
    module_name, _, attr = spec.partition(":")
    if not module_name or not attr:
        raise ValueError(f"fitter: expected 'module:function', got {spec!r}")
    fitter: Fitter = getattr(importlib.import_module(module_name), attr)
    return fitter


def failed_report(finished: RunFinished, worker: str, reason: str) -> FitReport:
    return FitReport(bench=finished.bench, run_id=finished.run_id, worker=worker,
                     status="failed", reason=reason, release_time_s=finished.release_time_s,
                     fitted_utc=datetime.now(UTC).isoformat())


class Worker:
    """A worker bound to an open `WorkerBus` (see `run_worker` for the usual entry)."""

    def __init__(self, options: WorkerOptions, bus: WorkerBus, events: queue.Queue[Event],
                 fitter: Fitter, clock: Callable[[], float] = time.monotonic,
                 finisher: Finisher | None = None) -> None:
        self.options = options
        self.bus = bus
        self.events = events
        self.fitter = fitter
        self.clock = clock
        self.finisher = finisher if finisher is not None else Finisher(events)
        self.sched = Scheduler(options.name)
        self.fitted: list[FitReport] = []
        self._complete_reports: dict[str, bytes] = {}

    # -- events -------------------------------------------------------------------------
    def pump(self, duration_s: float) -> None:
        """Handle events for `duration_s` (at least the ones already queued)."""
        deadline = self.clock() + duration_s
        while True:
            remaining = deadline - self.clock()
            try:
                event = self.events.get(timeout=max(remaining, 0.0)) if remaining > 0 else \
                    self.events.get_nowait()
            except queue.Empty:
                return
            self.handle(event)

    def handle(self, event: Event) -> None:
        if isinstance(event, Completed):
            self.finisher.done()
            self._complete(event.fit_dir, event.report)
            return
        try:
            if event.kind == "finished":
                finished = RunFinished.from_json_bytes(event.payload)
                # names become keys and paths: refuse `..`, `/` and the like
                keys.check_name("bench", finished.bench)
                keys.check_name("run_id", finished.run_id)
                self.sched.run_announced(finished)
            elif event.kind == "fit":
                self._fit_seen(FitReport.from_json_bytes(event.payload))
            elif event.kind == "worker":
                self._worker_event(event.key.rsplit("/", 1)[-1], event.up)
            elif event.kind == "daq" and event.up:
                self.catch_up_bench(keys.bench_of(event.key))
        except SchemaError as exc:
            log.warning("ignored a message on %s: %s", event.key, exc)

    def _fit_seen(self, report: FitReport) -> None:
        self.sched.fit_seen(report)
        key = keys.run_fit(report.bench, report.run_id)
        if report.final and key not in self._complete_reports:
            self._complete_reports[key] = report.to_json_bytes()
            self.bus.set_fit_snapshot(self._complete_reports)

    def _worker_event(self, name: str, up: bool) -> None:
        if up:
            self.sched.worker_up(name)
            return
        orphaned = self.sched.worker_down(name)
        log.info("worker %s is gone; its claimed runs are open again: %s", name,
                 ", ".join(map(str, orphaned)) or "none")

    # -- catch-up -----------------------------------------------------------------------
    def catch_up_bench(self, bench: str) -> None:
        try:
            runs = self.bus.list_runs(bench)
        except SchemaError as exc:
            log.warning("ignored the run list of %s: %s", bench, exc)
            return
        for finished in runs.runs if runs is not None else []:
            self.handle(BusEvent("finished", keys.run_finished(bench, "runs"),
                                 finished.to_json_bytes()))

    def start(self) -> None:
        """Learn who is alive and which runs the others know are done, scan the runs
        directory, ask each daq, gather history."""
        for name in self.bus.alive_workers():
            self.sched.worker_up(name)
        for payload in self.bus.known_fits():
            self.handle(BusEvent("fit", keys.ALL_FITS, payload))
        for _, finished in scan_runs(self.options.runs_dir):
            self.sched.run_announced(finished)
        for bench in sorted(self.bus.alive_benches()):
            self.catch_up_bench(bench)
        self.pump(self.options.sync_s)

    # -- one step -----------------------------------------------------------------------
    def step(self) -> bool:
        """Handle queued events, then claim and fit one run if one is mine. True if fitted."""
        self.pump(0.0)
        busy = self.finisher.backlog >= self.options.max_backlog
        run = None if busy else self.sched.next_claim()
        if run is None:
            self.pump(self.options.poll_s)
            return False
        return self.process(run)

    def process(self, run: RunRef) -> bool:
        finished = self.sched.runs[run].finished
        assert finished is not None
        run_file = find_run_file(self.options.runs_dir, run.bench, finished.file)
        fit_dir = fit_dir_for(self.options.runs_dir, run.bench, run.run_id, run_file)
        stored = read_report(fit_dir)
        if stored is not None:
            log.info("%s: already fitted (%s); republishing the stored report", run, fit_dir)
            self._fit_seen(stored)
            self.bus.publish_fit(stored)
            return False
        if not self._claim(run, finished):
            return False
        outcome = self._fit(finished, run_file, fit_dir)
        if isinstance(outcome, Pending):
            partial = self._checked(finished, outcome.partial)
            if partial.final:      # a partial that does not round-trip became a failure
                self._complete(fit_dir, partial)
                return True
            self.bus.publish_fit(partial)
            log.info("%s: fitted in %.2f s; %s next", run, partial.timings.total_s,
                     " and ".join(partial.pending))
            self.finisher.submit(fit_dir, outcome.finish, lambda reason: failed_report(
                finished, self.options.name, reason))
        else:
            self._complete(fit_dir, outcome)
        return True

    def _complete(self, fit_dir: Path, report: FitReport) -> None:
        finished = self.sched.runs[RunRef(report.bench, report.run_id)].finished
        if finished is not None:
            report = self._checked(finished, report)
        write_report(fit_dir, report)
        self.bus.publish_fit(report)
        self._fit_seen(report)
        self.fitted.append(report)
        log.info("%s/%s: %s in %.2f s%s", report.bench, report.run_id, report.status,
                 report.timings.total_s, f" ({report.reason})" if report.reason else "")

    def _checked(self, finished: RunFinished, report: FitReport) -> FitReport:
        """The report as subscribers will parse it (a NaN, written as null, would not)."""
        try:
            return FitReport.from_json_bytes(report.to_json_bytes())
        except SchemaError as exc:
            return failed_report(finished, self.options.name,
                                 f"the fit report does not round-trip: {exc}")

    def _claim(self, run: RunRef, finished: RunFinished) -> bool:
        name = self.options.name
        self.sched.claim(run)
        self.bus.publish_fit(FitReport(bench=run.bench, run_id=run.run_id, worker=name,
                                       status="fitting"))
        self.pump(self.options.settle_s)
        if self.sched.claim_won(run):
            return True
        self.sched.withdraw(run)
        self.bus.publish_fit(FitReport(bench=run.bench, run_id=run.run_id, worker=name,
                                       status="withdrawn"))
        log.info("%s: another worker claimed it first; withdrawn", run)
        return False

    def _fit(self, finished: RunFinished, run_file: Path | None, fit_dir: Path) -> FitOutcome:
        name = self.options.name
        started = self.clock()
        try:
            if run_file is None:
                dest = self.options.runs_dir / finished.bench / Path(finished.file).name
                run_file = self.bus.fetch_run(finished.bench, finished.run_id, dest)
            outcome = self.fitter(FitJob(finished, run_file, fit_dir, name))
        except Exception as exc:
            log.exception("%s/%s: fit failed", finished.bench, finished.run_id)
            outcome = failed_report(finished, name, f"{type(exc).__name__}: {exc}")
        if isinstance(outcome, FitReport) and outcome.timings.total_s == 0.0:
            timings = outcome.timings.model_copy(update={"total_s": self.clock() - started})
            outcome = outcome.model_copy(update={"timings": timings})
        return outcome

    def serve(self, stop: threading.Event) -> None:
        self.start()
        while not stop.is_set():
            self.step()


def run_worker(options: WorkerOptions, stop: threading.Event) -> list[FitReport]:
    """Open the bus, serve until `stop` is set, close. Returns the reports this worker made."""
    events: queue.Queue[Event] = queue.Queue()
    fitter = load_fitter(options.fitter)
    options.runs_dir.mkdir(parents=True, exist_ok=True)
    with WorkerBus(options.bus, options.name, events) as bus:
        worker = Worker(options, bus, events, fitter)
        try:
            worker.serve(stop)
        finally:
            worker.finisher.close()
        return worker.fitted


__all__ = ["DEFAULT_FITTER", "FitJob", "Fitter", "Worker", "WorkerOptions", "failed_report",
           "load_fitter", "run_worker"]
