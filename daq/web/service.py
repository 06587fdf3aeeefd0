"""The page server's engine: drains the Zenoh inbox into the hub and pushes events.

Runs on the asyncio loop of the web server:

- `pump`: every `flush_s` (50 ms), parse what the Zenoh callbacks enqueued (bounded per
  tick), feed the `Hub`, and hand its events to the `Broadcaster`: at most 20 pushes/s
  per page whatever the sample rate.
- `poll_status`: once per `status_every_s`, one `status` query per alive bench (not per
  page), so port and zero changes show without any page polling.
- `zero`/`arm`: a page's button press, one query in a worker thread.

Zenoh calls that block (queries) run in worker threads; declaring subscribers runs on the
loop (it does not wait on the network).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import queue
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import anyio.to_thread

from daq.web.broadcast import Broadcaster
from daq.web.files import RunFileError, fit_dir, list_fit_files
from daq.web.hub import Hub
from daq.web.link import InboxItem, QueryFailed, WebLink
from daq.web.live import DEFAULT_DISPLAY_HZ
from schemas import keys
from schemas.bus import BusConfig
from schemas.daq import DetectorStateMsg, RunFinished, SampleBatch
from schemas.fit import FitReport
from schemas.run_file import REPORT_NAME

log = logging.getLogger(__name__)

#: Most inbox items parsed per flush (about 25 s of 1 kHz batches of 20 for one bench).
MAX_ITEMS_PER_TICK = 5000
#: Most recent runs per bench whose fit folder is looked at on each status tick.
MAX_RUNS_SCANNED = 50


@dataclass(frozen=True)
class WebSettings:
    """How the page server joins Zenoh and what it serves."""

    bus: BusConfig
    runs_dir: Path | None = None
    display_hz: float = DEFAULT_DISPLAY_HZ
    flush_s: float = 0.05
    status_every_s: float = 1.0
    query_timeout_s: float = 2.0
    #: Host names (or addresses) the page answers to besides loopback and its bind address.
    allow_hosts: tuple[str, ...] = ()


class WebService:
    def __init__(self, settings: WebSettings) -> None:
        self.settings = settings
        self.inbox: queue.SimpleQueue[InboxItem] = queue.SimpleQueue()
        self.hub = Hub(settings.display_hz, fit_files=self._fit_files)
        self.broadcaster = Broadcaster()
        self.link = WebLink(settings.bus, self.inbox)
        self.bad_messages = 0
        self.flushes = 0
        self._tasks: list[asyncio.Task[None]] = []
        self._loop: asyncio.AbstractEventLoop | None = None
        self._bad_reports: set[tuple[str, str]] = set()
        self._pending: set[asyncio.Task[None]] = set()

    # -- lifecycle ---------------------------------------------------------------------
    async def start(self) -> None:
        self._loop = asyncio.get_running_loop()
        await anyio.to_thread.run_sync(self.link.open)
        self._tasks = [asyncio.create_task(self._pump()),
                       asyncio.create_task(self._poll_status())]

    async def stop(self) -> None:
        for task in self._tasks:
            task.cancel()
        for task in self._tasks:
            with contextlib.suppress(asyncio.CancelledError):
                await task
        self.broadcaster.close_all()
        await anyio.to_thread.run_sync(self.link.close)

    def end_streams_threadsafe(self) -> None:
        """End every page's event stream (from any thread): the server can then stop at once.

        Event streams never finish by themselves, and the server waits for open requests
        before it shuts down.
        """
        loop = self._loop
        if loop is not None and not loop.is_closed():
            loop.call_soon_threadsafe(self.broadcaster.close_all)

    # -- the inbox ---------------------------------------------------------------------
    def _fit_files(self, run_id: str) -> list[str]:
        runs_dir = self.settings.runs_dir
        return [] if runs_dir is None else list_fit_files(runs_dir, run_id)

    def _read_local_fit(self, bench: str, run_id: str) -> FitReport | None:
        """`<runs-dir>/<run_id>.fit/report.json` when present and about this run, else None."""
        runs_dir = self.settings.runs_dir
        if runs_dir is None or (bench, run_id) in self._bad_reports:
            return None
        path = fit_dir(runs_dir, run_id) / REPORT_NAME
        if not path.is_file():
            return None
        try:
            report = FitReport.from_json_bytes(path.read_bytes())
        except (OSError, ValueError) as exc:
            log.warning("unreadable fit report %s: %s", path.name, exc)
            self._bad_reports.add((bench, run_id))
            return None
        return report if (report.bench, report.run_id) == (bench, run_id) else None

    def _load_local_fit(self, bench: str, run_id: str) -> None:
        if run_id not in self.hub.bench(bench).fits:
            report = self._read_local_fit(bench, run_id)
            if report is not None:
                self.hub.on_fit(report)

    def handle(self, item: InboxItem) -> None:
        """Parse one inbox item and feed the hub (bad payloads are counted and skipped)."""
        try:
            if item.kind == "alive":
                bench = keys.bench_of(item.key)
                self.hub.on_alive(bench, item.up, time.time())
                if item.up:
                    self.link.follow(bench)
                    task = asyncio.get_running_loop().create_task(self.refresh(bench))
                    self._pending.add(task)              # keep a reference until it is done
                    task.add_done_callback(self._pending.discard)
            elif item.kind == "samples":
                self.hub.on_samples(SampleBatch.from_json_bytes(item.payload))
            elif item.kind == "state":
                self.hub.on_state(DetectorStateMsg.from_json_bytes(item.payload))
            elif item.kind == "finished":
                rec = RunFinished.from_json_bytes(item.payload)
                self.hub.on_finished(rec)
                self._load_local_fit(rec.bench, rec.run_id)
            elif item.kind == "fit":
                self.hub.on_fit(FitReport.from_json_bytes(item.payload))
        except ValueError as exc:
            self.bad_messages += 1
            log.warning("skipped a bad %s message on %s: %s", item.kind, item.key, exc)

    def drain(self) -> int:
        count = 0
        while count < MAX_ITEMS_PER_TICK:
            try:
                item = self.inbox.get_nowait()
            except queue.Empty:
                break
            self.handle(item)
            count += 1
        return count

    async def _pump(self) -> None:
        while True:
            await asyncio.sleep(self.settings.flush_s)
            self.drain()
            self.broadcaster.publish(self.hub.flush())
            self.flushes += 1

    # -- queries -----------------------------------------------------------------------
    async def _call(self, fn: Any, *args: Any) -> Any:
        return await anyio.to_thread.run_sync(fn, *args, self.settings.query_timeout_s)

    async def refresh_status(self, bench: str) -> None:
        try:
            status = await self._call(self.link.status, bench)
        except (QueryFailed, ValueError) as exc:
            if self.hub.bench(bench).alive:
                self.hub.on_status(bench, None, f"daq for bench {bench} does not answer: {exc}",
                                  time.time())
            return
        self.hub.on_status(bench, status, None, time.time())

    async def refresh(self, bench: str) -> None:
        """Runs and status of a bench whose daq just appeared."""
        try:
            runs = await self._call(self.link.runs, bench)
        except (QueryFailed, ValueError) as exc:
            log.warning("run list of %s: %s", bench, exc)
        else:
            self.hub.on_runs(runs)
            for rec in runs.runs:
                self._load_local_fit(rec.bench, rec.run_id)
        await self.refresh_status(bench)

    def scan_local_fits(self, limit: int = MAX_RUNS_SCANNED) -> int:
        """Load fit results written in the runs dir for runs still without one; how many.

        A fit report reaches the page over Zenoh only if the worker's session is linked to
        the page's (directly or through a router); on one machine the files are enough.
        """
        loaded = 0
        for name, view in list(self.hub.benches.items()):
            waiting = [run_id for run_id in view.finished
                       if run_id not in view.fits or not view.fits[run_id].final]
            for run_id in waiting[-limit:]:
                report = self._read_local_fit(name, run_id)
                if report is not None and report.final:
                    self.hub.on_fit(report)
                    loaded += 1
        return loaded

    async def _poll_status(self) -> None:
        while True:
            await asyncio.sleep(self.settings.status_every_s)
            self.scan_local_fits()
            for bench in [name for name, view in self.hub.benches.items() if view.alive]:
                await self.refresh_status(bench)

    async def zero(self, bench: str) -> dict[str, Any]:
        """Zero a bench now; the reply as the page shows it."""
        try:
            reply = await self._call(self.link.zero, bench)
        except (QueryFailed, ValueError) as exc:
            return {"ok": False, "message": f"zero failed: {exc}"}
        await self.refresh_status(bench)
        text = reply.message or ("zeroed: offsets " + ", ".join(f"{x:g}" for x in reply.zero_offsets_raw))
        return {"ok": reply.ok, "message": text, "reply": reply.model_dump(mode="json")}

    async def arm(self, bench: str) -> dict[str, Any]:
        """Arm a bench's release detector; the reply as the page shows it."""
        try:
            status = await self._call(self.link.arm, bench)
        except (QueryFailed, ValueError) as exc:
            return {"ok": False, "message": f"arm failed: {exc}"}
        self.hub.on_status(bench, status, None, time.time())
        return {"ok": status.state == "armed", "message": f"detector {status.state}",
                "reply": status.model_dump(mode="json")}

    async def run_bytes(self, bench: str, run_id: str) -> bytes:
        """A run's MCAP bytes over Zenoh (when the runs directory is not local)."""
        try:
            return bytes(await anyio.to_thread.run_sync(self.link.run_bytes, bench, run_id))
        except QueryFailed as exc:
            raise RunFileError(str(exc)) from exc
