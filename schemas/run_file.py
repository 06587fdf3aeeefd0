"""The MCAP run file: its layout and the one damage-tolerant reader, with strict limits.

Every reader of run files (`daq` exports and recovery, `ident`'s loader, the worker's and the
page's file lookups) goes through this module; nothing else builds an MCAP reader.

Layout of a runs directory (names built here and nowhere else):

| file | what |
|---|---|
| `<run_id>.mcap.part` | a run being written (or left by a crash) |
| `<run_id>.mcap` | a finished run: never overwritten, never deleted |
| `<run_id>-r<k>.mcap` | data recovered from a `.part` whose finished name was taken |
| `<run_id>.fit/report.json` | the fit report (and figures) beside the run file |
| `quarantine/<name>` | a `.part` nothing could be read from, moved aside (never deleted) |

Reading (`iter_records`): `mcap`'s sequential reader walks the file record by record, so a
file killed mid-write (no summary, an unfinished chunk) yields every complete record and
stops at the first damaged one (`ReadOutcome.complete` is then False). Chunks are opened
here, not by `mcap`, so that every size is checked before anything is allocated:

    file bytes ≤ max_file_bytes, each record ≤ max_record_bytes,
    each chunk's decompressed size ≤ max_record_bytes and (past 1 MiB) ≤ max_expansion × its
    compressed size, all chunks ≤ max_decompressed_bytes, messages ≤ max_messages,
    samples ≤ max_samples.

A limit exceeded is a refusal (`RunFileTooLarge`), never a partial read: a bomb is not data.
Samples are turned into arrays batch by batch, so memory stays near the arrays' size
(8 bytes per value), well under the file's decompressed JSON.
"""

from __future__ import annotations

import io
import os
import struct
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO, Final, TypeVar

import numpy as np
import numpy.typing as npt
import zstandard
from mcap.data_stream import ReadDataStream
from mcap.exceptions import EndOfFile, McapError
from mcap.opcode import Opcode
from mcap.reader import SeekingReader
from mcap.records import (
    Attachment,
    AttachmentIndex,
    Channel,
    Chunk,
    ChunkIndex,
    DataEnd,
    Footer,
    Header,
    McapRecord,
    Message,
    MessageIndex,
    Metadata,
    MetadataIndex,
    Schema,
    Statistics,
    SummaryOffset,
)

from schemas import topics
from schemas.daq import DetectorStateMsg, RunFinished, RunMetadata, SampleBatch
from schemas.errors import SchemaError

# --- layout -------------------------------------------------------------------------------

RUN_SUFFIX: Final = topics.RUN_SUFFIX
PART_SUFFIX: Final = topics.PART_SUFFIX
#: Folder of a run's fit report and figures, beside its MCAP file (written by `ident`).
FIT_SUFFIX: Final = ".fit"
#: The fit report's file name inside that folder.
REPORT_NAME: Final = "report.json"
#: Sub-folder of a runs directory for `.part` files nothing could be read from.
QUARANTINE_DIR: Final = "quarantine"
#: Suffix of a recovery being written (renamed to a free `.mcap` name when sealed).
RECOVERING_SUFFIX: Final = ".mcap.recovering"


def run_file_name(run_id: str) -> str:
    return f"{run_id}{RUN_SUFFIX}"


def final_path(runs_dir: Path, run_id: str) -> Path:
    return Path(runs_dir) / run_file_name(run_id)


def part_path(runs_dir: Path, run_id: str) -> Path:
    return Path(runs_dir) / f"{run_id}{PART_SUFFIX}"


def fit_dir_of(run_file: Path) -> Path:
    """`<dir>/<run_id>.fit` beside `<dir>/<run_id>.mcap`."""
    return run_file.with_name(run_id_of(run_file) + FIT_SUFFIX)


def run_id_of(path: Path) -> str:
    """The run id a run file or part is named after (`R.mcap`, `R.mcap.part` → `R`)."""
    name = Path(path).name
    for suffix in (PART_SUFFIX, RECOVERING_SUFFIX, RUN_SUFFIX):
        if name.endswith(suffix):
            return name[: -len(suffix)]
    raise SchemaError("run file name", f"<run_id>{RUN_SUFFIX} or <run_id>{PART_SUFFIX}", repr(name))


def recovered_run_id(runs_dir: Path, run_id: str) -> str:
    """A run id whose `.mcap` does not exist yet: `run_id` itself, else `run_id-r1`, `-r2`, …"""
    candidate, k = run_id, 0
    while final_path(runs_dir, candidate).exists() or final_path(runs_dir, candidate).is_symlink():
        k += 1
        candidate = f"{run_id}-r{k}"
    return candidate


