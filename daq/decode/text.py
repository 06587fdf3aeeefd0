"""The plain-text dialects `csv` and `ecp`: one sample per `\\n`-terminated line.

- `csv`: `time_s,pos1[,pos2]` (a Logger-Pro-like stream; `\\t` or `;` also separate).
  Positions stay in the unit sent (metres for our exports). A header line (fields that
  are names, not numbers) is ignored and counted in `extra["header"]`; `#` lines in
  `extra["comment"]`; blank lines are skipped.
- `ecp`: `cart1pos:cart2pos:target:duty:time_ms` as streamed by the Teensy controller of
  an ECP Model 210 rig. Positions are encoder counts; `target` and `duty` are kept as
  the frame's `drive` (a motor pulse moves the carts: the record keeps what drove them).

`t_us` is the sent time converted to microseconds (rounded); these dialects have no
sequence counter (`seq` is None) and their time does not wrap. Lines longer than
`max_line` are dropped and counted (`overlong`) without buffering more than that; a line
with a byte outside printable ASCII (tab allowed) counts `non_ascii`; anything else that
does not parse counts `malformed`. The decoders never raise on data.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from typing import Final

from daq.frames import DataFrame, DecodeCounters, Frame

MAX_LINE: Final = 256
_PRINTABLE_TAB: Final = bytes(range(0x20, 0x7F)) + b"\t"
_CSV_SEP = re.compile(rb"[,;\t]")
_NAME = re.compile(rb"[A-Za-z_][A-Za-z0-9_ ()\[\]/.-]*")


class _LineDecoder:
    """Shared line splitting: complete lines go to `_decode_line`, the tail is bounded."""

    def __init__(self, max_line: int = MAX_LINE) -> None:
        if max_line < 16:
            raise ValueError(f"max_line: expected at least 16 bytes, got {max_line}")
        self.counters = DecodeCounters()
        self.max_line = max_line
        self._tail = b""
        self._discarding = False

    def feed(self, data: bytes) -> list[Frame]:
        out: list[Frame] = []
        if self._discarding:
            newline = data.find(b"\n")
            if newline < 0:
                return out
            self.counters.lines += 1
            self._discarding = False
            data = data[newline + 1:]
        buf = self._tail + data if self._tail else data
        lines = buf.split(b"\n")
        tail = lines.pop()
        self.counters.lines += len(lines)
        for line in lines:
            if len(line) > self.max_line:
                self.counters.overlong += 1
                continue
            text = self._clean(line)
            frame = self._decode_line(text) if text is not None else None
            if frame is not None:
                self.counters.frames += 1
                out.append(frame)
        if len(tail) > self.max_line:
            self.counters.overlong += 1
            self._discarding = True
            tail = b""
        self._tail = tail
        return out

    def _decode_line(self, line: bytes) -> DataFrame | None:
        """Decode one cleaned line (no `\\r`, not blank, printable ASCII)."""
        raise NotImplementedError

    def _clean(self, line: bytes) -> bytes | None:
        """Strip a trailing `\\r`; None for a blank line or one with an unprintable byte (counted)."""
        if line.endswith(b"\r"):
            line = line[:-1]
        if not line.strip() or self._reject_unprintable(line):
            return None
        return line

    def _bump(self, name: str) -> None:
        self.counters.extra[name] = self.counters.extra.get(name, 0) + 1

    def _reject_unprintable(self, line: bytes) -> bool:
        if line.translate(None, _PRINTABLE_TAB):
            self.counters.non_ascii += 1
            return True
        return False


def _finite(text: bytes) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise ValueError("not finite")
    return value


class CsvDecoder(_LineDecoder):
    """`time_s,pos1[,pos2]` lines (see the module docstring)."""

    def _decode_line(self, line: bytes) -> DataFrame | None:
        if line.lstrip().startswith(b"#"):
            self._bump("comment")
            return None
        fields = _CSV_SEP.split(line)
        try:
            values = [_finite(f) for f in fields]
        except ValueError:
            if all(_NAME.fullmatch(f.strip()) for f in fields):
                self._bump("header")
            else:
                self.counters.malformed += 1
            return None
        if not 2 <= len(values) <= 3 or abs(values[0]) > 1e9:
            self.counters.malformed += 1
            return None
        return DataFrame(None, round(values[0] * 1e6), tuple(values[1:]))


class EcpDecoder(_LineDecoder):
    """`cart1pos:cart2pos:target:duty:time_ms` lines (see the module docstring)."""

    def _decode_line(self, line: bytes) -> DataFrame | None:
        fields = line.split(b":")
        try:
            values = [_finite(f) for f in fields]
        except ValueError:
            self.counters.malformed += 1
            return None
        if len(values) != 5 or abs(values[4]) > 1e12:
            self.counters.malformed += 1
            return None
        return DataFrame(None, round(values[4] * 1e3), (values[0], values[1]), (values[2], values[3]))


def encode_csv(t_s: float, positions: Sequence[float], digits: int = 6) -> bytes:
    """`time_s,pos1[,pos2]\\n` with `digits` decimals."""
    fields = [f"{t_s:.6f}"] + [f"{p:.{digits}f}" for p in positions]
    return (",".join(fields) + "\n").encode()


def encode_csv_header(n_positions: int) -> bytes:
    """`time_s,pos1[,pos2]\\n`."""
    return (",".join(["time_s"] + [f"pos{i + 1}" for i in range(n_positions)]) + "\n").encode()


def encode_ecp(cart1: int, cart2: int, target: float, duty: float, time_ms: float) -> bytes:
    """`cart1pos:cart2pos:target:duty:time_ms\\n` (positions in counts; a whole target, counts on
    the Teensy, without decimals, any other as exported: ECP Executive's efforts are volts)."""
    target_text = str(int(target)) if float(target).is_integer() else repr(float(target))
    return f"{cart1}:{cart2}:{target_text}:{duty:.4f}:{time_ms:.3f}\n".encode()
