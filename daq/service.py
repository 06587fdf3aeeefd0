"""The `daq` service loop: serial link → acquisition core → Zenoh + one MCAP file per run.

One thread owns everything (link, core, writer, bus publishers); Zenoh callbacks only
enqueue requests or read immutable snapshots (`daq.bus`). Each turn of the loop reads one
chunk (the link's read timeout bounds a turn), feeds the core, answers queued requests,
sends batches the port left waiting, and flushes the open run file on its cadence, so a
`kill -9` loses at most `flush_interval_s` plus one batch.

Start-up recovers `.part` files left by a crash and announces them as finished with status
`recovered`. `request_stop()` (called from a signal handler: it only sets a flag) makes the
loop finish the open run (status `aborted`, reason given) and return. Clocks are injected.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import BinaryIO

from daq import __version__
from daq.bus import BusRequest, DaqBus
from daq.detector import DetectorSettings
from daq.errors import DaqIOError
from daq.frames import Dialect
from daq.pipeline import Acquisition, AcquisitionConfig
from daq.recorder import RunWriter, final_path, finished_of, open_exclusive, part_path, recover_all
from daq.recording import BACKLOG_SAMPLES, Recording
from daq.serial_link import LinkEvent, SerialLink
from schemas import SchemaError, keys, topics
from schemas.bus import BusConfig
from schemas.daq import DaqStatus, DetectorStateMsg, RunFinished, RunList, RunMetadata, SampleBatch, ZeroReply

log = logging.getLogger(__name__)
SNAPSHOT_EVERY_S = 0.2
QUIET_FLUSH_S = 0.05
MAX_REFUSAL_CHARS = 300   # a refusal quotes what was asked: bound what a caller can make us log


@dataclass(frozen=True)
class ServiceConfig:
    port: str
    runs_dir: Path
    bench: str = "bench1"
    dialect: Dialect = "cartlab"
    bus: BusConfig | None = field(default_factory=BusConfig)
    counts_per_m: float | None = None
    signs: tuple[int, int] = (1, 1)
    detector: DetectorSettings = field(default_factory=DetectorSettings)
    until_eof: bool = False
    baudrate: int = 115200
    flush_interval_s: float = 0.25
    #: samples kept in memory while the disk is full (`daq.recording.BACKLOG_SAMPLES`)
    disk_backlog_samples: int = BACKLOG_SAMPLES


class _Outputs:
    """The core's sink: live data to the bus, runs to files (and their end to the bus)."""

    def __init__(self, service: Service, opener: Callable[[Path], BinaryIO] | None) -> None:
        self.service = service
        config = service.config
        self.recording = Recording(config.runs_dir, config.flush_interval_s, service.clock,
                                   opener=opener or open_exclusive, on_recovered=service.announce,
                                   backlog_samples=config.disk_backlog_samples)

    @property
    def writer(self) -> RunWriter | None:
        return self.recording.writer

    def live(self, batch: SampleBatch) -> None:
        if self.service.bus is not None:
            self.service.bus.publish_samples(batch.to_json_bytes())

    def state(self, msg: DetectorStateMsg) -> None:
        if self.service.bus is not None:
            self.service.bus.publish_state(msg)
        self.recording.state(msg)
        log.debug("detector %s at %.3f s", msg.state, msg.t_ns / 1e9)

    def run_started(self, metadata: RunMetadata) -> None:
        self.recording.start(metadata)
        if self.writer is not None:
            log.info("run %s: release at %.3f s (device), recording to %s", metadata.run_id,
                     (metadata.release_t_ns or 0) / 1e9, self.writer.path.name)

    def run_samples(self, batch: SampleBatch) -> None:
        self.recording.samples(batch)

    def run_finished(self, metadata: RunMetadata, finished: RunFinished) -> None:
        finished = self.recording.finish(metadata, finished)
        self.service.announce(finished)
        log.info("run %s %s: %d samples, release at %.3f s, %s", finished.run_id, finished.status,
                 finished.n_samples, finished.release_time_s or float("nan"), finished.reason or "")


