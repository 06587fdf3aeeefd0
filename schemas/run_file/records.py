"""The one damage-tolerant MCAP record reader (`iter_records`), within `Limits`.

`mcap`'s record parsers read the file record by record, so a file killed mid-write (no
summary, an unfinished chunk) yields every complete record and stops at the first damaged
one (`ReadOutcome.complete` is then False). Chunks are opened here, not by `mcap`, so that
every size is checked against the limits before anything is allocated.
"""

from __future__ import annotations

import io
import os
import struct
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO, Final

import zstandard
from mcap.data_stream import ReadDataStream
from mcap.exceptions import EndOfFile
from mcap.opcode import Opcode
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

from schemas.run_file.limits import DAMAGE_ERRORS, DEFAULT_LIMITS, Limits, RunFileTooLarge


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


def has_mcap_magic(path: Path) -> bool:
    """Whether `path` starts with the MCAP magic (a run file under any name: `.mcap.part`,
    a renamed copy); False for a shorter or different file. Raises `OSError` as `open`."""
    with open(path, "rb") as stream:
        return stream.read(len(_MAGIC)) == _MAGIC


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


__all__ = ["ReadOutcome", "iter_records"]
