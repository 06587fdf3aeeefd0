"""The acquisition core: bytes → frames → device time → metres → detector → runs.

`Acquisition` is fed the port's byte chunks and link events and calls an `Outputs` sink
with what to publish and record: live sample batches, detector state changes, and per
run the start (metadata), sample batches (the first ones hold the pre-trigger samples) and
the end. It does no I/O and reads no clock: batches close every 20 ms of device time (or when
the caller says the port went quiet), and the wall clock for run ids and UTC stamps is passed in.

Runs. A run starts at the detector's back-dated release minus `pre_trigger_s` (samples
come from a ring buffer, so the file starts before the release) and ends when the carts
settle (`complete`), or early at shutdown or end of stream (`aborted`, with the reason).
A run keeps the calibration (zero offsets) it started with; zeroing during a run only
affects the live view. A disconnected port leaves a gap interval in the counters; the
run keeps what it has and continues when the port comes back. Lost lines (a sequence gap)
leave a gap interval too; outside a run they disarm the detector only when the hole is
longer than its `max_hole_s` (a corrupted line during the hold must not lose the release),
while a disconnect or a clock anomaly always does.
"""

from __future__ import annotations

import logging
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import Protocol

import daq
from daq.calibration import Calibration
from daq.decode import make_decoder
from daq.detector import (
    METHOD,
    Armed,
    DetectorSettings,
    Disarmed,
    Event,
    Rejected,
    Released,
    ReleaseDetector,
    Settled,
)
from daq.drive import DriveSwitches
from daq.frames import DataFrame, Dialect, InfoFrame
from daq.held import lab_case, moving_carts
from daq.run_ids import new_run_id
from daq.timeline import Timeline
from schemas.daq import (
    DaqCounters,
    DetectorState,
    DetectorStateMsg,
    GapInterval,
    GapReason,
    RawUnit,
    RunFinished,
    RunMetadata,
    SampleBatch,
)

DEFAULT_COUNTS_PER_M: dict[str, float] = {"cartlab": 20000.0, "csv": 1.0, "ecp": 56000.0}
BATCH_NS = 20_000_000
MAX_BATCH = 500
MAX_LIVE_GAPS = 100   # gap intervals kept for the live status (a run keeps all of its own)
log = logging.getLogger(__name__)


class Outputs(Protocol):
    def live(self, batch: SampleBatch) -> None: ...
    def state(self, msg: DetectorStateMsg) -> None: ...
    def run_started(self, metadata: RunMetadata) -> None: ...
    def run_samples(self, batch: SampleBatch) -> None: ...
    def run_finished(self, metadata: RunMetadata, finished: RunFinished) -> None: ...


@dataclass(frozen=True)
class AcquisitionConfig:
    bench: str
    port: str
    dialect: Dialect = "cartlab"
    counts_per_m: float | None = None
    signs: tuple[int, int] = (1, 1)
    detector: DetectorSettings = field(default_factory=DetectorSettings)
    auto_zero: bool = True
    lab_case: str | None = None


class _Batch:
    """Column lists of samples waiting to be sent (one per destination): times and raw values.

    Positions are computed when the batch is taken, `pos_m = raw * gain - offset_m`, with the
    calibration the batch was filled under: the owner takes the batch before it changes the
    calibration (the same arithmetic per sample, once per batch instead of once per sample).
    """

    def __init__(self) -> None:
        self.clear()

    def clear(self) -> None:
        self.t_ns: list[int] = []
        self.raw1: list[float] = []
        self.raw2: list[float] = []
        self.target: list[float] = []
        self.duty: list[float] = []

    def add(self, t_ns: int, raw: tuple[float, ...], drive: tuple[float, float] | None) -> None:
        self.t_ns.append(t_ns)
        self.raw1.append(raw[0])
        if len(raw) == 2:
            self.raw2.append(raw[1])
        if drive is not None:
            self.target.append(drive[0])
            self.duty.append(drive[1])

    def take(self, bench: str, run_id: str | None, seq: int, unit: RawUnit,
             gains: tuple[float, ...], offsets_m: tuple[float, ...]) -> SampleBatch:
        """The batch as a record (len(gains) channels), and empty the lists."""
        g1, o1 = gains[0], offsets_m[0]
        pos1 = [r * g1 - o1 for r in self.raw1]
        pos2 = raw2 = None
        if len(gains) == 2:
            g2, o2 = gains[1], offsets_m[1]
            raw2 = self.raw2
            pos2 = [r * g2 - o2 for r in raw2]
        # a stream sends its drive with every sample or with none
        driven = len(self.target) == len(self.t_ns)
        batch = SampleBatch.model_construct(
            bench=bench, run_id=run_id, batch_seq=seq, t_ns=self.t_ns, pos1_m=pos1, pos2_m=pos2,
            raw1=self.raw1, raw2=raw2, raw_unit=unit, target=self.target if driven else None,
            duty=self.duty if driven else None, schema_version=1)
        self.clear()
        return batch


