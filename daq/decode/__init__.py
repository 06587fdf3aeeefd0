"""Pure, incremental decoders of the serial dialects, and the matching encoders.

Use::

    decoder = make_decoder("cartlab")      # or "csv", "ecp"
    frames = decoder.feed(chunk)           # list[DataFrame | InfoFrame]; never raises on data
    decoder.counters                       # DecodeCounters: lines, frames, rejections

Feed chunks as they come off the port; the unfinished tail is kept between calls, so any
split of a stream gives the same frames and counters as feeding it whole. No I/O, no
clocks: time stamps are the device's, unwrapped later by `daq.timeline`.
"""

from __future__ import annotations

from daq.decode.cartlab import (
    CartlabDecoder,
    encode_data,
    encode_frame,
    encode_info,
    encode_query_command,
    encode_rate_command,
    parse_host_command,
    xor_checksum,
)
from daq.decode.text import CsvDecoder, EcpDecoder, encode_csv, encode_csv_header, encode_ecp
from daq.errors import DaqValueError
from daq.frames import DIALECTS, Decoder, Dialect, Frame, InfoFrame

__all__ = [
    "CartlabDecoder",
    "CsvDecoder",
    "EcpDecoder",
    "encode",
    "encode_csv",
    "encode_csv_header",
    "encode_data",
    "encode_ecp",
    "encode_frame",
    "encode_info",
    "encode_query_command",
    "encode_rate_command",
    "make_decoder",
    "parse_host_command",
    "xor_checksum",
]


def make_decoder(dialect: Dialect | str, max_line: int = 256) -> Decoder:
    """A fresh decoder for `dialect` ("cartlab", "csv" or "ecp")."""
    if dialect == "cartlab":
        return CartlabDecoder(max_line)
    if dialect == "csv":
        return CsvDecoder(max_line)
    if dialect == "ecp":
        return EcpDecoder(max_line)
    raise DaqValueError("dialect", " or ".join(DIALECTS), dialect)


def _exact(value: float) -> str:
    return str(int(value)) if float(value).is_integer() else repr(float(value))


def encode(dialect: Dialect | str, frame: Frame) -> bytes:
    """The line `frame` was decoded from, in `dialect` (exact round trip for DataFrames).

    cartlab: `$D`/`$I` lines (counts rounded to integers); csv: `time_s,pos...` with the
    time to the microsecond and positions exact; ecp: `c1:c2:target:duty:time_ms` (the
    frame's drive, 0:0 when it has none). csv and ecp have no `$I` line.
    """
    if dialect == "cartlab":
        return encode_frame(frame)
    if isinstance(frame, InfoFrame) or dialect not in DIALECTS:
        raise DaqValueError("encode", "a DataFrame in cartlab, csv or ecp", (dialect, frame))
    if dialect == "csv":
        fields = [f"{frame.t_us // 1_000_000}.{frame.t_us % 1_000_000:06d}" if frame.t_us >= 0
                  else f"{frame.t_us / 1e6:.6f}"] + [_exact(p) for p in frame.raw]
        return (",".join(fields) + "\n").encode()
    if len(frame.raw) != 2:
        raise DaqValueError("encode ecp", "two positions", frame.raw)
    time_ms = f"{frame.t_us // 1000}.{frame.t_us % 1000:03d}" if frame.t_us >= 0 else f"{frame.t_us / 1e3:.3f}"
    target, duty = frame.drive or (0.0, 0.0)
    return f"{_exact(frame.raw[0])}:{_exact(frame.raw[1])}:{_exact(target)}:{_exact(duty)}:{time_ms}\n".encode()
