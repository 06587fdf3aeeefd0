"""The worker's main loop: drain events, claim, fit (in a child process), fence, report.

Zenoh callbacks (`ident.worker.bus`) only enqueue `BusEvent`s on a bounded queue; this loop
parses them, updates the `Scheduler`, hands claimed runs to the `FitProcess` (a child process
running the fitter, a plug-in: `FitJob -> FitReport | Pending`) and publishes what comes back
(`FitResult`s, through the same queue): only this loop publishes, writes reports and touches
the scheduler. Waits are bounded by the injected clock; the loop ends when `stop` is set.

Faults handled here (issue 14):
- A run whose file cannot be had (no local file and the daq does not answer) is deferred,
  not failed: the claim is withdrawn and the run retried when the bench's daq comes back,
  or after `retry_s`.
- Before a final report goes out the loop syncs (pending events, and after a stall longer
  than `stall_s`, e.g. a SIGSTOP past the lease, the other workers' fit queryables) and
  publishes only if it is not fenced (`Scheduler.fenced`): no final report of another
  worker, no alive claim of a higher epoch. A fenced result is dropped, never published.
- Events dropped by the bounded queue (a flood) are made up by a catch-up: every alive
  daq's `runs` list is asked again.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import UTC, datetime
from functools import partial
from pathlib import Path

from ident.worker.bus import MAX_FETCH_BYTES, MAX_QUEUED, BusEvent, RunUnavailable, WorkerBus
from ident.worker.fitproc import DEFAULT_MAX_FIT_S, FitProcess, FitResult
from ident.worker.job import FitJob, Fitter
from ident.worker.runs_dir import (
    find_run_file,
    fit_dir_for,
    read_report,
    scan_runs,
    write_report,
)
from ident.worker.schedule import RunRef, Scheduler
from schemas import keys
from schemas.bus import BusConfig
from schemas.daq import RunFinished
from schemas.errors import SchemaError
from schemas.fit import FitReport

log = logging.getLogger("ident.worker")

#: Bytes of run file allowed per sample the finished record claims (a fetch bound; real
#: files hold well under 0.1 KiB per sample).
FETCH_BYTES_PER_SAMPLE = 2048

Event = BusEvent | FitResult


@dataclass
class WorkerOptions:
    """Settings of one worker. `settle_s` is how long a claim waits for rival claims;
    `retry_s` how long a run whose file could not be had waits before it is tried again;
    `stall_s` the gap between two turns of the loop that means the process was stopped, and
    `reconnect_s` how long it then waits for its session to reconnect before syncing;
    `ready_s` the longest the worker waits for its fit process before it declares itself alive."""

    name: str
    runs_dir: Path
    bus: BusConfig = field(default_factory=BusConfig.connector)
    settle_s: float = 0.2
    sync_s: float = 0.3
    poll_s: float = 0.05
    max_backlog: int = 4
    retry_s: float = 30.0
    stall_s: float = 2.0
    reconnect_s: float = 5.0
    max_fit_s: float = DEFAULT_MAX_FIT_S
    ready_s: float = 300.0


def failed_report(finished: RunFinished, worker: str, reason: str) -> FitReport:
    return FitReport(bench=finished.bench, run_id=finished.run_id, worker=worker,
                     status="failed", reason=reason[:2000], release_time_s=finished.release_time_s,
                     fitted_utc=datetime.now(UTC).isoformat())


@dataclass(frozen=True)
class _InFlight:
    run: RunRef
    fit_dir: Path
    started: float


class Worker:
    """A worker bound to an open `WorkerBus` (see `run_worker` for the usual entry)."""

    def __init__(self, options: WorkerOptions, bus: WorkerBus, events: queue.Queue[Event],
                 fitter: Fitter, clock: Callable[[], float] = time.monotonic,
                 fits: FitProcess | None = None) -> None:
        self.options = options
        self.bus = bus
        self.events = events
        self.fitter = fitter
        self.clock = clock
        self._fits = fits
        self.sched = Scheduler(options.name)
        self.fitted: list[FitReport] = []
        self.fenced: list[FitReport] = []
        self._complete_reports: dict[str, bytes] = {}
        self._in_flight: dict[int, _InFlight] = {}
        self._last_turn = clock()

    @property
    def fits(self) -> FitProcess:
        if self._fits is None:
            self._fits = FitProcess(self.fitter, self.events, self.options.max_fit_s, self.clock)
        return self._fits

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
            self.bus.taken(event)
            self.handle(event)

    def handle(self, event: Event) -> None:
        if isinstance(event, FitResult):
            self._fit_result(event)
            return
        try:
            if event.kind == "finished":
                finished = RunFinished.from_json_bytes(event.payload)
                # the key is what access control checks: a payload that contradicts it is forged
                bench, run_id, _ = keys.parse_run_key(event.key)
                if (bench, run_id) != (finished.bench, finished.run_id):
                    raise SchemaError("finished record", f"bench {bench!r} and run {run_id!r} as its key",
                                      f"{finished.bench!r}/{finished.run_id!r}")
                self.sched.run_announced(finished)
            elif event.kind == "fit":
                self._fit_seen(FitReport.from_json_bytes(event.payload))
            elif event.kind == "worker":
                self._worker_event(event.key.rsplit("/", 1)[-1], event.up)
            elif event.kind == "daq" and event.up:
                bench = keys.bench_of(event.key)
                self.sched.retry_now(bench)
                self.catch_up_bench(bench)
        except SchemaError as exc:
            log.warning("ignored a message on %s: %s", event.key, exc)

    def _fit_seen(self, report: FitReport) -> None:
        run = self.sched.fit_seen(report)
        key = keys.run_fit(report.bench, report.run_id)
        done = self.sched.runs[run].final
        if done is not None and key not in self._complete_reports:
            self._complete_reports[key] = done.to_json_bytes()
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
            self.handle(BusEvent("finished", keys.run_finished(bench, finished.run_id),
                                 finished.to_json_bytes()))

    def catch_up(self) -> None:
        """Learn again what the others know: alive workers, their complete reports, every
        alive daq's runs (after dropped events or a stall)."""
        for name in self.bus.alive_workers():
            self.sched.worker_up(name)
        for payload in self.bus.known_fits():
            self.handle(BusEvent("fit", keys.ALL_FITS, payload))
        for bench in sorted(self.bus.alive_benches()):
            self.catch_up_bench(bench)
        self._last_turn = self.clock()   # blocking queries are not a stall

    def start(self, stop: threading.Event | None = None) -> None:
        """Scan the runs directory, wait for the fit process to be ready, declare this worker
        alive, then learn who else is alive and which runs the others know are done, ask each
        daq, gather history. The fit process starts first: its imports (seconds) overlap with
        the scan. The token comes only once a job can start at once: the others hand this
        worker runs as soon as they see it, and a first fit must not wait for the start-up
        (after `ready_s` it is declared anyway, its jobs then waiting; on `stop` never)."""
        fits = self.fits
        for _, finished in scan_runs(self.options.runs_dir):
            self.sched.run_announced(finished)
        started = self.clock()
        if fits.wait_ready(self.options.ready_s, stop):
            log.info("fit process ready in %.1f s", self.clock() - started)
        elif stop is not None and stop.is_set():
            return   # stopped while starting: never declared, nothing to undo
        else:
            log.warning("the fit process is not ready after %.0f s: declaring this worker alive anyway",
                        self.options.ready_s)
        self.bus.declare_alive()
        self.catch_up()
        self.pump(self.options.sync_s)
        self._last_turn = self.clock()

    # -- one step -----------------------------------------------------------------------
    def step(self) -> bool:
        """Handle queued events, then claim and start one run if one is mine. True if started."""
        self._notice_stall()
        if self.bus.take_dropped():
            log.warning("events were dropped (a flood); catching up with the daqs and workers")
            self.catch_up()
        self.pump(0.0)
        if self._fits is not None:
            self._fits.check_time()
        busy = len(self._in_flight) >= self.options.max_backlog
        run = None if busy else self.sched.next_claim(self.clock())
        if run is None:
            self.pump(self.options.poll_s)
            return False
        return self.process(run)

    def _notice_stall(self) -> None:
        now = self.clock()
        gap, self._last_turn = now - self._last_turn, now
        if gap > self.options.stall_s:
            log.warning("the loop stalled %.1f s (stopped, or starved): syncing before publishing", gap)
            known = self.sched.alive - {self.options.name}
            self.bus.wait_reconnected(timeout_s=self.options.reconnect_s)
            # a new session learns the others' tokens and queryables a moment after it opens:
            # sync only once the workers known before the stall are seen again (or given up)
            self.bus.wait_for_workers(known, timeout_s=self.options.reconnect_s)
            self.catch_up()
            self.pump(self.options.sync_s)

    def process(self, run: RunRef) -> bool:
        finished = self.sched.runs[run].finished
        assert finished is not None
        run_file = find_run_file(self.options.runs_dir, run.bench, finished.file)
        fit_dir = fit_dir_for(self.options.runs_dir, run.bench, run.run_id, run_file)
        stored = read_report(fit_dir)
        if stored is not None and stored.run_digest == finished.digest():
            log.info("%s: already fitted (%s); republishing the stored report", run, fit_dir)
            self._fit_seen(stored)
            self.bus.publish_fit(stored)
            return False
        epoch = self._claim(run)
        if epoch is None:
            return False
        if run_file is None:
            run_file = self._fetch(run, finished, epoch)
            self._last_turn = self.clock()   # a fetch blocks: not a stall
            if run_file is None:
                return False
        job = FitJob(finished, run_file, fit_dir, self.options.name)
        job_id = self.fits.submit(job, partial(failed_report, finished, self.options.name))
        self._in_flight[job_id] = _InFlight(run, fit_dir, self.clock())
        return True

    def _fetch(self, run: RunRef, finished: RunFinished, epoch: int) -> Path | None:
        """The run's bytes from its daq, or None (deferred: the daq is away or refused)."""
        dest = self.options.runs_dir / finished.bench / Path(finished.file).name
        # a run file holds about 0.3 KiB per sample: bound the fetch by what the record claims
        limit = min(MAX_FETCH_BYTES, (1 << 20) + finished.n_samples * FETCH_BYTES_PER_SAMPLE)
        try:
            return self.bus.fetch_run(finished.bench, finished.run_id, dest, max_bytes=limit)
        except RunUnavailable as exc:
            self._last_turn = self.clock()
            log.warning("%s: %s; retried when its daq is back (or in %.0f s)", run, exc,
                        self.options.retry_s)
            self.sched.defer(run, self.clock() + self.options.retry_s)
            self.bus.publish_fit(FitReport(bench=run.bench, run_id=run.run_id, worker=self.options.name,
                                           status="withdrawn", epoch=epoch))
            return None

    def _fit_result(self, result: FitResult) -> None:
        flight = self._in_flight.get(result.job_id)
        if flight is None:
            return
        finished = self.sched.runs[flight.run].finished
        assert finished is not None
        report = result.report.model_copy(update={"run_digest": finished.digest(),
                                                  "epoch": self.sched.runs[flight.run].claims.get(
                                                      self.options.name, 0)})
        if report.timings.total_s == 0.0 and not result.partial:
            timings = report.timings.model_copy(update={"total_s": self.clock() - flight.started})
            report = report.model_copy(update={"timings": timings})
        if result.partial:
            if self.sched.fenced(flight.run) is None:
                self.bus.publish_fit(report)
                log.info("%s: first results in %.2f s; %s next", flight.run,
                         self.clock() - flight.started, " and ".join(report.pending))
            return
        del self._in_flight[result.job_id]
        self._complete(flight, report)

    def _complete(self, flight: _InFlight, report: FitReport) -> None:
        """Publish a final report unless fenced (synced first: a stall noticed, pending events,
        the others' view of the run)."""
        self._notice_stall()
        self.pump(0.0)
        self._sync_run(flight.run)
        why = self.sched.fenced(flight.run)
        self.bus.set_claim(flight.run.bench, flight.run.run_id, None)
        if why is not None:
            log.warning("%s: not publishing my report: %s (fenced)", flight.run, why)
            self.fenced.append(report)
            self.sched.withdraw(flight.run)
            return
        write_report(flight.fit_dir, report)
        self.bus.publish_fit(report)
        self._fit_seen(report)
        self.fitted.append(report)
        log.info("%s/%s: %s in %.2f s%s", report.bench, report.run_id, report.status,
                 report.timings.total_s, f" ({report.reason})" if report.reason else "")

    def _sync_run(self, run: RunRef) -> None:
        """Ask the other workers what they know of `run` (final reports, live claims)."""
        for payload in self.bus.fit_state(run.bench, run.run_id):
            self.handle(BusEvent("fit", keys.run_fit(run.bench, run.run_id), payload))
        self._last_turn = self.clock()

    def _claim(self, run: RunRef) -> int | None:
        name = self.options.name
        epoch = self.sched.claim(run)
        self.bus.publish_fit(FitReport(bench=run.bench, run_id=run.run_id, worker=name,
                                       status="fitting", epoch=epoch))
        self.bus.set_claim(run.bench, run.run_id, FitReport(
            bench=run.bench, run_id=run.run_id, worker=name, status="fitting", epoch=epoch))
        self.pump(self.options.settle_s)
        if self.sched.claim_won(run):
            return epoch
        self.sched.withdraw(run)
        self.bus.set_claim(run.bench, run.run_id, None)
        self.bus.publish_fit(FitReport(bench=run.bench, run_id=run.run_id, worker=name,
                                       status="withdrawn", epoch=epoch))
        log.info("%s: another worker claimed it first; withdrawn", run)
        return None

    def serve(self, stop: threading.Event) -> None:
        self.start(stop)
        while not stop.is_set():
            self.step()

    def close(self) -> None:
        if self._fits is not None:
            self._fits.close()


def run_worker(options: WorkerOptions, fitter: Fitter, stop: threading.Event) -> list[FitReport]:
    """Open the bus, serve until `stop` is set, close (a fit in progress is cancelled).
    `fitter` runs in the fit process: a module-level function (it is pickled by reference).
    Returns the reports this worker published."""
    events: queue.Queue[Event] = queue.Queue(maxsize=MAX_QUEUED)
    options.runs_dir.mkdir(parents=True, exist_ok=True)
    with WorkerBus(options.bus, options.name, events) as bus:
        worker = Worker(options, bus, events, fitter)
        try:
            worker.serve(stop)
        finally:
            worker.close()
        return worker.fitted


__all__ = ["Worker", "WorkerOptions", "failed_report", "run_worker"]
