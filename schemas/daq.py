"""Records of the `daq` service: live samples, detector state, run metadata and run end.

Units are in field names: `t_ns` is the device clock, unwrapped, in integer nanoseconds;
`*_m` are metres in the zeroed frame; `*_s` are float seconds. `release_time_s` is always on
the time base of the run's exported samples: seconds from the run's first sample.

Consumers (`ident`, viewers) read these from Zenoh payloads and from MCAP files; keep field
names stable and bump `SCHEMA_VERSION` on any incompatible change.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from schemas.base import Record
from schemas.keys import BenchName, FileName, RunId

DetectorState = Literal["idle", "armed", "released", "settled"]
RunStatus = Literal["complete", "recovered", "aborted"]
RawUnit = Literal["counts", "m"]
GapReason = Literal["disconnect", "seq_gap", "clock_jump", "disk_full"]
RunTrigger = Literal["hand", "drive"]


class SampleBatch(Record):
    """A batch of consecutive samples (live on Zenoh, one MCAP message per batch).

    `t_ns[i]`, `pos1_m[i]`, `pos2_m[i]`, `raw1[i]`, `raw2[i]` describe sample i; every list
    has the same length. `raw*` are the decoded values before calibration and zeroing, in
    `raw_unit` (encoder counts for the `cartlab` and `ecp` dialects, metres for `csv`).
    `pos2_m`/`raw2` are None for one-channel streams. `run_id` is None outside a run.
    `batch_seq` counts batches per stream (live) or per file (MCAP), from 0. `target[i]`,
    `duty[i]` are the rig's drive command with sample i as the device sent it (the `ecp`
    dialect's fields; in open loop `target` is the duty's target, `4096·V/5`), None for a
    stream without a drive.
    """

    bench: BenchName
    run_id: RunId | None = None
    batch_seq: int = Field(ge=0)
    t_ns: list[int]
    pos1_m: list[float]
    pos2_m: list[float] | None = None
    raw1: list[float]
    raw2: list[float] | None = None
    raw_unit: RawUnit = "counts"
    target: list[float] | None = None
    duty: list[float] | None = None

    @model_validator(mode="after")
    def _same_lengths(self) -> SampleBatch:
        n = len(self.t_ns)
        lengths = [len(self.pos1_m), len(self.raw1)]
        lengths += [len(x) for x in (self.pos2_m, self.raw2, self.target, self.duty) if x is not None]
        if any(length != n for length in lengths):
            raise ValueError(f"expected every list of length {n} (len(t_ns)), got lengths {lengths}")
        if (self.pos2_m is None) != (self.raw2 is None):
            raise ValueError("expected pos2_m and raw2 both present or both None")
        if (self.target is None) != (self.duty is None):
            raise ValueError("expected target and duty both present or both None")
        return self


class PositionSample(Record):
    """One sample, as its own MCAP message on `/position` (viewers plot one point per message).

    `t_ns` is the device clock (unwrapped) like `SampleBatch.t_ns`; the message's log time is
    the same instant in UTC. `pos2_m` is None for one-channel streams.
    """

    t_ns: int
    pos1_m: float
    pos2_m: float | None = None


class DetectorStateMsg(Record):
    """A change of the release detector's state, stamped with the device time of the sample."""

    bench: BenchName
    state: DetectorState
    t_ns: int
    run_id: RunId | None = None


class GapInterval(Record):
    """A stretch of device time with missing samples (port gone, lost lines, clock jump)."""

    start_t_ns: int
    end_t_ns: int
    reason: GapReason
    lost_frames: int | None = None


class DaqCounters(Record):
    """What the link, decoder and timeline saw. Totals since the service (or run) began."""

    lines: int = 0
    frames: int = 0
    bad_lines: int = 0
    bad_checksum: int = 0
    torn: int = 0
    non_ascii: int = 0
    overlong: int = 0
    malformed: int = 0
    seq_gaps: int = 0
    lost_frames: int = 0
    clock_wraps: int = 0
    reconnects: int = 0
    gap_intervals: list[GapInterval] = Field(default_factory=list)


