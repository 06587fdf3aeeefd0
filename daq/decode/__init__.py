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
from daq.frames import DIALECTS, Decoder, Dialect
from daq.errors import DaqValueError

__all__ = [
    "CartlabDecoder", "CsvDecoder", "EcpDecoder", "make_decoder", "encode_data", "encode_frame",
    "encode_info", "encode_query_command", "encode_rate_command", "parse_host_command",
    "xor_checksum", "encode_csv", "encode_csv_header", "encode_ecp",
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
