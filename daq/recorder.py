"""Crash-safe MCAP run files: write `<run_id>.mcap.part`, finish, fsync, rename; recover.

Crash bound: a killed writer loses the open chunk and the Python file buffer. `RunWriter`
closes the chunk (`Writer.flush()`) and flushes the file at least every `flush_interval_s`
(the caller passes the time in, from its own clock), so at most that much is lost. The header,
schemas, channels and the `RunMetadata` known at the start (`cartlab.run_started`) are
flushed at open, so even an early kill leaves a file that recovery understands; `finish`
adds the final `cartlab.run` and `cartlab.run_finished`: one metadata record per name.

Time: message log/publish times are UTC ns, `t_ns + utc_offset_ns` (the offset fixed at the
stream's start, in the metadata), so viewers place runs on the real time axis; the device
clock stays in every message. Each sample is also written as its own `PositionSample` on
`/position`, because a viewer's time-series plot (Foxglove's Plot panel) draws one point per
message: a batch message would show as one point per 20 ms.

Recovery reads a `.part` with `schemas.run_file`'s reader (every complete chunk), rewrites the
records into a new finished file (`<run_id>.mcap`, or `<run_id>-r<k>.mcap` when that name is
taken: a finished run is never overwritten), adds the final metadata with status `recovered`,
fsyncs, links it into place (no replace), then removes the `.part`. A part nothing can be read
from is moved to `quarantine/`, never deleted; a directory or a symlink named `*.mcap.part` is
skipped with a warning.
"""

from __future__ import annotations

import contextlib
import logging
import os
from collections.abc import Callable
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import BinaryIO, Literal

from mcap.records import Channel, Message, Metadata, Schema
from mcap.well_known import MessageEncoding, SchemaEncoding
from mcap.writer import CompressionType, Writer

import daq
from daq.errors import DaqIOError
from schemas import Record, SchemaError, run_file, topics
from schemas.daq import (
    DetectorStateMsg,
    PositionSample,
    RunFinished,
    RunMetadata,
    SampleBatch,
)

log = logging.getLogger(__name__)
CHUNK_SIZE = 32 * 1024
LIBRARY = f"cartlab-daq/{daq.__version__}"


def utc_now_iso() -> str:
    return datetime.now(UTC).isoformat(timespec="milliseconds")


part_path = run_file.part_path
final_path = run_file.final_path


def _metadata_map(record: Record) -> dict[str, str]:
    """The record's JSON under `json`, plus flat scalar fields for viewers' metadata panels."""
    flat = {k: str(v) for k, v in record.model_dump(mode="json").items()
            if isinstance(v, str | int | float | bool) or v is None}
    flat[topics.METADATA_JSON_KEY] = record.model_dump_json()
    return flat


def utc_offset_ns(metadata: RunMetadata) -> int:
    """UTC ns minus device ns for this run: the stream's offset, else (older callers) the one
    implied by `started_utc` at the release (good to the detector's confirmation delay)."""
    if metadata.utc_offset_ns is not None:
        return metadata.utc_offset_ns
    started = datetime.fromisoformat(metadata.started_utc)
    started = started if started.tzinfo else started.replace(tzinfo=UTC)
    started_ns = round(started.timestamp() * 1e6) * 1000
    return started_ns - (metadata.release_t_ns if metadata.release_t_ns is not None else metadata.first_t_ns)


def position_json(t_ns: int, pos1_m: float, pos2_m: float | None) -> bytes:
    """A `PositionSample` as JSON, built directly: one per sample, so pydantic's per-object cost
    would dominate the recorder (tests validate these bytes against the model)."""
    second = "null" if pos2_m is None else repr(float(pos2_m))
    return (f'{{"schema_version":{PositionSample.SCHEMA_VERSION},"t_ns":{int(t_ns)},'
            f'"pos1_m":{float(pos1_m)!r},"pos2_m":{second}}}').encode()


