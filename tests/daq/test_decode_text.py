"""Byte transcripts of the `csv` and `ecp` dialects."""

from __future__ import annotations

import pytest

from daq.decode import encode_csv, encode_csv_header, encode_ecp, make_decoder
from daq.errors import DaqValueError
from daq.frames import DataFrame


def test_csv_transcript() -> None:
    decoder = make_decoder("csv")
    stream = (b"time_s,pos1_m,pos2_m\r\n"
              b"0.000,0.0,-0.0015\r\n"
              b"0.010\t0.000050\t-0.001500\n"
              b"# comment\n"
              b"\n"
              b"0.020,abc,0.1\n"
              b"0.030,0.1\n"
              b"0.040,0.1,0.2,0.3\n"
              b"0.050,nan,0.2\n"
              b"0.06\x00,0.1\n"
              + b"1" * 300 + b"\n"
              b"0.070;0.25\n")
    frames = decoder.feed(stream[:17]) + decoder.feed(stream[17:])
    assert frames == [DataFrame(None, 0, (0.0, -0.0015)), DataFrame(None, 10000, (0.00005, -0.0015)),
                      DataFrame(None, 30000, (0.1,)), DataFrame(None, 70000, (0.25,))]
    c = decoder.counters
    assert (c.lines, c.frames, c.malformed, c.non_ascii, c.overlong) == (12, 4, 3, 1, 1)
    assert c.extra == {"header": 1, "comment": 1}


def test_ecp_transcript() -> None:
    decoder = make_decoder("ecp")
    stream = (b"120:-35:1000:0.4878:9\n"
              b"130:-30:1000:0.4800:18.5\r\n"
              b"1:2:3:4\n"
              b"x:2:3:4:5\n"
              b"1:2:3:4:5:6\n"
              b"\xff1:2:3:4:5\n")
    frames = decoder.feed(stream)
    assert frames == [DataFrame(None, 9000, (120.0, -35.0), (1000.0, 0.4878)),
                      DataFrame(None, 18500, (130.0, -30.0), (1000.0, 0.48))]   # the drive kept
    c = decoder.counters
    assert (c.lines, c.frames, c.malformed, c.non_ascii) == (6, 2, 3, 1)


def test_text_encoders_round_trip() -> None:
    assert encode_csv_header(2) == b"time_s,pos1,pos2\n"
    assert encode_csv(1.5, [0.1, -0.02]) == b"1.500000,0.100000,-0.020000\n"
    assert encode_ecp(12, -3, 0, 0.25, 4.5) == b"12:-3:0:0.2500:4.500\n"
    assert make_decoder("csv").feed(encode_csv(1.5, [0.1])) == [DataFrame(None, 1_500_000, (0.1,))]
    assert make_decoder("ecp").feed(encode_ecp(12, -3, 0, 0.25, 4.5)) == [
        DataFrame(None, 4500, (12.0, -3.0), (0.0, 0.25))]


def test_unknown_dialect_is_named() -> None:
    with pytest.raises(DaqValueError, match="dialect: expected cartlab or csv or ecp, got 'nmea'"):
        make_decoder("nmea")