@dataclass
class _Run:
    metadata: RunMetadata
    calibration: Calibration
    counters_at_start: DaqCounters
    gaps: list[GapInterval] = field(default_factory=list)
    batch: _Batch = field(default_factory=_Batch)
    gains: tuple[float, ...] = ()
    offsets_m: tuple[float, ...] = ()
    batch_seq: int = 0
    n_samples: int = 0
    last_t_ns: int = 0


class Acquisition:
    """Feed `data(chunk)`; call `disconnected`/`reconnected`/`finish` on link events."""

    def __init__(self, config: AcquisitionConfig, outputs: Outputs,
                 wall_clock: Callable[[], datetime], existing_run_ids: Callable[[str], bool]) -> None:
        self.config = config
        self.outputs = outputs
        self._wall_clock = wall_clock
        self._run_id_taken = existing_run_ids
        self.decoder = make_decoder(config.dialect)
        self.timeline = Timeline(clock_bits=32 if config.dialect == "cartlab" else None)
        self._live = _Batch()   # before the calibration: setting one takes the live batch
        cpm = config.counts_per_m or DEFAULT_COUNTS_PER_M[config.dialect]
        self.calibration = Calibration(cpm, config.signs, (0.0, 0.0))
        self.detector = ReleaseDetector(config.detector)
        self.info: InfoFrame | None = None
        self.reconnects = 0
        self.gaps: deque[GapInterval] = deque(maxlen=MAX_LIVE_GAPS)   # bounded: a day of lost lines
        self.n_channels: int | None = None
        self.last_t_ns: int | None = None
        self.last_raw: tuple[float, ...] | None = None
        self.runs_started = 0
        self.run: _Run | None = None
        self._unit: RawUnit = "m" if config.dialect == "csv" else "counts"
        self._ring: deque[tuple[int, tuple[float, ...], tuple[float, float] | None]] = deque()
        self._drive = DriveSwitches()
        # a release is known up to first_release_confirm_s after its trigger (see daq.detector)
        self._ring_ns = int((config.detector.pre_trigger_s + config.detector.first_release_confirm_s + 1.0) * 1e9)
        self._live_seq = 0
        self._batch_start_ns = 0
        self._disconnected_at: int | None = None
        self.state: DetectorState = "idle"
        # UTC ns minus device ns, fixed at the stream's first sample (host clock then): file
        # log times are t_ns + utc_offset_ns, so viewers put runs on the real time axis
        self.utc_offset_ns: int | None = None

    # --- link events ------------------------------------------------------------------------------
    def data(self, chunk: bytes) -> None:
        for frame in self.decoder.feed(chunk):
            if isinstance(frame, DataFrame):
                self._sample(frame)
            else:
                self._info(frame)

    def disconnected(self) -> None:
        self._flush_batches()
        self._disconnected_at = self.last_t_ns

    def reconnected(self) -> None:
        self.reconnects += 1

    def finish(self, reason: str) -> None:
        """End of stream or shutdown: a release the detector confirmed but had not dated yet
        starts its run (`ReleaseDetector.finish`); send what is batched, close an open run as
        aborted."""
        if self.run is None and self.last_t_ns is not None:
            self._events(self.detector.finish(), self.last_t_ns)
        self._flush_batches()
        if self.run is not None:
            self._end_run("aborted", reason)

    def flush(self) -> None:
        """Send the batched samples now (the loop calls it when the port is quiet)."""
        self._flush_batches()

    # --- commands -----------------------------------------------------------------------------------
    def zero_now(self) -> tuple[float, ...] | None:
        """Zero the live positions at the last sample; None before the first sample."""
        if self.last_raw is None:
            return None
        self.calibration = self.calibration.zeroed_at(self.last_raw)
        return self.calibration.zero_offsets_raw

    def arm_now(self) -> bool:
        """Arm the detector at the current position (no stillness wait); False if not possible."""
        if self.last_raw is None or self.last_t_ns is None or self.run is not None:
            return False
        pos = self.calibration.unzeroed_metres(self.last_raw)
        self._events(self.detector.arm_now(self.last_t_ns / 1e9, pos), self.last_t_ns)
        return True

    # --- samples -------------------------------------------------------------------------------------
    def _info(self, frame: InfoFrame) -> None:
        self.info = frame
        if self.config.counts_per_m is None and frame.counts_per_m > 0:
            self.calibration = self.calibration.with_counts_per_m(frame.counts_per_m)

    @property
    def calibration(self) -> Calibration:
        return self._calibration

    @calibration.setter
    def calibration(self, value: Calibration) -> None:
        if self._live.t_ns:   # the batched samples keep the calibration they were taken under
            self._flush_live()
        self._calibration = value
        self._gains, self._offsets_m = value.linear_terms()

    def _sample(self, frame: DataFrame) -> None:
        step = self.timeline.push(frame.seq, frame.t_us)
        if step.duplicate:
            return
        raw = frame.raw
        if self.n_channels is None:
            self.n_channels = min(2, len(raw))
            self.calibration = self.calibration.with_channels(self.n_channels)
        if len(raw) != self.n_channels:
            raw = ((*tuple(raw), 0.0, 0.0))[: self.n_channels]
        t_ns = step.t_ns
        if self.utc_offset_ns is None:
            self.utc_offset_ns = _utc_ns(self._wall_clock()) - t_ns
        if step.lost or self._disconnected_at is not None or step.anomaly:
            self._gap(t_ns, step.lost, step.anomaly)
        self.last_t_ns, self.last_raw = t_ns, raw
        drive = frame.drive
        self._drive.push(t_ns, drive)
        ring = self._ring
        ring.append((t_ns, raw, drive))
        while ring[0][0] < t_ns - self._ring_ns:
            ring.popleft()
        g = self._gains
        live = self._live
        if not live.t_ns:
            self._batch_start_ns = t_ns
        live.add(t_ns, raw, drive)
        if len(raw) == 2:
            unzeroed: tuple[float, ...] = (raw[0] * g[0], raw[1] * g[1])
        else:
            unzeroed = (raw[0] * g[0],)
        run = self.run
        if run is not None:
            run.batch.add(t_ns, raw, drive)
        events = self.detector.feed(t_ns * 1e-9, unzeroed)
        if events:
            self._events(events, t_ns)
        if t_ns - self._batch_start_ns >= BATCH_NS or len(live.t_ns) >= MAX_BATCH:
            self._flush_batches()

    def _gap(self, t_ns: int, lost: int, anomaly: str | None) -> None:
        start = self._disconnected_at if self._disconnected_at is not None else (self.last_t_ns or t_ns)
        reason: GapReason = "disconnect" if self._disconnected_at is not None else (
            "clock_jump" if anomaly else "seq_gap")
        gap = GapInterval(start_t_ns=start, end_t_ns=t_ns, reason=reason, lost_frames=lost or None)
        self.gaps.append(gap)
        if self.run is not None:
            self.run.gaps.append(gap)
        self._disconnected_at = None
        if self.run is not None:   # the run goes on; only its ringing is judged afresh after the hole
            self.detector.forget_turns()
            return
        if reason == "seq_gap":   # lost lines: the detector judges whether the hole can hide a move
            self._events(self.detector.hole((t_ns - start) * 1e-9), t_ns)
        else:                     # unplugged, or the device clock is not to be trusted
            self._events(self.detector.reset(), t_ns)

    # --- detector events ---------------------------------------------------------------------------
    def _events(self, events: list[Event], t_ns: int) -> None:
        for event in events:
            if isinstance(event, Armed):
                if self.config.auto_zero:   # the carts held still read 0 (a swinging one keeps its zero)
                    raw = self.calibration.raw_of_unzeroed(event.hold_pos)
                    zeros = self.calibration.zero_offsets_raw
                    self.calibration = self.calibration.zeroed_at(
                        [r if event.watched is None or c in event.watched else z
                         for c, (r, z) in enumerate(zip(raw, zeros, strict=True))])
                self._set_state("armed", t_ns)
            elif isinstance(event, Released):
                self._set_state("released", self._start_run(event))
            elif isinstance(event, Settled):
                self._set_state("settled", t_ns)
                if self.run is not None:
                    self._end_run("complete", f"settled ({event.reason})")
            elif isinstance(event, Rejected | Disarmed):
                if isinstance(event, Rejected):   # shown at -v: why handling made no run
                    log.debug("candidate at %.3f s turned down: %s", event.t_s, event.reason)
                    switch = self._drive.recent(round(event.t_s * 1e9))
                    if switch is not None:   # the drive moved the carts, whatever a hand's rules say
                        log.debug("... but the drive switched at %.3f s", switch / 1e9)
                        self._events(self.detector.drive_release(switch / 1e9), t_ns)
                        continue
                self._set_state("idle", t_ns)
        if self.detector.state == "idle" and self.state == "settled":
            self._set_state("idle", t_ns)

    def _set_state(self, state: DetectorState, t_ns: int) -> None:
        if state == self.state:
            return
        self.state = state
        run_id = self.run.metadata.run_id if self.run is not None else None
        msg = DetectorStateMsg(bench=self.config.bench, state=state, t_ns=t_ns, run_id=run_id)
        self.outputs.state(msg)

    # --- runs ------------------------------------------------------------------------------------------
    def counters(self) -> DaqCounters:
        """Totals since start-up; `gap_intervals` only the last `MAX_LIVE_GAPS` (a run keeps all its own)."""
        d, tl = self.decoder.counters, self.timeline.counters
        return DaqCounters(lines=d.lines, frames=d.frames, bad_lines=d.rejected, bad_checksum=d.bad_checksum,
                           torn=d.torn, non_ascii=d.non_ascii, overlong=d.overlong, malformed=d.malformed,
                           seq_gaps=tl.seq_gaps, lost_frames=tl.lost_lines, clock_wraps=tl.clock_wraps,
                           reconnects=self.reconnects, gap_intervals=list(self.gaps))

    def _start_run(self, event: Released) -> int:
        """Open the run of `event`; its release instant (device ns)."""
        self._flush_batches()
        # the drive moved the carts: a step response, from the first sample of a new drive
        driven, release_ns = self._drive.at_release(round(event.t_release_s * 1e9))
        if driven:
            log.debug("release at %.3f s is the drive's (dated %.3f s)", event.t_release_s, release_ns / 1e9)
        first_ns = release_ns - int(self.config.detector.pre_trigger_s * 1e9)
        ring = list(self._ring)
        start = next((i for i, (t, _, _) in enumerate(ring) if t >= first_ns), len(ring))
        pre = ring[max(0, start - 1):]   # one sample more, so at least pre_trigger_s precede the release
        first_t = pre[0][0] if pre else release_ns
        now = self._wall_clock()
        run_id = new_run_id(self.config.bench, now, self._run_id_taken)
        self.runs_started += 1
        cal = self.calibration
        info = self.info
        meta = RunMetadata(
            bench=self.config.bench, run_id=run_id, dialect=self.config.dialect, port=self.config.port,
            counts_per_m=cal.counts_per_m, signs=list(cal.signs), zero_offsets_raw=list(cal.zero_offsets_raw),
            n_channels=cal.n_channels, rate_hz=info.rate_hz if info else None,
            device_model=info.model if info else None, firmware=info.firmware if info else None,
            detector_settings=self.config.detector.as_metadata(), detector_method=METHOD,
            release_time_s=(release_ns - first_t) / 1e9, release_t_ns=release_ns, first_t_ns=first_t,
            pre_trigger_s=self.config.detector.pre_trigger_s, pulled_cart=event.channel + 1,
            lab_case=self.config.lab_case, trigger="drive" if driven else "hand", counters=self.counters(),
            software_version=daq.__version__,
            started_utc=now.isoformat(timespec="milliseconds"), utc_offset_ns=self.utc_offset_ns)
        gains, offsets_m = cal.linear_terms()
        self.run = _Run(meta, cal, self.counters(), gains=gains, offsets_m=offsets_m)
        self.outputs.run_started(meta)
        for t, raw, drive in pre:
            self.run.batch.add(t, raw, drive)
        return release_ns

    def _end_run(self, status: str, reason: str) -> None:
        run = self.run
        assert run is not None
        self._flush_run(run)
        counters = _delta(self.counters(), run.counters_at_start, run.gaps)
        pulled, ratio = run.metadata.pulled_cart, self.config.detector.held_ratio
        spans, swings = self.detector.run_spans_m(), self.detector.run_swings_m()
        meta = run.metadata.model_copy(update={
            "counters": counters, "ended_utc": self._wall_clock().isoformat(timespec="milliseconds"),
            "lab_case": self.config.lab_case or (lab_case(pulled, spans, ratio, swings) if spans else None),
            "moving_carts": moving_carts(pulled, spans, ratio, swings) if spans else None})
        finished = RunFinished(
            bench=meta.bench, run_id=meta.run_id, status="complete" if status == "complete" else "aborted",
            file=f"{meta.run_id}.mcap", n_samples=run.n_samples, release_time_s=meta.release_time_s,
            duration_s=(run.last_t_ns - meta.first_t_ns) / 1e9 if run.n_samples else 0.0,
            counters=counters, reason=reason)
        self.run = None
        self.outputs.run_finished(meta, finished)

    def _flush_batches(self) -> None:
        if self._live.t_ns:
            self._flush_live()
        if self.run is not None:
            self._flush_run(self.run)

    def _flush_live(self) -> None:
        n_channels = self.n_channels or 1
        run_id = self.run.metadata.run_id if self.run is not None else None
        batch = self._live.take(self.config.bench, run_id, self._live_seq, self._unit,
                                self._gains[:n_channels], self._offsets_m[:n_channels])
        self._live_seq += 1
        self.outputs.live(batch)

    def _flush_run(self, run: _Run) -> None:
        if not run.batch.t_ns:
            return
        n_channels = run.calibration.n_channels
        batch = run.batch.take(self.config.bench, run.metadata.run_id, run.batch_seq, self._unit,
                               run.gains[:n_channels], run.offsets_m[:n_channels])
        run.batch_seq += 1
        run.n_samples += len(batch.t_ns)
        run.last_t_ns = batch.t_ns[-1]
        self.outputs.run_samples(batch)


def _utc_ns(moment: datetime) -> int:
    """Integer UTC nanoseconds of an aware datetime (exact: no float seconds in between)."""
    if moment.tzinfo is None:   # a naive wall clock is taken as UTC
        moment = moment.replace(tzinfo=UTC)
    delta = moment - datetime(1970, 1, 1, tzinfo=UTC)
    return (delta.days * 86_400 + delta.seconds) * 1_000_000_000 + delta.microseconds * 1000


def _delta(now: DaqCounters, start: DaqCounters, gaps: list[GapInterval]) -> DaqCounters:
    """Counters accumulated since `start`, with the run's own gap intervals `gaps`."""
    fields = {name: getattr(now, name) - getattr(start, name)
              for name, info in DaqCounters.model_fields.items()
              if info.annotation is int and name != "schema_version"}
    return now.model_copy(update={**fields, "gap_intervals": gaps})


__all__ = ["Acquisition", "AcquisitionConfig", "Outputs"]
