"""`sim://` as a pyserial port: determinism, options, faults, disconnects, capture, commands."""

from __future__ import annotations

import importlib
from pathlib import Path

import pytest
import serial

import daq  # noqa: F401
from daq.decode import encode_query_command, encode_rate_command
from daq.frames import InfoFrame
from daq.serial_handlers import EndOfStream
from daq.sim import SimOptionError, describe_options
from tests.daq.sim_support import data_frames, decode, read_all

FAST = "sim://?realtime=0&rest_s=0.5&pull_s=0.5&hold_s=0.5&ring_max_s=3&tail_s=0.5"


def test_handler_modules_import_directly() -> None:
    for name in ("daq.serial_handlers.protocol_sim", "daq.serial_handlers.protocol_replay"):
        module = importlib.import_module(name)
        assert issubclass(module.Serial, serial.SerialBase)


def test_realtime_0_is_deterministic_and_depends_on_seed() -> None:
    first = read_all(FAST + "&seed=3")
    assert first == read_all(FAST + "&seed=3")
    assert first != read_all(FAST + "&seed=4")
    frames, counters = decode(first)
    assert isinstance(frames[0], InfoFrame) and frames[0].counts_per_m == 20000
    assert counters.rejected == 0
    seqs = [f.seq for f in data_frames(frames)]
    assert seqs == list(range(len(seqs)))


@pytest.mark.parametrize("url, option", [
    ("sim://?bogus=1", "sim option name"),
    ("sim://?rate_hz=fast", "'rate_hz'"),
    ("sim://?rate_hz=0", "'rate_hz'"),
    ("sim://?cases=cart1,cart9", "'cases'"),
    ("sim://?dialect=nmea", "'dialect'"),
    ("sim://?carts=1&cases=both", "'cases'"),
    ("sim://?realtime=maybe", "'realtime'"),
])
def test_bad_options_name_the_option_and_value(url: str, option: str) -> None:
    with pytest.raises(SimOptionError) as info:
        serial.serial_for_url(url)
    message = str(info.value)
    assert option in message and "expected" in message
    assert isinstance(info.value, ValueError) and isinstance(info.value, serial.SerialException)


def test_describe_options_lists_every_option_with_default() -> None:
    table = describe_options()
    assert "| `rate_hz` | `100.0` | Hz |" in table
    assert "| `cases` | `cart1` |" in table
    assert table.count("\n| `") == 45


def test_end_of_stream_after_duration() -> None:
    stream = read_all("sim://?realtime=0&cases=none&duration_s=2&rate_hz=50")
    frames = data_frames(decode(stream)[0])
    assert [f.t_us for f in frames] == [20000 * i for i in range(101)]


def test_commands_query_and_rate() -> None:
    port = serial.serial_for_url("sim://?realtime=0&cases=none&duration_s=1&rate_hz=100")
    try:
        first = port.read(200)
        port.write(encode_rate_command(250) + encode_query_command() + b"garbage\n")
        rest = bytearray()
        while True:
            try:
                rest += port.read(4096)
            except EndOfStream:
                break
        assert port.rig is not None and port.rig.stats.commands == 2
        assert port.rig.stats.bad_commands == 1
    finally:
        port.close()
    frames, counters = decode(first + bytes(rest))
    infos = [f for f in frames if isinstance(f, InfoFrame)]
    assert [i.rate_hz for i in infos] == [100.0, 250.0, 250.0]
    times = [f.t_us for f in data_frames(frames)]
    steps = {b - a for a, b in zip(times, times[1:])}
    assert steps == {10000, 4000}
    assert times[-1] <= 1_000_000 and counters.rejected == 0


def test_capture_file_holds_every_byte_delivered(tmp_path: Path) -> None:
    path = tmp_path / "capture.bin"
    stream = read_all(FAST + f"&capture={path}&garbage=0.05&corrupt=0.05")
    assert path.read_bytes() == stream and len(stream) > 10_000


def test_csv_and_ecp_dialects_decode_to_the_same_counts() -> None:
    url = FAST + "&seed=5&noise_counts=0"
    cartlab = data_frames(decode(read_all(url))[0])
    csv = data_frames(decode(read_all(url + "&dialect=csv"), "csv")[0])
    ecp = data_frames(decode(read_all(url + "&dialect=ecp"), "ecp")[0])
    assert len(cartlab) == len(csv) == len(ecp) > 400
    assert [f.raw for f in ecp] == [f.raw for f in cartlab]
    assert [tuple(round(p * 20000) for p in f.raw) for f in csv] == [f.raw for f in cartlab]
    assert [f.t_us for f in csv] == [f.t_us for f in cartlab] == [f.t_us for f in ecp]