def quarantine_path(runs_dir: Path, name: str) -> Path:
    """A free path under `<runs_dir>/quarantine/` for the file called `name`."""
    folder = Path(runs_dir) / QUARANTINE_DIR
    candidate, k = folder / name, 0
    while candidate.exists() or candidate.is_symlink():
        k += 1
        candidate = folder / f"{name}.{k}"
    return candidate


# --- limits -------------------------------------------------------------------------------

@dataclass(frozen=True)
class Limits:
    """What one reader accepts; see the module docstring. Defaults fit a 2.5 h run at 1 kHz."""

    max_file_bytes: int = 1 << 30
    max_record_bytes: int = 64 << 20
    max_decompressed_bytes: int = 2 << 30
    max_messages: int = 25_000_000   # /position holds one message per sample
    max_samples: int = 10_000_000
    #: Decompressed bytes per compressed byte of a chunk larger than `expansion_after_bytes`
    #: decompressed: real chunks compress 5-20x; a bomb (one batch repeated) thousands of times.
    max_expansion: float = 200.0
    expansion_after_bytes: int = 1 << 20


DEFAULT_LIMITS: Final = Limits()


class RunFileTooLarge(SchemaError):
    """A run file (or something inside it) beyond a reader limit: refused, not truncated."""

    def __init__(self, path: Path, what: str, limit: int, got: int) -> None:
        super().__init__(f"run file {Path(path).name}", f"{what} ≤ {limit}",
                         f"{got} (refused; raise the limit only for a file you trust)")


#: What damaged or truncated MCAP bytes raise at the damage, in `mcap` and its codecs.
DAMAGE_ERRORS: Final = (McapError, EndOfFile, EOFError, ValueError, KeyError, IndexError,
                        struct.error, zstandard.ZstdError, UnicodeDecodeError)


# --- the reader ----------------------------------------------------------------------------

@dataclass
class ReadOutcome:
    """How a read ended: `complete` (a footer was reached) or the damage it stopped at."""

    complete: bool = False
    stop_reason: str | None = None
    n_messages: int = 0
    decompressed_bytes: int = 0
    file_bytes: int = 0


_PARSERS: Final[dict[int, Callable[[ReadDataStream, int], McapRecord]]] = {
    Opcode.HEADER: lambda s, n: Header.read(s),
    Opcode.FOOTER: lambda s, n: Footer.read(s),
    Opcode.SCHEMA: lambda s, n: Schema.read(s),
    Opcode.CHANNEL: lambda s, n: Channel.read(s),
    Opcode.MESSAGE: Message.read,
    Opcode.CHUNK: lambda s, n: Chunk.read(s),
    Opcode.MESSAGE_INDEX: lambda s, n: MessageIndex.read(s),
    Opcode.CHUNK_INDEX: lambda s, n: ChunkIndex.read(s),
    Opcode.ATTACHMENT: lambda s, n: Attachment.read(s),
    Opcode.ATTACHMENT_INDEX: lambda s, n: AttachmentIndex.read(s),
    Opcode.STATISTICS: lambda s, n: Statistics.read(s),
    Opcode.METADATA: lambda s, n: Metadata.read(s),
    Opcode.METADATA_INDEX: lambda s, n: MetadataIndex.read(s),
    Opcode.SUMMARY_OFFSET: lambda s, n: SummaryOffset.read(s),
    Opcode.DATA_END: lambda s, n: DataEnd.read(s),
}
_MAGIC: Final = b"\x89MCAP0\r\n"


def iter_records(path: Path, outcome: ReadOutcome, limits: Limits = DEFAULT_LIMITS, *,
                 messages: bool = True) -> Iterator[McapRecord]:
    """Every readable record of `path` in file order (chunks opened, within `limits`).

    Each record's bytes are read whole (its length checked against what is left of the file
    and against the limit first) and parsed on their own, so a length field that lies can
    neither allocate its lie nor read into the next record. Stops quietly at damage (recorded
    in `outcome`); raises `RunFileTooLarge` at a limit and `OSError` when the file cannot be
    opened. With `messages=False` chunks are skipped unopened (metadata is never in a chunk).
    """
    path = Path(path)
    with open(path, "rb") as stream:
        size = os.fstat(stream.fileno()).st_size
        if size > limits.max_file_bytes:
            raise RunFileTooLarge(path, "file bytes", limits.max_file_bytes, size)
        outcome.file_bytes = size
        try:
            if stream.read(len(_MAGIC)) != _MAGIC:
                raise ValueError("expected the MCAP magic at the start of the file")
            yield from _top_level(path, stream, size - len(_MAGIC), outcome, limits, messages)
        except RunFileTooLarge:
            raise   # a refusal, not damage (it is a ValueError too)
        except DAMAGE_ERRORS as exc:
            outcome.stop_reason = f"{type(exc).__name__}: {exc}"[:200]


