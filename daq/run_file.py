"""Reading run files (finished or salvaged): records, arrays, metadata, exports.

One reader for both cases: `mcap`'s `StreamReader` walks the file record by record, so a
file killed mid-write (no summary, no footer, an unfinished chunk) yields every complete
chunk and stops at the first unreadable record (`complete` is then False).

Time base of exports: `time_s = (t_ns - t_ns[0]) / 1e9`, the device clock (unwrapped) in
seconds from the run's first sample; `release_time_s` is on that same base.
"""

from __future__ import annotations

import csv
import io
import json
import struct
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import zstandard
from mcap.exceptions import EndOfFile, McapError
from mcap.records import Channel, Message, Metadata, Schema
from mcap.stream_reader import StreamReader

from daq.errors import DaqIOError, DaqValueError
from schemas import SchemaError, topics
from schemas.daq import DetectorStateMsg, RunFinished, RunMetadata, SampleBatch

#: What a truncated stream may raise at the cut (besides mcap's own errors).
_TRUNCATION_ERRORS = (McapError, EndOfFile, EOFError, ValueError, struct.error, zstandard.ZstdError)


@dataclass
class RawRun:
    """Every readable record of one file, in file order."""

    schemas: list[Schema] = field(default_factory=list)
    channels: list[Channel] = field(default_factory=list)
    messages: list[Message] = field(default_factory=list)
    metadata: list[Metadata] = field(default_factory=list)
    complete: bool = False
    stop_reason: str | None = None


@dataclass(frozen=True)
class RunData:
    """A run as arrays: `t_ns` (N,) int64 device time; `pos_m`, `raw` (N, n_channels)."""

    t_ns: npt.NDArray[np.int64]
    pos_m: npt.NDArray[np.float64]
    raw: npt.NDArray[np.float64]
    metadata: RunMetadata | None
    finished: RunFinished | None
    states: list[DetectorStateMsg]
    complete: bool

    @property
    def time_s(self) -> npt.NDArray[np.float64]:
        """Seconds from the run's first sample (shape (N,))."""
        if self.t_ns.size == 0:
            return np.zeros(0)
        return (self.t_ns - self.t_ns[0]).astype(np.float64) / 1e9

    @property
    def release_time_s(self) -> float | None:
        """The release on the `time_s` base (from the metadata's device-time release)."""
        meta = self.metadata
        if meta is None or meta.release_t_ns is None or self.t_ns.size == 0:
            return meta.release_time_s if meta is not None else None
        return (meta.release_t_ns - int(self.t_ns[0])) / 1e9

    @property
    def n_channels(self) -> int:
        return int(self.pos_m.shape[1])


def read_raw(path: Path) -> RawRun:
    """All complete records of `path`; stops quietly at a truncation."""
    run = RawRun()
    try:
        with open(path, "rb") as stream:
            for record in _records(stream, run):
                if isinstance(record, Message):
                    run.messages.append(record)
                elif isinstance(record, Channel):
                    run.channels.append(record)
                elif isinstance(record, Schema):
                    run.schemas.append(record)
                elif isinstance(record, Metadata):
                    run.metadata.append(record)
    except OSError as exc:
        raise DaqIOError(f"cannot read run file {path}: {exc}") from exc
    return run


def _records(stream: io.BufferedReader, run: RawRun) -> Iterator[object]:
    reader = StreamReader(stream, skip_magic=False, emit_chunks=False)
    try:
        for record in reader.records:
            yield record
        run.complete = True
    except _TRUNCATION_ERRORS as exc:
        run.stop_reason = f"{type(exc).__name__}: {exc}"


def last_metadata(raw: RawRun, name: str) -> dict[str, str] | None:
    found = [m.metadata for m in raw.metadata if m.name == name]
    return found[-1] if found else None


def parse_metadata(raw: RawRun) -> tuple[RunMetadata | None, RunFinished | None]:
    # the final record, else (a crashed .part) the one written when the run opened
    meta_map = last_metadata(raw, topics.METADATA_RUN) or last_metadata(raw, topics.METADATA_RUN_STARTED)
    done_map = last_metadata(raw, topics.METADATA_FINISHED)
    meta = RunMetadata.from_json_bytes(meta_map[topics.METADATA_JSON_KEY]) if meta_map else None
    done = RunFinished.from_json_bytes(done_map[topics.METADATA_JSON_KEY]) if done_map else None
    return meta, done


