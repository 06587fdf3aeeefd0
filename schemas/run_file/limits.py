"""What one reader of run files accepts, the refusal beyond it, and what damage raises.

    file bytes ≤ max_file_bytes, each record ≤ max_record_bytes,
    each chunk's decompressed size ≤ max_record_bytes and (past 1 MiB) ≤ max_expansion × its
    compressed size, all chunks ≤ max_decompressed_bytes, messages ≤ max_messages,
    samples ≤ max_samples.

A limit exceeded is a refusal (`RunFileTooLarge`), never a partial read: a bomb is not data.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Final

import zstandard
from mcap.exceptions import EndOfFile, McapError

from schemas.errors import SchemaError


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


__all__ = ["DAMAGE_ERRORS", "DEFAULT_LIMITS", "Limits", "RunFileTooLarge"]