class RunWriter:
    """One open run file. Not thread-safe: owned by the service loop."""

    def __init__(self, runs_dir: Path, metadata: RunMetadata, now_s: float,
                 flush_interval_s: float = 0.25,
                 opener: Callable[[Path], BinaryIO] | None = None) -> None:
        self.runs_dir = Path(runs_dir)
        self.run_id = metadata.run_id
        self.metadata = metadata
        self.flush_count = 0
        self.path = part_path(self.runs_dir, self.run_id)
        self.flush_interval_s = flush_interval_s
        self.n_samples = 0
        self.first_t_ns: int | None = None
        self.last_t_ns: int | None = None
        try:
            self.runs_dir.mkdir(parents=True, exist_ok=True)
            self._file: BinaryIO = (opener or open_exclusive)(self.path)
        except OSError as exc:
            raise DaqIOError(f"cannot create run file {self.path}: {exc}") from exc
        try:
            self._start(metadata, now_s)
        except BaseException:
            self._file.close()   # a file that could not be started (a full disk) is not kept open
            raise

    def _start(self, metadata: RunMetadata, now_s: float) -> None:
        self._writer = Writer(self._file, chunk_size=CHUNK_SIZE, compression=CompressionType.ZSTD)
        self._writer.start(profile=topics.MCAP_PROFILE, library=LIBRARY)
        self._samples_channel = self._channel(topics.SAMPLES, SampleBatch)
        self._position_channel = self._channel(topics.POSITION, PositionSample)
        self._state_channel = self._channel(topics.STATE, DetectorStateMsg)
        self._writer.add_metadata(topics.METADATA_RUN_STARTED, _metadata_map(metadata))
        self.utc_offset_ns = utc_offset_ns(metadata)
        self._batch_seq = 0
        self._position_seq = 0
        self._last_flush_s = now_s
        self.flush(now_s)

    def _channel(self, topic: str, model: type[Record]) -> int:
        schema_id = self._writer.register_schema(name=model.schema_name(), encoding=SchemaEncoding.JSONSchema,
                                                 data=model.json_schema_bytes())
        return self._writer.register_channel(topic=topic, message_encoding=MessageEncoding.JSON,
                                             schema_id=schema_id)

    def _utc(self, t_ns: int) -> int:
        return max(0, t_ns + self.utc_offset_ns)

    def write_samples(self, batch: SampleBatch, now_s: float) -> None:
        """Append a batch (log time = its first sample's UTC time) and each of its samples on
        `/position` (log time = the sample's UTC time)."""
        if not batch.t_ns:
            return
        stamp = self._utc(batch.t_ns[0])
        self._writer.add_message(channel_id=self._samples_channel, log_time=stamp, publish_time=stamp,
                                 sequence=self._batch_seq, data=batch.to_json_bytes())
        self._batch_seq += 1
        second = batch.pos2_m if batch.pos2_m is not None else [None] * len(batch.t_ns)
        add, channel, seq = self._writer.add_message, self._position_channel, self._position_seq
        for t, p1, p2 in zip(batch.t_ns, batch.pos1_m, second, strict=True):
            utc = self._utc(t)
            add(channel_id=channel, log_time=utc, publish_time=utc, sequence=seq, data=position_json(t, p1, p2))
            seq += 1
        self._position_seq = seq
        self.n_samples += len(batch.t_ns)
        if self.first_t_ns is None:
            self.first_t_ns = batch.t_ns[0]
        self.last_t_ns = batch.t_ns[-1]
        self.maybe_flush(now_s)

    def write_state(self, msg: DetectorStateMsg, now_s: float) -> None:
        stamp = self._utc(msg.t_ns)
        self._writer.add_message(channel_id=self._state_channel, log_time=stamp, publish_time=stamp,
                                 sequence=0, data=msg.to_json_bytes())
        self.maybe_flush(now_s)

    @property
    def next_batch_seq(self) -> int:
        return self._batch_seq

    def maybe_flush(self, now_s: float) -> None:
        if now_s - self._last_flush_s >= self.flush_interval_s:
            self.flush(now_s)

    def flush(self, now_s: float) -> None:
        """Close the open chunk and push it to the OS (no fsync: that is for `finish`)."""
        self._writer.flush()
        self._file.flush()
        self._last_flush_s = now_s
        self.flush_count += 1

    def finish(self, metadata: RunMetadata, finished: RunFinished) -> Path:
        """Write the final metadata, close the file, fsync it, rename `.part` → `.mcap`."""
        self._writer.add_metadata(topics.METADATA_RUN, _metadata_map(metadata))
        self._writer.add_metadata(topics.METADATA_FINISHED, _metadata_map(finished))
        self._writer.finish()
        return _seal(self._file, self.path, final_path(self.runs_dir, self.run_id))

    def abandon(self) -> None:
        """Close without finishing (the `.part` stays for recovery)."""
        try:
            self._writer.flush()
        finally:
            self._file.close()

    def abandon_quietly(self) -> None:
        """Close after a write failed (a full disk): what cannot be flushed is lost, the `.part`
        keeps everything flushed before; never raises."""
        try:
            self.abandon()
        except OSError:
            with contextlib.suppress(OSError):   # the descriptor is released even if the flush fails
                self._file.close()


