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
    """A run file read: `t_ns` (N,) int64 device time; `pos_m`, `raw` (N, n_channels);
    `drive` (N, 2) the rig's drive as sent (`SampleBatch.target`, `.duty`), None when no
    batch carries one (0 in a batch without it).

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
    drive: npt.NDArray[np.float64] | None = None


_Arrays = tuple[npt.NDArray[np.int64], npt.NDArray[np.float64], npt.NDArray[np.float64],
                npt.NDArray[np.float64] | None]

#: Capacity growth of the sample arrays while reading (`_Columns`): the peak is about this
#: times the arrays (doubling: 41.6 bytes a sample for 24 of arrays).
GROWTH = 1.25


@dataclass
class _Columns:
    """The samples gathered while reading, written batch by batch into arrays that grow in
    place by `GROWTH` (`ndarray.resize`: a large block is remapped by the allocator, not
    copied; the new capacity is zero-filled, so it counts), so the peak stays near the arrays'
    own size. Holding every batch's arrays and joining them at the end had taken twice that."""

    t_ns: npt.NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, np.int64))
    pos: npt.NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 1)))
    raw: npt.NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 1)))
    drive: npt.NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2)))
    driven: bool = False
    #: (first time, start row, rows) of each batch, to put them in time order at the end
    batches: list[tuple[int, int, int]] = field(default_factory=list)
    n_samples: int = 0
    two_channels: bool | None = None

    def add(self, batch: SampleBatch) -> None:
        two = batch.pos2_m is not None
        if self.two_channels is None:
            self.two_channels = two
            width = 2 if two else 1
            self.pos, self.raw = np.zeros((0, width)), np.zeros((0, width))
        if two != self.two_channels:
            raise SchemaError("SampleBatch", f"{2 if self.two_channels else 1} channels in every batch",
                              f"{2 if two else 1} in batch {batch.batch_seq}")
        pos = [batch.pos1_m, batch.pos2_m] if two else [batch.pos1_m]
        raw = [batch.raw1, batch.raw2] if two else [batch.raw1]
        rows = len(batch.t_ns)
        start, stop = self.n_samples, self.n_samples + rows
        if stop > self.t_ns.shape[0]:
            self._grow(max(stop, int(GROWTH * self.t_ns.shape[0]), 1024))
        self.t_ns[start:stop] = batch.t_ns
        self.pos[start:stop] = np.asarray(pos, dtype=np.float64).T.reshape(rows, len(pos))
        self.raw[start:stop] = np.asarray(raw, dtype=np.float64).T.reshape(rows, len(raw))
        if batch.target is not None and batch.duty is not None:
            if not self.driven:   # kept from the first batch that has one: no room taken in a run without
                self.driven = True
                self.drive.resize((self.t_ns.shape[0], 2), refcheck=False)
            self.drive[start:stop] = np.asarray([batch.target, batch.duty], dtype=np.float64).T.reshape(rows, 2)
        if rows:
            self.batches.append((int(batch.t_ns[0]), start, rows))
        self.n_samples = stop

    def _grow(self, capacity: int) -> None:
        # the arrays own their data and no view of them leaves this object before `arrays`
        self.t_ns.resize((capacity,), refcheck=False)
        self.pos.resize((capacity, self.pos.shape[1]), refcheck=False)
        self.raw.resize((capacity, self.raw.shape[1]), refcheck=False)
        if self.driven:
            self.drive.resize((capacity, 2), refcheck=False)

    def arrays(self) -> _Arrays:
        """(t_ns, pos, raw, drive or None) of every sample read, the unwritten capacity given
        back, batches in time order (a file keeps them in order; a recovered one may not: then a
        copy). Call once, at the end."""
        self._grow(self.n_samples)
        t_ns, pos, raw, drive = self.t_ns, self.pos, self.raw, self.drive
        order = sorted(range(len(self.batches)), key=lambda i: self.batches[i][0])
        if order != list(range(len(order))):
            rows = np.concatenate([np.arange(self.batches[i][1], self.batches[i][1] + self.batches[i][2])
                                   for i in order])
            t_ns, pos, raw = t_ns[rows], pos[rows], raw[rows]
            drive = drive[rows] if self.driven else drive
        return t_ns, pos, raw, drive if self.driven else None


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
    t_ns, pos, raw, drive = _joined(columns, metadata)
    return RunContents(t_ns, pos, raw, metadata, finished, states, outcome.complete,
                       outcome.stop_reason, n_records, drive)


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


def _joined(columns: _Columns, metadata: RunMetadata | None) -> _Arrays:
    n_channels = (2 if columns.two_channels else 1) if columns.two_channels is not None else (
        metadata.n_channels if metadata is not None else 1)
    if not columns.n_samples:
        return np.zeros(0, np.int64), np.zeros((0, n_channels)), np.zeros((0, n_channels)), None
    return columns.arrays()


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
