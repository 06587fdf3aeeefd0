"""Byte transcripts of the `cartlab` dialect: exact bytes in, exact frames and counters out."""

from __future__ import annotations

import pytest

from daq.decode import (
    encode_data,
    encode_info,
    encode_query_command,
    encode_rate_command,
    make_decoder,
    parse_host_command,
    xor_checksum,
)
from daq.frames import DataFrame, InfoFrame


def counters_of(stream: bytes) -> tuple[list[object], dict[str, int]]:
    decoder = make_decoder("cartlab")
    frames = decoder.feed(stream)
    c = decoder.counters
    counts = {"lines": c.lines, "frames": c.frames, "info": c.info_frames, "bad_checksum": c.bad_checksum,
              "torn": c.torn, "non_ascii": c.non_ascii, "overlong": c.overlong, "malformed": c.malformed}
    return list(frames), {k: v for k, v in counts.items() if v}


def test_checksum_is_xor_between_dollar_and_star() -> None:
    # 0x44 ^ 0x2c ^ 0x31 ^ 0x2c ^ 0x32 ^ 0x2c ^ 0x33 = 0x58
    assert xor_checksum(b"D,1,2,3") == 0x58
    assert encode_data(1, 2, [3]) == b"$D,1,2,3*58\n"
    assert encode_query_command() == b"$Q*51\n"          # 'Q' = 0x51
    assert encode_rate_command(200) == b"$R,200*%02X\n" % xor_checksum(b"R,200")


def test_clean_two_encoder_and_one_encoder_lines() -> None:
    stream = b"$D,7,1000,-12,34*5B\n$D,8,2000,5*67\r\n"       # checksums computed by hand
    frames, counts = counters_of(stream)
    assert frames == [DataFrame(7, 1000, (-12.0, 34.0)), DataFrame(8, 2000, (5.0,))]
    assert counts == {"lines": 2, "frames": 2}


def test_info_line() -> None:
    line = encode_info("cartbox", "1.2.0", 20000, 100)
    assert line == b"$I,cartbox,1.2.0,20000,100*%02X\n" % xor_checksum(b"I,cartbox,1.2.0,20000,100")
    frames, counts = counters_of(line)
    assert frames == [InfoFrame("cartbox", "1.2.0", 20000.0, 100.0)]
    assert counts == {"lines": 1, "info": 1}


def test_bad_checksum_is_counted_and_dropped() -> None:
    good = b"$D,1,2,3*58\n"
    frames, counts = counters_of(b"$D,1,2,3*59\n$D,1,2,4*58\n" + good)
    assert frames == [DataFrame(1, 2, (3.0,))]
    assert counts == {"lines": 3, "frames": 1, "bad_checksum": 2}


def test_torn_line_dropped_at_next_dollar_and_next_line_kept() -> None:
    stream = b"$D,1,100,5,6*4" + encode_data(2, 200, [7, 8]) + encode_data(3, 300, [9, 10])
    frames, counts = counters_of(stream)
    assert frames == [DataFrame(2, 200, (7.0, 8.0)), DataFrame(3, 300, (9.0, 10.0))]
    assert counts == {"lines": 2, "frames": 2, "torn": 1}


def test_nul_invalidates_the_frame_even_though_xor_ignores_it() -> None:
    line = encode_data(4, 400, [1, 2])
    with_nul = line[:5] + b"\x00" + line[5:]                 # checksum still matches
    frames, counts = counters_of(with_nul + line)
    assert frames == [DataFrame(4, 400, (1.0, 2.0))]
    assert counts == {"lines": 2, "frames": 1, "non_ascii": 1}


def test_non_ascii_byte_in_frame_and_junk_between_lines() -> None:
    line = encode_data(5, 500, [3, 4])
    stream = line[:4] + b"\xe9" + line[4:] + b"noise\xff!!" + line + b"\r\n"
    frames, counts = counters_of(stream)
    assert frames == [DataFrame(5, 500, (3.0, 4.0))]
    assert counts == {"lines": 3, "frames": 1, "non_ascii": 1, "malformed": 1}


@pytest.mark.parametrize("split", [1, 7, 100, 255, 300, 301, 10_000])
def test_overlong_line_dropped_without_unbounded_buffering(split: int) -> None:
    decoder = make_decoder("cartlab")
    good = encode_data(9, 900, [1, -1])
    stream = b"$D,1," + b"9" * 600 + b"\n" + good + b"x" * 1000 + b"\n" + good
    frames = []
    for i in range(0, len(stream), split):
        frames += decoder.feed(stream[i:i + split])
        assert len(decoder._tail) <= 256  # type: ignore[attr-defined]
    assert frames == [DataFrame(9, 900, (1.0, -1.0))] * 2
    c = decoder.counters
    assert (c.overlong, c.malformed, c.frames, c.lines) == (1, 1, 2, 4)


def test_malformed_frames() -> None:
    cases = [b"D,1,2", b"D,x,2,3", b"D,1,2,3,4,5", b"X,1", b"D,99999999999,1,2", b"I,a,b,c,d"]
    stream = b"".join(b"$%s*%02X\n" % (body, xor_checksum(body)) for body in cases)
    frames, counts = counters_of(stream + b"$D,1,2,3*ZZ\n$D,1,2,3\n")
    assert frames == []
    assert counts == {"lines": 8, "malformed": 8}


def test_u32_limits_and_negative_counts() -> None:
    line = encode_data(2**32 - 1, 2**32 - 1, [-(2**31), 2**31 - 1])
    frames, _ = counters_of(line)
    assert frames == [DataFrame(2**32 - 1, 2**32 - 1, (-(2.0**31), 2.0**31 - 1))]
    assert encode_data(2**32 + 5, 2**32 + 6, [0]) == encode_data(5, 6, [0])


def test_host_commands_parse_on_the_device_side() -> None:
    assert parse_host_command(encode_rate_command(250)) == ("R", 250.0)
    assert parse_host_command(encode_query_command()) == ("Q", None)
    assert parse_host_command(b"$Q*52\n") is None
    assert parse_host_command(b"$R,abc*%02X" % xor_checksum(b"R,abc")) is None
