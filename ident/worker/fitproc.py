"""Fits run in one child process, so that a stop (SIGTERM) cancels a fit cleanly.

The worker loop hands a job to `FitProcess.submit`; the child (started with `spawn`: a fork
of a process holding a Zenoh session is unsafe) runs the fitter and sends back, through a
pipe, first the early results of a `Pending` outcome (`FitResult(partial=True)`), then the
complete report. A reader thread in the parent (not a daemon: `close` joins it) turns what
arrives into `FitResult` items on the loop's event queue; only the loop publishes.

Bounds: one fit at a time; a fit that takes longer than `max_fit_s` is ended by ending the
child (the job gets a failed report naming the limit, and a new child is started for the next
job). `close()` ends the child at once: a stop never waits for a diagnosis to finish, and the
interpreter shuts down with no thread left running a fit.
"""

from __future__ import annotations

import logging
import multiprocessing
import multiprocessing.connection
import os
import queue
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from ident.errors import IdentError
from schemas.errors import SchemaError
from schemas.fit import FitReport

log = logging.getLogger("ident.worker")

#: Longest a fit may take (s) before its child process is ended and the job reported failed.
DEFAULT_MAX_FIT_S = 600.0


@dataclass(frozen=True)
class Pending:
    """First results of a fit (`partial`, an `ok` report with `pending` stages) and the rest."""

    partial: FitReport
    finish: Callable[[], FitReport]


FitOutcome = FitReport | Pending


class FitProcessError(IdentError, RuntimeError):
    """The fit process ended before it could take a job (its fitter failed to load)."""

    def __init__(self, exitcode: int | None) -> None:
        super().__init__(f"the fit process ended at start-up (exit code {exitcode}): expected it to load "
                         "the fitter; run the worker in the foreground to see the child's traceback")


@dataclass(frozen=True)
class FitResult:
    """What the child made of job `job_id`: early results (`partial`) or the complete report."""

    job_id: int
    report: FitReport
    partial: bool = False


def _die_with_parent(parent_pid: int) -> None:
    """Ask Linux to SIGKILL this process when its parent dies (a kill -9 of the worker must
    not leave an orphan fit that publishes nothing but still writes figures)."""
    import ctypes
    import os
    import signal

    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, int(signal.SIGKILL))   # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        return   # not Linux: the child ends at its next job, when the pipe reports EOF
    if os.getppid() != parent_pid:   # the parent died before prctl took effect
        raise SystemExit(1)


def _child_main(fitter: Callable[[Any], FitOutcome], conn: multiprocessing.connection.Connection,
                parent_pid: int) -> None:
    """The child's loop: one job at a time, results back as JSON (`(kind, job_id, bytes)`)."""
    import signal

    _die_with_parent(parent_pid)
    signal.signal(signal.SIGINT, signal.SIG_IGN)   # the parent decides when a fit ends
    # the fitter was unpickled before this runs: its module and what it imports are loaded
    conn.send(("ready", 0, b""))
    while True:
        try:
            item = conn.recv()
        except EOFError:
            return
        if item is None:
            return
        job_id, job, on_error = item
        try:
            outcome = fitter(job)
            if isinstance(outcome, Pending):
                conn.send(("partial", job_id, outcome.partial.to_json_bytes()))
                outcome = outcome.finish()
            conn.send(("final", job_id, outcome.to_json_bytes()))
        except Exception as exc:
            log.exception("fit failed")
            conn.send(("final", job_id, on_error(f"{type(exc).__name__}: {exc}").to_json_bytes()))


@dataclass
class _Running:
    job_id: int
    started: float
    on_error: Callable[[str], FitReport]


