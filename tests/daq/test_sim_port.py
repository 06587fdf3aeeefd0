"""`sim://` as a pyserial port: determinism, options, faults, disconnects, capture, commands."""

from __future__ import annotations

import importlib
import itertools
from pathlib import Path

import pytest
import serial

import daq  # noqa: F401 - registers sim:// and replay://
from daq.decode import encode_query_command, encode_rate_command
from daq.frames import InfoFrame
from daq.serial_handlers import EndOfStream
from daq.sim import SimOptionError, describe_options
from testkit.sim_support import data_frames, decode, read_all

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
    assert table.count("\n| `") == 55            # 47 + the student's 8
    assert "| `student` | `off` |" in table


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
    steps = {b - a for a, b in itertools.pairwise(times)}
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


def run_port(url: str) -> tuple[bytes, object]:
    """Bytes of a finite sim port and its rig (for the ground truth of faults)."""
    port = serial.serial_for_url(url)
    out = bytearray()
    rig = port.rig
    try:
        for _ in range(100_000):
            try:
                out += port.read(65536)
            except EndOfStream:
                return bytes(out), rig
    finally:
        port.close()
    raise AssertionError("no end of stream")


@pytest.mark.parametrize("garbage", [0.0, 0.05])
def test_faults_cost_exactly_the_faulted_lines_and_are_counted(garbage: float) -> None:
    url = FAST + "&seed=11&rate_hz=200"
    clean = data_frames(decode(read_all(url))[0])
    stream, rig = run_port(url + f"&corrupt=0.05&drop=0.03&garbage={garbage}")
    frames, counters = decode(stream)
    faults = rig.stats.faults  # type: ignore[attr-defined]
    kinds = [kind for _, kind in faults]
    assert {"drop", "bitflip", "truncate", "nul", "non_ascii", "overlong"} <= set(kinds)
    lost = {index for index, _ in faults}
    assert data_frames(frames) == [f for i, f in enumerate(clean) if i not in lost]
    assert counters.rejected >= len(faults) - kinds.count("drop")
    assert counters.overlong == kinds.count("overlong")
    if garbage == 0.0:
        assert counters.non_ascii >= kinds.count("nul") + kinds.count("non_ascii")
        assert counters.torn >= kinds.count("truncate")
    else:
        assert rig.stats.garbage_bursts > 10  # type: ignore[attr-defined]
        assert counters.malformed > 0


def test_disconnect_raises_then_the_same_rig_comes_back() -> None:
    url = "sim://?realtime=0&cases=none&duration_s=3&rate_hz=100&disconnect_every_s=1&disconnect_s=0.5&reopen_failures=2"
    port = serial.serial_for_url(url)
    got = bytearray()
    with pytest.raises(serial.SerialException, match="unplugged"):
        for _ in range(1000):
            got += port.read(4096)
    with pytest.raises(serial.SerialException):
        port.read(1)                                   # the old connection stays dead
    port.close()
    for _ in range(2):
        with pytest.raises(serial.SerialException, match="could not open"):
            serial.serial_for_url(url)
    port = serial.serial_for_url(url)
    got += port.read(2000)
    port.close()
    seqs = [f.seq for f in data_frames(decode(bytes(got))[0])]
    assert seqs[:100] == list(range(100)) and seqs[100:103] == [150, 151, 152]   # 1.0-1.5 s lost


@pytest.mark.timeout(30)
def test_realtime_paces_by_the_injected_clock(monkeypatch: pytest.MonkeyPatch) -> None:
    from daq.serial_handlers import protocol_sim

    now = [100.0]
    monkeypatch.setattr(protocol_sim.Serial, "clock", staticmethod(lambda: now[0]))
    monkeypatch.setattr(protocol_sim.Serial, "sleep", staticmethod(lambda s: now.__setitem__(0, now[0] + s)))
    port = serial.serial_for_url("sim://?rate_hz=100&cases=none", timeout=0.5)
    try:
        data = port.read(1_000_000)                    # times out after 0.5 s of the fake clock
        assert now[0] == pytest.approx(100.5)
        assert port.in_waiting == 0
        now[0] += 0.105
        later = port.read(port.in_waiting)
    finally:
        port.close()
    first = data_frames(decode(data)[0])
    assert [f.t_us for f in first] == [10_000 * i for i in range(51)]
    assert len(data_frames(decode(data + later)[0])) == 61


