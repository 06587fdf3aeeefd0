"""A run file as arrays and records (`read_run`), and its `RunFinished` record alone.

Samples are turned into arrays batch by batch, so memory stays near the arrays' size
(8 bytes per value), well under the file's decompressed JSON.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypeVar

import numpy as np
import numpy.typing as npt
from mcap.reader import SeekingReader
from mcap.records import Channel, Message, Metadata

from schemas import topics
from schemas.daq import DetectorStateMsg, RunFinished, RunMetadata, SampleBatch
from schemas.errors import SchemaError
from schemas.run_file.limits import DAMAGE_ERRORS, DEFAULT_LIMITS, Limits, RunFileTooLarge
from schemas.run_file.records import ReadOutcome, iter_records


@dataclass(frozen=True)
class RunContents:
    """A run file read: `t_ns` (N,) int64 device time; `pos_m`, `raw` (N, n_channels).

    `metadata` is the final `cartlab.run` record (else `cartlab.run_started`), `finished` the
    `cartlab.run_finished` one;
    `complete` is False for a truncated or damaged file (`stop_reason` says where).
    """

    t_ns: npt.NDArray[np.int64]
    pos_m: npt.NDArray[np.float64]
    raw: npt.NDArray[np.float64]
    metadata: RunMetadata | None
    finished: RunFinished | None
    states: list[DetectorStateMsg]
    complete: bool
    stop_reason: str | None = None
    n_records: int = 0


@dataclass
class _Columns:
    """Per-batch arrays gathered while reading (joined once at the end)."""

    t_ns: list[npt.NDArray[np.int64]] = field(default_factory=list)
    pos: list[npt.NDArray[np.float64]] = field(default_factory=list)
    raw: list[npt.NDArray[np.float64]] = field(default_factory=list)
    n_samples: int = 0
    two_channels: bool | None = None

    def add(self, batch: SampleBatch) -> None:
        two = batch.pos2_m is not None
        if self.two_channels is None:
            self.two_channels = two
        if two != self.two_channels:
            raise SchemaError("SampleBatch", f"{2 if self.two_channels else 1} channels in every batch",
                              f"{2 if two else 1} in batch {batch.batch_seq}")
        pos = [batch.pos1_m, batch.pos2_m] if two else [batch.pos1_m]
        raw = [batch.raw1, batch.raw2] if two else [batch.raw1]
        self.t_ns.append(np.asarray(batch.t_ns, dtype=np.int64))
        self.pos.append(np.asarray(pos, dtype=np.float64).T.reshape(len(batch.t_ns), len(pos)))
        self.raw.append(np.asarray(raw, dtype=np.float64).T.reshape(len(batch.t_ns), len(raw)))
        self.n_samples += len(batch.t_ns)


def read_run(path: Path, limits: Limits = DEFAULT_LIMITS) -> RunContents:
    """A run file (finished, truncated or damaged) as arrays and records, batches in time order.

    Raises `RunFileTooLarge` at a limit, `SchemaError` for a record that is not a cartlab
    record, `OSError` when the file cannot be opened. A file with no readable record at all
    gives empty arrays and `complete` False: the caller decides whether that is an error.
    """
    outcome = ReadOutcome()
    columns = _Columns()
    states: list[DetectorStateMsg] = []
    meta: dict[str, Metadata] = {}
    topic_of: dict[int, str] = {}
    n_records = 0
    for record in iter_records(path, outcome, limits):
        n_records += 1
        if isinstance(record, Channel):
            topic_of[record.id] = record.topic
        elif isinstance(record, Message):
            topic = topic_of.get(record.channel_id)
            if topic == topics.SAMPLES:
                columns.add(SampleBatch.from_json_bytes(record.data))
                if columns.n_samples > limits.max_samples:
                    raise RunFileTooLarge(path, "samples", limits.max_samples, columns.n_samples)
            elif topic == topics.STATE:
                states.append(DetectorStateMsg.from_json_bytes(record.data))
        elif isinstance(record, Metadata):
            meta[record.name] = record  # the last record of a name wins
    metadata = run_metadata(meta)
    finished = _metadata(meta, topics.METADATA_FINISHED, RunFinished)
    t_ns, pos, raw = _joined(columns, metadata)
    return RunContents(t_ns, pos, raw, metadata, finished, states, outcome.complete,
                       outcome.stop_reason, n_records)


_R = TypeVar("_R", RunMetadata, RunFinished)


def _metadata(found: dict[str, Metadata], name: str, model: type[_R]) -> _R | None:
    record = found.get(name)
    if record is None:
        return None
    text = record.metadata.get(topics.METADATA_JSON_KEY)
    if text is None:
        raise SchemaError(f"metadata {name!r}", f"a {topics.METADATA_JSON_KEY!r} key", "none")
    return model.from_json_bytes(text)


def run_metadata(found: dict[str, Metadata]) -> RunMetadata | None:
    """The run's `RunMetadata` from its metadata records by name: the final `cartlab.run`,
    else (a crashed `.part`) `cartlab.run_started`, written when the run opened."""
    final = _metadata(found, topics.METADATA_RUN, RunMetadata)
    return final if final is not None else _metadata(found, topics.METADATA_RUN_STARTED, RunMetadata)


def _joined(columns: _Columns, metadata: RunMetadata | None
            ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    n_channels = (2 if columns.two_channels else 1) if columns.two_channels is not None else (
        metadata.n_channels if metadata is not None else 1)
    if not columns.t_ns:
        return np.zeros(0, np.int64), np.zeros((0, n_channels)), np.zeros((0, n_channels))
    # batches in time order (a file keeps them in order; a recovered one may not)
    order = sorted(range(len(columns.t_ns)), key=lambda i: int(columns.t_ns[i][0]) if columns.t_ns[i].size else 0)
    t_ns = np.concatenate([columns.t_ns[i] for i in order])
    pos = np.concatenate([columns.pos[i] for i in order])
    raw = np.concatenate([columns.raw[i] for i in order])
    return t_ns, pos, raw


def read_finished(path: Path, limits: Limits = DEFAULT_LIMITS) -> RunFinished | None:
    """The `RunFinished` record of a run file, or None (none, unreadable, or not a cartlab file).

    Through the summary index when the file has one, else by walking its top-level records
    without opening chunks.
    """
    try:
        with open(path, "rb") as stream:
            if os.fstat(stream.fileno()).st_size > limits.max_file_bytes:
                return None
            reader = SeekingReader(stream, record_size_limit=limits.max_record_bytes)
            for record in reader.iter_metadata():
                if record.name == topics.METADATA_FINISHED:
                    return RunFinished.from_json_bytes(record.metadata.get(topics.METADATA_JSON_KEY, ""))
            return None
    except (OSError, *DAMAGE_ERRORS):
        pass
    return _finished_by_walking(path, limits)


def _finished_by_walking(path: Path, limits: Limits) -> RunFinished | None:
    found: dict[str, Metadata] = {}
    try:
        for record in iter_records(path, ReadOutcome(), limits, messages=False):
            if isinstance(record, Metadata) and record.name == topics.METADATA_FINISHED:
                found[record.name] = record
        return _metadata(found, topics.METADATA_FINISHED, RunFinished)
    except (OSError, SchemaError):
        return None


__all__ = ["RunContents", "read_finished", "read_run", "run_metadata"]