class Service:
    """Build with a config; `run()` until EOF (with `until_eof`) or `request_stop()`."""

    def __init__(self, config: ServiceConfig, clock: Callable[[], float] = time.monotonic,
                 wall_clock: Callable[[], datetime] = lambda: datetime.now(UTC),
                 link: SerialLink | None = None,
                 opener: Callable[[Path], BinaryIO] | None = None) -> None:
        """`opener` opens a new run file (tests inject a full disk there)."""
        self.config = config
        self.clock = clock
        keys.check_name("bench", config.bench)
        self.link = link or SerialLink(config.port, baudrate=config.baudrate, clock=clock)
        self.outputs = _Outputs(self, opener)
        self.acq = Acquisition(
            AcquisitionConfig(bench=config.bench, port=config.port, dialect=config.dialect,
                              counts_per_m=config.counts_per_m, signs=config.signs, detector=config.detector),
            self.outputs, wall_clock=wall_clock, existing_run_ids=self._run_id_taken)
        self.bus: DaqBus | None = None
        self.finished_runs: list[RunFinished] = []
        self.connected = False
        self._stop = threading.Event()
        self._last_snapshot = -1e9
        self._runs_changed = True     # the run list must be (re)published with the next snapshot
        self._last_data = 0.0

    # --- control ---------------------------------------------------------------------------------
    def request_stop(self) -> None:
        """Safe from a signal handler: only sets a flag the loop checks every turn."""
        self._stop.set()

    def announce(self, finished: RunFinished) -> None:
        self.finished_runs.append(finished)
        self._runs_changed = True
        if self.bus is not None:
            self.bus.publish_finished(finished)
        self._publish_snapshot(force=True)

    # --- main loop ---------------------------------------------------------------------------------
    def run(self) -> int:
        """Serve until stopped; returns the number of runs finished in this session."""
        self.config.runs_dir.mkdir(parents=True, exist_ok=True)
        recovered = recover_all(self.config.runs_dir)
        self.finished_runs = self._scan_runs()
        self._runs_changed = True
        try:
            self.link.open()
            self.connected = True
            if self.config.bus is not None:
                self.bus = DaqBus(self.config.bench, self.config.bus)
            for finished in recovered:
                log.info("recovered %s from a crash: %d samples", finished.file, finished.n_samples)
                if self.bus is not None:
                    self.bus.publish_finished(finished)
            self._publish_snapshot(force=True)
            return self._loop()
        finally:
            self._shutdown()

    def _loop(self) -> int:
        started = self.acq.runs_started
        eof = False
        while not self._stop.is_set():
            if eof:
                if self.config.until_eof:
                    break
                self._stop.wait(0.05)
            else:
                eof = self._turn()
            self._serve_requests()
            self._publish_snapshot()
        self.acq.finish("stopped by signal" if self._stop.is_set() else "end of stream")
        return self.acq.runs_started - started

    def _turn(self) -> bool:
        got = self.link.read()
        now = self.clock()
        if got.data:
            self.acq.data(got.data)
            self._last_data = now
        elif got.event is LinkEvent.DATA and now - self._last_data > QUIET_FLUSH_S:
            self.acq.flush()
        if got.event is LinkEvent.DISCONNECTED:
            self.connected = False
            self.acq.disconnected()
            log.warning("serial port %s disconnected; reopening with back-off", self.config.port)
        elif got.event is LinkEvent.RECONNECTED:
            self.connected = True
            self.acq.reconnected()
            log.warning("serial port %s back after %.1f s", self.config.port, got.gap_s or 0.0)
        # the back-off after a disconnect may sleep: leave nothing in memory meanwhile
        self.outputs.recording.flush(now, always=got.event is LinkEvent.DISCONNECTED)
        return got.event is LinkEvent.EOF

    def _shutdown(self) -> None:
        self.outputs.recording.abandon()   # only after an exception: a normal stop finished the run
        self.link.close()
        if self.bus is not None:
            self.bus.close()
            self.bus = None

    # --- requests and snapshots ----------------------------------------------------------------------
    def _serve_requests(self) -> None:
        if self.bus is None:
            return
        while True:
            try:
                request = self.bus.requests.get_nowait()
            except queue.Empty:
                return
            self._answer(self.bus, request)

    def _answer(self, bus: DaqBus, request: BusRequest) -> None:
        if request.kind == "zero":
            offsets = self.acq.zero_now()
            reply = ZeroReply(bench=self.config.bench, ok=offsets is not None,
                              zero_offsets_raw=list(offsets or ()),
                              message="" if offsets is not None else "no sample received yet")
            bus.reply_record(request, reply)
        elif request.kind == "arm":
            self.acq.arm_now()
            bus.reply_record(request, self.status())
        else:
            self._answer_run(bus, request)
        self._publish_snapshot(force=True)

    def _answer_run(self, bus: DaqBus, request: BusRequest) -> None:
        try:
            run_id = keys.check_name("run_id", request.run_id or "")
        except SchemaError as exc:
            self._refuse(bus, request, f"run: {exc}")
            return
        runs_dir = self.config.runs_dir.resolve()
        path = final_path(runs_dir, run_id).resolve()
        if path.parent != runs_dir or not path.is_file():
            self._refuse(bus, request, f"run: expected the id of a finished run in this bench's runs directory, "
                                       f"got {run_id!r}")
            return
        bus.reply_bytes(request, path.read_bytes())

    @staticmethod
    def _refuse(bus: DaqBus, request: BusRequest, reason: str) -> None:
        """Answer a request with an error reply and log why (the reason shortened)."""
        if len(reason) > MAX_REFUSAL_CHARS:
            reason = reason[:MAX_REFUSAL_CHARS] + f"... ({len(reason)} characters)"
        log.warning("refused a %s request: %s", request.kind, reason)
        bus.reply_error(request, reason)

    def status(self) -> DaqStatus:
        acq = self.acq
        last = acq.calibration.metres(acq.last_raw) if acq.last_raw is not None else None
        return DaqStatus(bench=self.config.bench, state=acq.state,
                         run_id=acq.run.metadata.run_id if acq.run is not None else None,
                         port=self.config.port, dialect=self.config.dialect, connected=self.connected,
                         counts_per_m=acq.calibration.counts_per_m,
                         zero_offsets_raw=list(acq.calibration.zero_offsets_raw), last_t_ns=acq.last_t_ns,
                         last_pos_m=list(last) if last is not None else None, n_runs=len(self.finished_runs),
                         counters=acq.counters(), software_version=__version__)

    def _publish_snapshot(self, force: bool = False) -> None:
        now = self.clock()
        if self.bus is None or (not force and now - self._last_snapshot < SNAPSHOT_EVERY_S):
            return
        self._last_snapshot = now
        runs = RunList(bench=self.config.bench, runs=list(self.finished_runs)) if self._runs_changed else None
        self.bus.set_snapshot(self.status(), runs)
        self._runs_changed = False

    # --- runs directory ---------------------------------------------------------------------------------
    def _run_id_taken(self, run_id: str) -> bool:
        runs_dir = self.config.runs_dir
        return final_path(runs_dir, run_id).exists() or part_path(runs_dir, run_id).exists()

    def _scan_runs(self) -> list[RunFinished]:
        found = []
        for path in sorted(self.config.runs_dir.glob(f"*{topics.RUN_SUFFIX}")):
            try:
                finished = finished_of(path)
            except (DaqIOError, SchemaError) as exc:
                log.warning("skipping %s: %s", path.name, exc)
                continue
            if finished is not None and finished.bench == self.config.bench:
                found.append(finished)
        return found