class FitProcess:
    """One child process running fits in order; results come back on `out` as `FitResult`s.

    `on_error` (given per job, picklable) builds the failed report for an exception or a
    fit that overran `max_fit_s`.
    """

    def __init__(self, fitter: Callable[[Any], FitOutcome], out: queue.Queue[Any],
                 max_fit_s: float = DEFAULT_MAX_FIT_S, clock: Callable[[], float] = time.monotonic) -> None:
        self._fitter = fitter
        self._out = out
        self.max_fit_s = max_fit_s
        self._clock = clock
        self._ctx = multiprocessing.get_context("spawn")
        self._lock = threading.Lock()
        self._queued: list[_Running] = []       # submitted, not completed, in order
        self._next_id = 0
        self._start_child()

    def _start_child(self) -> None:
        self._ready = threading.Event()   # set when the child is ready, or gone
        self._child_ready = False
        parent, child = self._ctx.Pipe()
        self._conn = parent
        self._proc = self._ctx.Process(target=_child_main, args=(self._fitter, child, os.getpid()),
                                       name="ident-fit", daemon=False)
        self._proc.start()
        child.close()
        self._reader = threading.Thread(target=self._read, args=(parent, self._ready), name="fit-results")
        self._reader.start()

    def wait_ready(self, timeout_s: float, stop: threading.Event | None = None) -> bool:
        """Wait (at most `timeout_s`, less if `stop` is set) until the child has loaded the
        fitter; True when it has. Raises `FitProcessError` if the child ended before."""
        deadline = self._clock() + timeout_s
        while not self._ready.wait(timeout=0.1):
            if self._clock() >= deadline or (stop is not None and stop.is_set()):
                return False
        if not self._child_ready:
            raise FitProcessError(self._proc.exitcode)
        return True

    @property
    def backlog(self) -> int:
        """Jobs submitted and not yet completed."""
        with self._lock:
            return len(self._queued)

    def submit(self, job: Any, on_error: Callable[[str], FitReport]) -> int:
        """Queue `job` for the child; returns its id (the `job_id` of its results)."""
        with self._lock:
            self._next_id += 1
            job_id = self._next_id
            self._queued.append(_Running(job_id, self._clock(), on_error))
            if len(self._queued) == 1:
                self._queued[0].started = self._clock()
        self._conn.send((job_id, job, on_error))
        return job_id

    def check_time(self) -> None:
        """End a fit that overran `max_fit_s` (called by the loop every turn)."""
        with self._lock:
            head = self._queued[0] if self._queued else None
        if head is None or self._clock() - head.started <= self.max_fit_s:
            return
        log.warning("fit %d overran %.0f s: ending its process", head.job_id, self.max_fit_s)
        lost = self._end_child()
        for running in lost:
            reason = (f"the fit took longer than {self.max_fit_s:g} s and was ended"
                      if running is head else "its fit process was ended (an earlier fit overran)")
            self._out.put(FitResult(running.job_id, running.on_error(reason)))
        self._start_child()

    def _read(self, conn: multiprocessing.connection.Connection, ready: threading.Event) -> None:
        try:
            self._read_results(conn, ready)
        finally:
            ready.set()   # the child is gone: nobody waits for it any more

    def _read_results(self, conn: multiprocessing.connection.Connection, ready: threading.Event) -> None:
        while True:
            try:
                kind, job_id, payload = conn.recv()
            except (EOFError, OSError):
                return
            if kind == "ready":
                self._child_ready = True
                ready.set()
                continue
            with self._lock:
                running = next((r for r in self._queued if r.job_id == job_id), None)
                if kind == "final":
                    self._queued = [r for r in self._queued if r.job_id != job_id]
                    if self._queued:
                        self._queued[0].started = self._clock()
            try:
                report = FitReport.from_json_bytes(payload)
            except SchemaError as exc:   # e.g. a NaN, written as null: subscribers could not parse it
                if running is None:
                    continue
                report = running.on_error(f"the fit report does not round-trip: {exc}")
                kind = "final" if kind == "final" else "dropped"
            if kind != "dropped":
                self._out.put(FitResult(job_id, report, partial=kind == "partial"))

    def _end_child(self) -> list[_Running]:
        self._stop_child(kill=True)
        with self._lock:
            lost, self._queued = self._queued, []
        return lost

    def _stop_child(self, kill: bool) -> None:
        """End the child, then the reader (it sees the pipe close), then our end of the pipe."""
        if self._proc.is_alive():
            self._proc.kill() if kill else self._proc.terminate()
            self._proc.join(timeout=5.0)
            if self._proc.is_alive():
                self._proc.kill()
                self._proc.join(timeout=5.0)
        self._reader.join(timeout=5.0)
        self._conn.close()

    def close(self) -> None:
        """End the child now (a fit in progress is cancelled) and join the reader."""
        self._stop_child(kill=False)


__all__ = ["DEFAULT_MAX_FIT_S", "FitOutcome", "FitProcess", "FitProcessError", "FitResult", "Pending"]