@pytest.mark.timeout(30)
def test_realtime_unplug_lasts_disconnect_s_of_the_clock(monkeypatch: pytest.MonkeyPatch) -> None:
    from daq.serial_handlers import protocol_sim

    now = [0.0]
    monkeypatch.setattr(protocol_sim.Serial, "clock", staticmethod(lambda: now[0]))
    monkeypatch.setattr(protocol_sim.Serial, "sleep", staticmethod(lambda s: now.__setitem__(0, now[0] + s)))
    url = "sim://?rate_hz=100&cases=none&disconnect_every_s=1&disconnect_s=0.5"
    port = serial.serial_for_url(url, do_not_open=True, timeout=0.305)
    port.open()
    got = bytearray()
    with pytest.raises(serial.SerialException):
        for _ in range(10):
            got += port.read(10**6)
    port.close()
    assert now[0] == pytest.approx(1.0, abs=0.01)
    with pytest.raises(serial.SerialException, match="could not open"):
        serial.serial_for_url(url)
    now[0] = 1.525
    port = serial.serial_for_url(url, timeout=0.1)
    got += port.read(10**6)
    port.close()
    seqs = [f.seq for f in data_frames(decode(bytes(got))[0])]
    # read up to 0.915 s; 0.92-0.99 were not read when it was unplugged at 1.0 (lost in
    # transit); the lines of 1.0-1.5 s were never sent; back at 1.5 s
    assert seqs == list(range(92)) + list(range(150, 163))


def test_reboot_on_reconnect_restarts_seq_and_clock_and_sends_info() -> None:
    from daq.serial_link import LinkEvent, SerialLink
    from daq.timeline import Timeline

    link = SerialLink("sim://?realtime=0&cases=none&duration_s=3&rate_hz=100&disconnect_every_s=2"
                      "&disconnect_s=0.5&reopen_failures=0&reboot_on_reconnect=1&clock0_us=5000000",
                      sleep=lambda s: None)
    link.open()
    stream = bytearray()
    for _ in range(10_000):
        got = link.read()
        stream += got.data
        if got.event is LinkEvent.EOF:
            break
    frames, _counters = decode(bytes(stream))
    assert [type(f).__name__ for f in frames].count("InfoFrame") == 2
    data = data_frames(frames)
    assert [f.seq for f in data] == list(range(200)) + list(range(51))
    assert data[200].t_us == 5_000_000                  # the clock restarted at boot
    timeline = Timeline()
    steps = [timeline.push(f.seq, f.t_us) for f in data]
    assert steps[200].anomaly == "seq_reset" and timeline.counters.clock_backwards == 1
    assert all(b.t_ns > a.t_ns for a, b in itertools.pairwise(steps))


def test_rate_command_before_the_first_sample() -> None:
    port = serial.serial_for_url("sim://?realtime=0&cases=none&duration_s=0.1&rate_hz=100")
    try:
        port.write(encode_rate_command(200))
        stream = bytearray()
        with pytest.raises(EndOfStream):
            for _ in range(100):
                stream += port.read(4096)
    finally:
        port.close()
    times = [f.t_us for f in data_frames(decode(bytes(stream))[0])]
    assert times == [5000 * i for i in range(21)]


def test_unwritable_capture_path_is_a_named_option_error(tmp_path: Path) -> None:
    with pytest.raises(SimOptionError, match="'capture': expected a writable file path"):
        serial.serial_for_url(f"sim://?capture={tmp_path / 'missing' / 'c.bin'}")
