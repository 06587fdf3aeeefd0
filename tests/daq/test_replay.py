"""`replay://`: byte-exact reproduction of a capture, pacing by time stamps, end of stream."""

from __future__ import annotations

from pathlib import Path

import pytest
import serial

from daq.decode import encode_csv, encode_csv_header
from daq.serial_handlers import EndOfStream, protocol_replay
from daq.sim import SimOptionError
from testkit.sim_support import data_frames, decode, read_all

U32 = 2**32


def test_capture_replays_byte_for_byte_and_ends(tmp_path: Path) -> None:
    capture = tmp_path / "rig capture.bin"
    emitted = read_all(f"sim://?realtime=0&rest_s=0.5&pull_s=0.5&hold_s=0.5&ring_max_s=2&corrupt=0.02"
                       f"&garbage=0.02&capture={capture}")
    url = "replay://" + str(capture).replace(" ", "%20") + "?speed=max"
    port = serial.serial_for_url(url)
    try:
        replayed = port.read(1000) + port.read(10**9)
        with pytest.raises(EndOfStream):
            port.read(1)
    finally:
        port.close()
    assert replayed == emitted == capture.read_bytes()


class FakeClock:
    def __init__(self) -> None:
        self.now = 50.0

    def clock(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.now += seconds


@pytest.mark.timeout(30)
@pytest.mark.parametrize("clock0", [0, U32 - 500_000])
def test_speed_1_paces_lines_by_their_device_time_across_a_wrap(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, clock0: int) -> None:
    fake = FakeClock()
    monkeypatch.setattr(protocol_replay.Serial, "clock", staticmethod(fake.clock))
    monkeypatch.setattr(protocol_replay.Serial, "sleep", staticmethod(fake.sleep))
    capture = tmp_path / "c.bin"
    capture.write_bytes(read_all(f"sim://?realtime=0&cases=none&duration_s=2&rate_hz=100&clock0_us={clock0}"))
    port = serial.serial_for_url(f"replay://{capture}?speed=1", timeout=0.255)
    try:
        first = port.read(10**6)
        assert fake.now == pytest.approx(50.255)
        fake.now += 10.0
        rest = port.read(10**6)
    finally:
        port.close()
    frames = data_frames(decode(first)[0])
    assert len(frames) == 26                       # lines due at 0, 10, ... 250 ms
    assert len(data_frames(decode(first + rest)[0])) == 201
    assert first + rest == capture.read_bytes()


def test_text_export_replays_at_a_speed_factor(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    fake = FakeClock()
    monkeypatch.setattr(protocol_replay.Serial, "clock", staticmethod(fake.clock))
    monkeypatch.setattr(protocol_replay.Serial, "sleep", staticmethod(fake.sleep))
    export = tmp_path / "run.csv"
    export.write_bytes(encode_csv_header(2) + b"".join(encode_csv(i * 0.01, [0.001 * i, 0.0]) for i in range(100)))
    port = serial.serial_for_url(f"replay://{export}?speed=10", timeout=0.0505)
    try:
        first = port.read(10**6)                   # 0.05 s at 10x covers 0.5 s of the file
    finally:
        port.close()
    frames = data_frames(decode(first, "csv")[0])
    assert first.startswith(b"time_s,pos1,pos2\n") and len(frames) == 51


@pytest.mark.parametrize("url, option", [
    ("replay:///x.bin?speed=0", "'speed'"),
    ("replay:///x.bin?speed=fast", "'speed'"),
    ("replay:///x.bin?loop=1", "replay option name"),
    ("replay:///x.bin?dialect=nmea", "'dialect'"),
])
def test_bad_replay_options_are_named(url: str, option: str) -> None:
    with pytest.raises(SimOptionError, match=option):
        serial.serial_for_url(url)


def test_missing_file_is_a_serial_exception(tmp_path: Path) -> None:
    with pytest.raises(serial.SerialException, match="could not open port"):
        serial.serial_for_url(f"replay://{tmp_path / 'absent.bin'}")


def test_guess_dialect() -> None:
    assert protocol_replay.guess_dialect(b"\x00junk\n$D,1,2,3*58\n") == "cartlab"
    assert protocol_replay.guess_dialect(b"1:2:3:0.5:10\n") == "ecp"
    assert protocol_replay.guess_dialect(b"time_s,pos1\n0.0,1.0\n") == "csv"


def test_replay_option_table_names_every_option() -> None:
    table = protocol_replay.describe_replay_options()
    for name in ("speed", "dialect", "rate_hz"):
        assert f"| `{name}` |" in table


@pytest.mark.timeout(30)
def test_rate_hz_paces_lines_without_using_their_stamps(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    fake = FakeClock()
    monkeypatch.setattr(protocol_replay.Serial, "clock", staticmethod(fake.clock))
    monkeypatch.setattr(protocol_replay.Serial, "sleep", staticmethod(fake.sleep))
    export = tmp_path / "same_time.csv"
    export.write_bytes(b"".join(encode_csv(0.0, [0.001 * i]) for i in range(100)))
    port = serial.serial_for_url(f"replay://{export}?speed=1&rate_hz=100&dialect=csv", timeout=0.255)
    try:
        first = port.read(10**6)
    finally:
        port.close()
    assert len(data_frames(decode(first, "csv")[0])) == 26


@pytest.mark.parametrize(("header", "rows", "drives"), [
    ("Sample\tTime\tEncoder 1 Pos\tEncoder 2 Pos\tControl Effort",   # the 2025 ECP-210 app: duty targets
     ["1\t0.001\t0\t3\t0", "2\t0.002\t-5\t3\t491", "3\t0.004\t-20\t4\t491"], [0.0, 491.0, 491.0]),
    (" Sample   Time     Commanded Pos   Encoder 1 Pos   Control Effort",   # ECP Executive: volts
     ["[    0    0.000               0               0          0.5000;",
      "     1    0.009              -1              -2          0.5000;",
      "     2    0.018              -1              -9          0.0000]"], [0.5, 0.5, 0.0]),
])
def test_a_lab_export_replays_with_its_control_effort_as_the_drive(
        tmp_path: Path, header: str, rows: list[str], drives: list[float]) -> None:
    """The export's Control Effort is the ecp line's target, as exported (an Executive export's
    0.5 V had been rounded to 0: its steps reached daq with no drive)."""
    path = tmp_path / "export.txt"
    path.write_text("\n".join([header, "", *rows]) + "\n")
    frames = data_frames(decode(read_all(f"replay://{path}?speed=max"), "ecp")[0])
    assert [f.drive for f in frames] == [(d, 0.0) for d in drives]
    assert [f.t_us for f in frames] == [round(float(r.replace("[", " ").split()[1]) * 1e6) for r in rows]