def open_exclusive(path: Path) -> BinaryIO:
    """A new file for writing (never an existing one: a finished run is never overwritten)."""
    return open(path, "xb")


def _seal(stream: BinaryIO, written: Path, target: Path) -> Path:
    try:
        stream.flush()
        os.fsync(stream.fileno())
        stream.close()
        os.replace(written, target)
        _fsync_dir(target.parent)
    except OSError as exc:
        raise DaqIOError(f"cannot finish run file {target}: {exc}") from exc
    return target


def _fsync_dir(directory: Path) -> None:
    fd = os.open(directory, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


# --- recovery ---------------------------------------------------------------------------------

@dataclass(frozen=True)
class Recovery:
    """What became of one `.part`: recovered into `finished.file`, quarantined, or skipped."""

    part: Path
    outcome: Literal["recovered", "quarantined", "skipped"]
    detail: str
    finished: RunFinished | None = None
    last_t_ns: int | None = None   # the last sample recovered (device ns), None when none


def recover_part(path: Path) -> RunFinished:
    """Rewrite a crashed `<run_id>.mcap.part` as a finished run (status recovered), under a new
    name: `<run_id>.mcap` if free, else `<run_id>-r<k>.mcap`. Never over a finished file.

    Raises `DaqIOError` for a path that is not a regular `.part` file, and after moving a part
    nothing could be read from to `quarantine/`.
    """
    done = recover_one(Path(path))
    if done.finished is None:
        raise DaqIOError(f"cannot recover {path}: {done.detail}")
    return done.finished


def recover_one(path: Path) -> Recovery:
    """Recover one `.part` (see `recover_part`); odd entries are skipped, never raised on."""
    if not path.name.endswith(topics.PART_SUFFIX):
        raise DaqIOError(f"not a partial run file (expected *{topics.PART_SUFFIX}): {path}")
    if path.is_symlink() or not path.is_file():
        return Recovery(path, "skipped", "not a regular file (a directory, a symlink or gone): left as is")
    runs_dir = path.parent
    try:
        return _recover_readable(path, runs_dir)
    except (SchemaError, OSError) as exc:
        return _quarantine(path, runs_dir, f"{type(exc).__name__}: {exc}")


def _recover_readable(path: Path, runs_dir: Path) -> Recovery:
    probe = run_file.ReadOutcome()
    found: dict[str, Metadata] = {}
    for record in run_file.iter_records(path, probe, messages=False):
        if isinstance(record, Metadata):
            found[record.name] = record
    meta = run_file.run_metadata(found)
    if meta is None:
        return _quarantine(path, runs_dir, "no run metadata readable"
                           + (f" ({probe.stop_reason})" if probe.stop_reason else ""))
    run_id = run_file.recovered_run_id(runs_dir, run_file.run_id_of(path))
    temp = runs_dir / f"{run_id}{run_file.RECOVERING_SUFFIX}"
    with open(temp, "wb") as stream:
        finished, last_t_ns = _rewrite(path, meta, run_id, stream)
        stream.flush()
        os.fsync(stream.fileno())
    target = run_file.final_path(runs_dir, run_id)
    try:
        os.link(temp, target)   # fails if the name was taken meanwhile: never replaces a file
    finally:
        temp.unlink(missing_ok=True)
    path.unlink()
    _fsync_dir(runs_dir)
    return Recovery(path, "recovered", f"{finished.n_samples} samples into {target.name}", finished, last_t_ns)


def _quarantine(path: Path, runs_dir: Path, reason: str) -> Recovery:
    """Move an unreadable part aside (never delete it): `quarantine/<name>`."""
    dest = run_file.quarantine_path(runs_dir, path.name)
    dest.parent.mkdir(exist_ok=True)
    os.rename(path, dest)
    _fsync_dir(runs_dir)
    log.warning("%s: nothing recoverable (%s); moved to %s", path.name, reason,
                dest.relative_to(runs_dir))
    return Recovery(path, "quarantined", f"{reason}; moved to {dest.relative_to(runs_dir)}")


def _rewrite(path: Path, meta: RunMetadata, run_id: str, stream: BinaryIO) -> tuple[RunFinished, int | None]:
    """Copy every readable record of `path` into a new file, record by record (bounded memory);
    returns its finished record and its last sample's time (ns)."""
    writer = Writer(stream, chunk_size=CHUNK_SIZE, compression=CompressionType.ZSTD)
    writer.start(profile=topics.MCAP_PROFILE, library=LIBRARY)
    schema_ids: dict[int, int] = {}
    channel_ids: dict[int, int] = {}
    samples_channels: set[int] = set()
    n_samples, first_t, last_t = 0, None, None
    outcome = run_file.ReadOutcome()
    for record in run_file.iter_records(path, outcome):
        if isinstance(record, Schema):
            schema_ids[record.id] = writer.register_schema(record.name, record.encoding, record.data)
        elif isinstance(record, Channel):
            channel_ids[record.id] = writer.register_channel(
                record.topic, record.message_encoding, schema_ids.get(record.schema_id, 0),
                dict(record.metadata))
            if record.topic == topics.SAMPLES:
                samples_channels.add(record.id)
        elif isinstance(record, Message) and record.channel_id in channel_ids:
            if record.channel_id in samples_channels:
                try:
                    batch = SampleBatch.from_json_bytes(record.data)
                except SchemaError:
                    continue   # a damaged batch is not copied: every recovered one parses
                n_samples += len(batch.t_ns)
                if batch.t_ns:
                    first_t = batch.t_ns[0] if first_t is None else min(first_t, batch.t_ns[0])
                    last_t = batch.t_ns[-1] if last_t is None else max(last_t, batch.t_ns[-1])
            writer.add_message(channel_ids[record.channel_id], record.log_time, record.data,
                               record.publish_time, record.sequence)
    reason = f"recovered after a crash: {outcome.stop_reason or 'file ended early'}"
    original = run_file.run_id_of(path)
    if run_id != original:
        reason += f" (from {path.name}; {original}{topics.RUN_SUFFIX} was already finished)"
    finished = RunFinished(
        bench=meta.bench, run_id=run_id, status="recovered",
        file=run_file.run_file_name(run_id), n_samples=n_samples,
        release_time_s=meta.release_time_s,
        duration_s=((last_t - first_t) / 1e9) if first_t is not None and last_t is not None else 0.0,
        counters=meta.counters, reason=reason[:500])
    final_meta = meta.model_copy(update={"ended_utc": utc_now_iso(), "run_id": run_id})
    writer.add_metadata(topics.METADATA_RUN, _metadata_map(final_meta))
    writer.add_metadata(topics.METADATA_FINISHED, _metadata_map(finished))
    writer.finish()
    return finished, last_t


def recover_dir(runs_dir: Path) -> list[Recovery]:
    """Recover every `.part` in `runs_dir` (oldest name first); odd entries are skipped with a
    warning, unreadable parts quarantined; a finished run is never touched."""
    done = []
    for path in sorted(Path(runs_dir).glob(f"*{topics.PART_SUFFIX}")):
        result = recover_one(path)
        if result.outcome == "skipped":
            log.warning("%s: %s", path.name, result.detail)
        done.append(result)
    return done


def recover_all(runs_dir: Path) -> list[RunFinished]:
    """The finished records of every `.part` recovered in `runs_dir` (see `recover_dir`)."""
    return [r.finished for r in recover_dir(runs_dir) if r.finished is not None]


def finished_of(path: Path) -> RunFinished | None:
    """The `RunFinished` record of a finished run file, or None."""
    return run_file.read_finished(path)
