"""The `cartlab` dialect: NMEA-style ASCII lines with an XOR checksum.

Wire format (one line per frame, `\\n` terminated, `\\r\\n` tolerated)::

    $D,<seq>,<t_us>,<enc1>[,<enc2>]*HH      data: seq u32, t_us u32, counts i32
    $I,<model>,<firmware>,<counts_per_m>,<rate_hz>*HH   info (boot, `$Q`, `$R`)
    $R,<rate_hz>*HH   $Q*HH                  host -> device commands

`HH` is two hex digits, the XOR of every byte between `$` and `*`.

Framing rules, defined on the byte stream (so any split of the stream decodes alike):

- a frame starts at `$` and ends at `\\n`; a `$` inside a frame tears it: the torn part is
  counted (`torn`) and the new frame after the `$` is kept;
- bytes after a `\\n` and before the next `$` are junk (`malformed`, one per run of junk,
  blank runs and a lone `\\r` ignored);
- any byte outside printable ASCII (0x20..0x7e) invalidates the frame it falls in
  (`non_ascii`), even where the XOR would not notice (a NUL XORs to nothing);
- a frame or junk run longer than `max_line` bytes is dropped and counted once
  (`overlong`, or `malformed` for junk) without buffering more than `max_line` bytes;
- a wrong checksum counts `bad_checksum`; anything else unparsable counts `malformed`.

The decoder never raises on data. It does no I/O and knows nothing of time.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import Final

from daq.frames import DataFrame, DecodeCounters, Frame, InfoFrame

MAX_LINE: Final = 256
U32: Final = 1 << 32
I32_MIN: Final = -(1 << 31)
I32_MAX: Final = (1 << 31) - 1

# Fast path: a whole clean data line. Group 1 is the checksummed body.
_DATA_LINE = re.compile(rb"\$(D,(\d{1,10}),(\d{1,10}),(-?\d{1,10})(?:,(-?\d{1,10}))?)\*([0-9A-Fa-f]{2})\r?")
_INFO_BODY = re.compile(rb"I,([^,*]{1,64}),([^,*]{1,64}),([0-9.eE+-]{1,24}),([0-9.eE+-]{1,24})")
_PRINTABLE: Final = bytes(range(0x20, 0x7F))
_BLANK: Final = b" \t\r"


def xor_checksum(body: bytes) -> int:
    """XOR of all bytes of `body` (the bytes between `$` and `*`), 0..255.

    Read as one little-endian integer and folded in halves (bytes i and i + 16 XORed by
    `n ^ (n >> 128)`, and so on down to 8 bits): 1.5x faster than a byte loop.
    """
    n = int.from_bytes(body, "little")
    if len(body) > 32:
        bits = 256
        while bits < 8 * len(body):
            bits *= 2
        while bits > 256:
            bits //= 2
            n = (n ^ (n >> bits)) & ((1 << bits) - 1)
    n ^= n >> 128
    n ^= n >> 64
    n ^= n >> 32
    n ^= n >> 16
    n ^= n >> 8
    return n & 0xFF


def _framed(body: bytes) -> bytes:
    return b"$%s*%02X\n" % (body, xor_checksum(body))


def _num(value: float) -> bytes:
    """A number as the firmware prints it: integers without a decimal point."""
    if float(value).is_integer():
        return b"%d" % int(value)
    return repr(float(value)).encode()


def encode_data(seq: int, t_us: int, counts: Sequence[int]) -> bytes:
    """`$D,<seq>,<t_us>,<enc1>[,<enc2>]*HH\\n`; seq and t_us are taken modulo 2**32."""
    if not 1 <= len(counts) <= 2:
        raise ValueError(f"counts: expected 1 or 2 encoder values, got {len(counts)}")
    fields = b",".join(b"%d" % int(c) for c in counts)
    return _framed(b"D,%d,%d,%s" % (seq % U32, t_us % U32, fields))


def encode_info(model: str, firmware: str, counts_per_m: float, rate_hz: float) -> bytes:
    """`$I,<model>,<firmware>,<counts_per_m>,<rate_hz>*HH\\n`."""
    body = b"I,%s,%s,%s,%s" % (model.encode("ascii"), firmware.encode("ascii"),
                               _num(counts_per_m), _num(rate_hz))
    return _framed(body)


def encode_rate_command(rate_hz: float) -> bytes:
    """Host command `$R,<rate_hz>*HH\\n`: set the streaming rate."""
    return _framed(b"R,%s" % _num(rate_hz))


def encode_query_command() -> bytes:
    """Host command `$Q*HH\\n`: ask for an `$I` line."""
    return _framed(b"Q")


def encode_frame(frame: Frame) -> bytes:
    """The line of a decoded frame (data counts are rounded to integers)."""
    if isinstance(frame, InfoFrame):
        return encode_info(frame.model, frame.firmware, frame.counts_per_m, frame.rate_hz)
    return encode_data(frame.seq or 0, frame.t_us, [round(c) for c in frame.raw])


def parse_host_command(line: bytes) -> tuple[str, float | None] | None:
    """Device side: `$R,<rate>*HH` -> ("R", rate), `$Q*HH` -> ("Q", None), else None."""
    line = line.strip()
    star = line.rfind(b"*")
    if not line.startswith(b"$") or star < 0 or len(line) != star + 3:
        return None
    body = line[1:star]
    try:
        if int(line[star + 1:], 16) != xor_checksum(body):
            return None
    except ValueError:
        return None
    if body == b"Q":
        return ("Q", None)
    if body.startswith(b"R,"):
        try:
            return ("R", float(body[2:]))
        except ValueError:
            return None
    return None


class CartlabDecoder:
    """Incremental decoder of the `cartlab` dialect (see the module docstring)."""

    def __init__(self, max_line: int = MAX_LINE) -> None:
        if max_line < 64:
            raise ValueError(f"max_line: expected at least 64 bytes, got {max_line}")
        self.counters = DecodeCounters()
        self.max_line = max_line
        self._tail = b""          # unfinished line, at most max_line bytes
        self._discarding = False  # inside an over-long frame or junk run, already counted

    def feed(self, data: bytes) -> list[Frame]:
        out: list[Frame] = []
        if self._discarding:
            data = self._skip_discarded(data)
            if not data:
                return out
        buf = self._tail + data if self._tail else data
        lines = buf.split(b"\n")
        tail = lines.pop()
        if lines:
            self.counters.lines += len(lines)
            fast = self._decode_lines(lines, out)   # (the slow path counts its own frames)
            self.counters.frames += fast
        self._tail = self._bound_tail(tail, out)
        return out

    def _decode_lines(self, lines: list[bytes], out: list[Frame]) -> int:
        """Complete lines -> frames; returns how many clean data lines took the fast path."""
        match, checksum, append = _DATA_LINE.fullmatch, xor_checksum, out.append
        fast = 0
        for line in lines:
            hit = match(line)
            if hit is None:
                self._slow_line(line, out)
                continue
            body, seq_text, t_text, enc1_text, enc2_text, hex_text = hit.groups()
            if int(hex_text, 16) == checksum(body):
                seq, t_us, enc1 = int(seq_text), int(t_text), int(enc1_text)
                if seq < U32 and t_us < U32 and I32_MIN <= enc1 <= I32_MAX:
                    if enc2_text is None:
                        append(DataFrame(seq, t_us, (float(enc1),)))
                        fast += 1
                        continue
                    enc2 = int(enc2_text)
                    if I32_MIN <= enc2 <= I32_MAX:
                        append(DataFrame(seq, t_us, (float(enc1), float(enc2))))
                        fast += 1
                        continue
            self._data_frame(hit, out)      # a rejection: counted there
        return fast

    def _skip_discarded(self, data: bytes) -> bytes:
        """Drop the rest of an already counted over-long run, up to the next `$` or `\\n`."""
        dollar = data.find(b"$")
        newline = data.find(b"\n")
        if newline >= 0 and (dollar < 0 or newline < dollar):
            self.counters.lines += 1
            self._discarding = False
            return data[newline + 1:]
        if dollar >= 0:
            self._discarding = False
            return data[dollar:]
        return b""

    def _data_frame(self, hit: re.Match[bytes], out: list[Frame]) -> None:
        c = self.counters
        if int(hit[6], 16) != xor_checksum(hit[1]):
            c.bad_checksum += 1
            return
        seq, t_us, enc1 = int(hit[2]), int(hit[3]), int(hit[4])
        if seq >= U32 or t_us >= U32 or not I32_MIN <= enc1 <= I32_MAX:
            c.malformed += 1
            return
        if hit[5] is None:
            raw: tuple[float, ...] = (float(enc1),)
        else:
            enc2 = int(hit[5])
            if not I32_MIN <= enc2 <= I32_MAX:
                c.malformed += 1
                return
            raw = (float(enc1), float(enc2))
        c.frames += 1
        out.append(DataFrame(seq, t_us, raw))

    def _slow_line(self, line: bytes, out: list[Frame]) -> None:
        """A complete line that is not a clean data frame: split it at every `$`."""
        pieces = line.split(b"$")
        self._junk(pieces[0])
        for piece in pieces[1:-1]:
            self._torn(piece)
        if len(pieces) > 1:
            self._candidate(pieces[-1], out)

    def _junk(self, junk: bytes) -> None:
        if len(junk) > self.max_line or junk.strip(_BLANK):
            self.counters.malformed += 1

    def _torn(self, piece: bytes) -> None:
        c = self.counters
        if len(piece) + 1 > self.max_line:
            c.overlong += 1
        elif piece.translate(None, _PRINTABLE):
            c.non_ascii += 1
        else:
            c.torn += 1

    def _candidate(self, piece: bytes, out: list[Frame]) -> None:
        """The last frame of a line, `$` stripped, terminated by `\\n`."""
        c = self.counters
        if len(piece) + 1 > self.max_line:
            c.overlong += 1
            return
        if piece.endswith(b"\r"):
            piece = piece[:-1]
        if piece.translate(None, _PRINTABLE):
            c.non_ascii += 1
            return
        star = piece.rfind(b"*")
        if star < 0 or len(piece) != star + 3:
            c.malformed += 1
            return
        body = piece[:star]
        try:
            checksum = int(piece[star + 1:], 16)
        except ValueError:
            c.malformed += 1
            return
        if checksum != xor_checksum(body):
            c.bad_checksum += 1
            return
        frame = _parse_body(body)
        if frame is None:
            c.malformed += 1
        elif isinstance(frame, InfoFrame):
            c.info_frames += 1
            out.append(frame)
        else:
            c.frames += 1
            out.append(frame)

    def _bound_tail(self, tail: bytes, out: list[Frame]) -> bytes:
        """The unfinished line from its last `$`, at most `max_line` bytes. What a later `$`
        has already ended (junk before it, torn frames) is counted now, as the completed line
        would count it: counted only once the tail grew too long, a split of the stream that
        dropped the junk earlier kept a torn frame pending and counted it never."""
        last = tail.rfind(b"$")
        if last > 0:
            pieces = tail[:last].split(b"$")
            self._junk(pieces[0])
            for piece in pieces[1:]:
                self._torn(piece)
            tail = tail[last:]
        if len(tail) <= self.max_line:
            return tail
        if last >= 0:
            self.counters.overlong += 1
        else:
            self.counters.malformed += 1
        self._discarding = True
        return b""


def _parse_body(body: bytes) -> Frame | None:
    """A checksum-verified body without `$`/`*HH`, or None when it is not a valid frame."""
    if body.startswith(b"D,"):
        hit = _DATA_LINE.fullmatch(_framed(body)[:-1])
        if hit is None:
            return None
        seq, t_us, counts = int(hit[2]), int(hit[3]), [int(hit[4])]
        if hit[5] is not None:
            counts.append(int(hit[5]))
        if seq >= U32 or t_us >= U32 or not all(I32_MIN <= n <= I32_MAX for n in counts):
            return None
        return DataFrame(seq, t_us, tuple(float(n) for n in counts))
    info = _INFO_BODY.fullmatch(body)
    if info is None:
        return None
    try:
        counts_per_m, rate_hz = float(info[3]), float(info[4])
    except ValueError:
        return None
    if not (0 < counts_per_m < 1e12 and 0 < rate_hz < 1e7):
        return None
    return InfoFrame(info[1].decode(), info[2].decode(), counts_per_m, rate_hz)