def _top_level(path: Path, stream: BinaryIO, left: int, outcome: ReadOutcome, limits: Limits,
               messages: bool) -> Iterator[McapRecord]:
    while True:
        opcode, body = _next_record(path, stream, left, limits)
        left -= 9 + len(body)
        record = _parse(opcode, body)
        if isinstance(record, Chunk):
            if messages:
                yield from _open_chunk(path, record, outcome, limits)
        elif record is not None:
            if isinstance(record, Message):
                _count_message(path, outcome, limits)
            yield record
        if isinstance(record, Footer):
            if stream.read(len(_MAGIC)) != _MAGIC:
                raise ValueError("expected the MCAP magic after the footer")
            outcome.complete = True
            return


def _next_record(path: Path, stream: BinaryIO, left: int, limits: Limits) -> tuple[int, bytes]:
    """(opcode, body) of the next record; `left` is how many bytes the stream still holds."""
    head = stream.read(9)
    if len(head) < 9:
        raise EOFError("the file ends before its footer" if head == b"" else "a record header is cut")
    opcode, length = struct.unpack("<BQ", head)
    if length > left - 9:
        raise ValueError(f"record 0x{opcode:02x} claims {length} bytes, {max(left - 9, 0)} are left")
    if length > limits.max_record_bytes:
        raise RunFileTooLarge(path, "record bytes", limits.max_record_bytes, length)
    body = stream.read(length)
    if len(body) != length:
        raise EOFError("a record is cut")
    return opcode, body


def _parse(opcode: int, body: bytes) -> McapRecord | None:
    """One record from exactly its bytes (unknown opcodes are skipped, as the spec says)."""
    parser = _PARSERS.get(opcode)
    if parser is None:
        return None
    return parser(_Exact(io.BytesIO(body)), len(body))


class _Exact(ReadDataStream):
    """A record's bytes: a field asking for more than is left is damage, not a short read."""

    def read(self, length: int) -> bytes:
        data = super().read(length)
        if len(data) != length:
            raise EndOfFile()
        return data


def _count_message(path: Path, outcome: ReadOutcome, limits: Limits) -> None:
    outcome.n_messages += 1
    if outcome.n_messages > limits.max_messages:
        raise RunFileTooLarge(path, "messages", limits.max_messages, outcome.n_messages)


def _open_chunk(path: Path, chunk: Chunk, outcome: ReadOutcome, limits: Limits) -> list[McapRecord]:
    """The records inside `chunk`, its declared decompressed size checked before anything is
    allocated and the output bounded by it (a size that lies cannot allocate more)."""
    declared = chunk.uncompressed_size
    if declared > limits.max_record_bytes:
        raise RunFileTooLarge(path, "decompressed chunk bytes", limits.max_record_bytes, declared)
    if declared > limits.expansion_after_bytes and declared > limits.max_expansion * max(len(chunk.data), 1):
        raise RunFileTooLarge(path, "a chunk's decompressed bytes per compressed byte (a bomb?)",
                              int(limits.max_expansion), round(declared / max(len(chunk.data), 1)))
    if outcome.decompressed_bytes + declared > limits.max_decompressed_bytes:
        raise RunFileTooLarge(path, "decompressed bytes", limits.max_decompressed_bytes,
                              outcome.decompressed_bytes + declared)
    if chunk.compression == "zstd":
        reader = zstandard.ZstdDecompressor().stream_reader(io.BytesIO(chunk.data))
        data = reader.read(declared + 1)
    elif chunk.compression == "":
        data = chunk.data
    else:
        raise ValueError(f"chunk: expected zstd or no compression, got {chunk.compression!r}")
    if len(data) != declared:
        raise ValueError(f"chunk: expected {declared} decompressed bytes, got {len(data)}")
    outcome.decompressed_bytes += len(data)
    records: list[McapRecord] = []
    stream, left = io.BytesIO(data), len(data)
    while left > 0:
        opcode, body = _next_record(path, stream, left, limits)
        left -= 9 + len(body)
        record = _parse(opcode, body)
        if isinstance(record, Message):
            _count_message(path, outcome, limits)
        if isinstance(record, Schema | Channel | Message):
            records.append(record)
    return records


# --- a run as arrays ------------------------------------------------------------------------

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


__all__ = ["DAMAGE_ERRORS", "DEFAULT_LIMITS", "FIT_SUFFIX", "PART_SUFFIX", "QUARANTINE_DIR",
           "RECOVERING_SUFFIX", "REPORT_NAME", "RUN_SUFFIX", "Limits", "ReadOutcome",
           "RunContents", "RunFileTooLarge", "final_path", "fit_dir_of", "iter_records",
           "part_path", "quarantine_path", "read_finished", "read_run", "recovered_run_id",
           "run_file_name", "run_id_of", "run_metadata"]