class RunMetadata(Record):
    """Everything needed to interpret a run file, written as an MCAP metadata record.

    Written when the run file is opened (`cartlab.run_started`: counters so far, `ended_utc`
    None) and when it is finished (`cartlab.run`); readers prefer the latter.
    `release_time_s` is on the exported time base (seconds from the run's first sample,
    `first_t_ns`); `release_t_ns` is the same instant on the device clock.
    `zero_offsets_raw` are the raw values subtracted by zeroing and `signs` the per-channel
    sign applied after: `pos_m = sign * (raw - offset) / counts_per_m` (csv: `counts_per_m`
    is 1 and raw is already metres). `utc_offset_ns` ties the device
    clock to UTC, `utc_ns = t_ns + utc_offset_ns`, fixed at the start of the stream from the
    host clock (None in files written before it existed). `lab_case` and `moving_carts` (the
    carts that swung freely, the pulled one first: the ones to fit) come from the carts'
    amplitudes when the run ends: a cart whose span is a small fraction of the pulled cart's
    is held, even though a loose hand lets it wander (None while the run is open).
    `trigger` is "hand" for a hand release and "drive" for a run that began where the rig's
    drive switched (a motor pulse's edge: a step response to the drive, which the samples
    carry as `target`/`duty`; the release time is then the first sample of the new drive).
    """

    bench: BenchName
    run_id: RunId
    dialect: str
    port: str
    counts_per_m: float
    signs: list[int]
    zero_offsets_raw: list[float]
    n_channels: int = Field(ge=1, le=2)
    rate_hz: float | None = None
    device_model: str | None = None
    firmware: str | None = None
    detector_settings: dict[str, float | int | str]
    detector_method: str
    release_time_s: float | None
    release_t_ns: int | None
    first_t_ns: int
    pre_trigger_s: float
    pulled_cart: int | None = None
    lab_case: str | None = None
    moving_carts: list[int] | None = None
    trigger: RunTrigger = "hand"
    counters: DaqCounters = Field(default_factory=DaqCounters)
    software_version: str
    started_utc: str
    ended_utc: str | None = None
    utc_offset_ns: int | None = None


class RunFinished(Record):
    """The run-end record on `cartlab/<bench>/runs/<run_id>/finished` and in the file.

    `file` is relative to the runs directory (`<run_id>.mcap`). `duration_s` spans the first
    to the last sample; `release_time_s` is on the exported time base.
    """

    bench: BenchName
    run_id: RunId
    status: RunStatus
    file: FileName
    n_samples: int = Field(ge=0)
    release_time_s: float | None
    duration_s: float
    counters: DaqCounters = Field(default_factory=DaqCounters)
    reason: str | None = None

    def digest(self) -> str:
        """A short hash of this record (blake2b-64 of its JSON, hex): a fit report carries it,
        so that it counts only for the run the daq recorded (`FitReport.run_digest`)."""
        import hashlib

        return hashlib.blake2b(self.to_json_bytes(), digest_size=8).hexdigest()


class DaqStatus(Record):
    """Reply of the `status` (and `arm`) queryable: a snapshot of the service."""

    bench: BenchName
    state: DetectorState
    run_id: RunId | None
    port: str
    dialect: str
    connected: bool
    counts_per_m: float
    zero_offsets_raw: list[float]
    last_t_ns: int | None
    last_pos_m: list[float] | None
    n_runs: int
    counters: DaqCounters
    software_version: str


class ZeroReply(Record):
    """Reply of the `zero` queryable: the raw offsets now subtracted, or why not."""

    bench: BenchName
    ok: bool
    zero_offsets_raw: list[float]
    message: str = ""


class RunList(Record):
    """Reply of the `runs` queryable: the finished record of every run file, oldest first.

    A worker that starts late (or missed a `finished` put) catches up from this list.
    """

    bench: BenchName
    runs: list[RunFinished]


__all__ = [
    "DaqCounters",
    "DaqStatus",
    "DetectorState",
    "DetectorStateMsg",
    "GapInterval",
    "PositionSample",
    "RunFinished",
    "RunList",
    "RunMetadata",
    "RunStatus",
    "SampleBatch",
    "ZeroReply",
]