def load_run(path: Path) -> RunData:
    """A run file (finished or truncated) as arrays and records."""
    raw = read_raw(Path(path))
    if not raw.messages and not raw.metadata:
        raise DaqValueError(f"run file {path}", "an MCAP file written by daq", "no readable records")
    topic_of = {c.id: c.topic for c in raw.channels}
    batches: list[SampleBatch] = []
    states: list[DetectorStateMsg] = []
    try:
        for message in raw.messages:
            topic = topic_of.get(message.channel_id)
            if topic == topics.SAMPLES:
                batches.append(SampleBatch.from_json_bytes(message.data))
            elif topic == topics.STATE:
                states.append(DetectorStateMsg.from_json_bytes(message.data))
        meta, done = parse_metadata(raw)
    except SchemaError as exc:
        raise DaqValueError(f"run file {path}", "records of the cartlab schemas", str(exc)) from exc
    batches.sort(key=lambda b: b.t_ns[0] if b.t_ns else 0)
    t_ns, pos_m, raw_values = _stack(batches, meta)
    return RunData(t_ns, pos_m, raw_values, meta, done, states, raw.complete)


def _stack(batches: list[SampleBatch], meta: RunMetadata | None
           ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    n_channels = meta.n_channels if meta is not None else (
        2 if batches and batches[0].pos2_m is not None else 1)
    t_ns = np.array([t for b in batches for t in b.t_ns], dtype=np.int64)
    pos = np.zeros((t_ns.size, n_channels))
    raw = np.zeros((t_ns.size, n_channels))
    pos[:, 0] = [x for b in batches for x in b.pos1_m]
    raw[:, 0] = [x for b in batches for x in b.raw1]
    if n_channels == 2:
        pos[:, 1] = [x for b in batches for x in (b.pos2_m or [])]
        raw[:, 1] = [x for b in batches for x in (b.raw2 or [])]
    return t_ns, pos, raw


def run_info(run: RunData, path: Path) -> dict[str, Any]:
    """A JSON-able summary: metadata, counters, sample count, time span, release time."""
    meta = run.metadata
    time_s = run.time_s
    return {
        "file": Path(path).name,
        "complete": run.complete,
        "n_samples": int(run.t_ns.size),
        "n_channels": run.n_channels,
        "duration_s": float(time_s[-1]) if time_s.size else 0.0,
        "release_time_s": run.release_time_s,
        "status": run.finished.status if run.finished else None,
        "metadata": meta.model_dump(mode="json") if meta else None,
    }


def export_csv(run: RunData) -> str:
    """`time_s,pos1_m[,pos2_m]` with full float precision."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["time_s", "pos1_m", "pos2_m"][: 1 + run.n_channels])
    for t, row in zip(run.time_s.tolist(), run.pos_m.tolist()):
        writer.writerow([repr(t)] + [repr(x) for x in row])
    return out.getvalue()


def export_json(run: RunData, path: Path) -> str:
    body = run_info(run, path)
    body["time_s"] = run.time_s.tolist()
    body["pos1_m"] = run.pos_m[:, 0].tolist()
    if run.n_channels == 2:
        body["pos2_m"] = run.pos_m[:, 1].tolist()
    return json.dumps(body)


def export_mat(run: RunData, out_path: Path) -> None:
    """MATLAB file with `time_s`, `pos1_m`[, `pos2_m`], `release_time_s` (NaN if unknown)."""
    from scipy.io import savemat  # lazy: scipy costs seconds to import

    release = run.release_time_s
    data: dict[str, Any] = {
        "time_s": run.time_s[:, None],
        "pos1_m": run.pos_m[:, :1],
        "release_time_s": float("nan") if release is None else release,
    }
    if run.n_channels == 2:
        data["pos2_m"] = run.pos_m[:, 1:2]
    savemat(str(out_path), data)
