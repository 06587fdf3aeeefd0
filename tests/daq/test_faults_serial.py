"""Serial faults through the whole acquisition (issue 6, part 1).

- 1 % of the lines of a clean `sim://` capture corrupted here (bit flips, truncation,
  random bytes, NUL bytes, 10 kB lines without a newline) and replayed with `replay://`:
  every intact line inside a run is recorded, every corrupted one is counted and rejected.
- 10+ unplug/replug cycles during one run (`sim://` `disconnect_every_s`): reconnected each
  time, every delivered sample kept, each gap marked in the run metadata.
- the device clock and sequence counter wrap mid-run: continuous time in the recording.

The truth is the bytes themselves: lines are decoded here by a regular expression with
their checksum verified (`_intact_lines`), never by `daq.decode`. The `daq` service runs
in this process, without Zenoh, on an injected no-wait back-off.
"""

from __future__ import annotations

import random
import re
from collections.abc import Callable
from dataclasses import dataclass
from functools import reduce
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest
import serial

import daq  # noqa: F401  (registers sim:// and replay://)
from daq.run_file import RunData, load_run
from daq.serial_handlers import EndOfStream
from daq.serial_link import SerialLink
from daq.service import Service, ServiceConfig
from schemas.daq import DaqCounters

DATA_LINE = re.compile(rb"\$(D,(\d+),(\d+),(-?\d+),(-?\d+))\*([0-9A-F]{2})\n")
CORRUPTIONS = ("bitflip", "truncate", "random", "nul", "long")


def read_port(url: str, max_reads: int = 200_000) -> bytes:
    port = serial.serial_for_url(url, timeout=0.05)
    out = bytearray()
    try:
        for _ in range(max_reads):
            try:
                out += port.read(65536)
            except EndOfStream:
                return bytes(out)
    finally:
        port.close()
    raise AssertionError(f"{url}: no end of stream after {max_reads} reads")


def _intact_lines(stream: bytes) -> npt.NDArray[np.int64]:
    """(N, 4) seq, t_us, enc1, enc2 of every well-formed `$D` line with a good checksum."""
    rows = []
    for match in DATA_LINE.finditer(stream):
        if reduce(lambda a, b: a ^ b, match.group(1), 0) == int(match.group(6), 16):
            rows.append([int(match.group(i)) for i in range(2, 6)])
    return np.array(rows, dtype=np.int64).reshape(-1, 4)


def _unwrap_us(t_us: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
    steps = np.diff(t_us) % (1 << 32)
    return np.concatenate([[t_us[0]], t_us[0] + np.cumsum(steps)]) if t_us.size else t_us


def _corrupt(line: bytes, kind: str, rng: random.Random) -> bytes:
    """One corrupted line that no decoder may accept, and that is exactly one bad line."""
    star = line.index(b"*")
    body = bytearray(line)
    printable_junk = bytes(b for b in range(256) if b not in b"\n$")
    if kind == "bitflip":
        for _ in range(100):
            i = rng.randrange(1, star)
            flipped = body[i] ^ (1 << rng.randrange(8))
            if flipped not in b"\n$":
                body[i] = flipped
                return bytes(body)
    if kind == "truncate":
        return line[:rng.randrange(2, len(line) - 2)] + b"\n"
    if kind == "random":
        return b"$" + bytes(rng.choice(printable_junk) for _ in range(star - 1)) + line[star:]
    if kind == "nul":
        body[rng.randrange(1, star)] = 0
        return bytes(body)
    # kind == "long": the line's start, then 10 kB without a newline: the next `$` ends it.
    return line[:star] + bytes(rng.choice(printable_junk) for _ in range(10_000))


@dataclass
class Corrupted:
    stream: bytes
    injected: dict[str, int]
    intact: npt.NDArray[np.int64]


def corrupt_capture(clean: bytes, fraction: float, seed: int,
                    spare: Callable[[int], bool] = lambda _t_us: False) -> Corrupted:
    """Corrupt a `fraction` of the data lines (kinds in turn); lines whose device time
    `spare(t_us)` holds are left alone."""
    rng = random.Random(seed)
    lines = clean.splitlines(keepends=True)
    injected = {kind: 0 for kind in CORRUPTIONS}
    out = []
    for i, line in enumerate(lines):
        # Never the first/last lines (device info, end of stream); only data lines.
        match = DATA_LINE.fullmatch(line)
        if 5 < i < len(lines) - 5 and match and not spare(int(match.group(3))) and rng.random() < fraction:
            kind = CORRUPTIONS[sum(injected.values()) % len(CORRUPTIONS)]
            injected[kind] += 1
            out.append(_corrupt(line, kind, rng))
        else:
            out.append(line)
    stream = b"".join(out)
    return Corrupted(stream, injected, _intact_lines(stream))


def run_service(url: str, runs_dir: Path) -> tuple[list[RunData], DaqCounters]:
    link = SerialLink(url, sleep=lambda _s: None)
    service = Service(ServiceConfig(port=url, runs_dir=runs_dir, bench="faults", bus=None, until_eof=True),
                      link=link)
    service.run()
    runs = [load_run(p) for p in sorted(runs_dir.glob("*.mcap"))]
    return runs, service.acq.counters()


def run_service_on_bytes(stream: bytes, workdir: Path) -> tuple[list[RunData], DaqCounters]:
    workdir.mkdir(parents=True, exist_ok=True)
    (workdir / "stream.bin").write_bytes(stream)
    return run_service(f"replay://{workdir / 'stream.bin'}?speed=max", workdir / "runs")


def _recorded(run: RunData) -> set[tuple[int, int, int]]:
    raw = run.raw.astype(np.int64)
    return {(int(t), int(a), int(b)) for t, a, b in zip(run.t_ns, raw[:, 0], raw[:, 1], strict=True)}


def _expected(lines: npt.NDArray[np.int64], t_ns: npt.NDArray[np.int64], run: RunData) -> set[tuple[int, int, int]]:
    inside = (t_ns >= run.t_ns[0]) & (t_ns <= run.t_ns[-1])
    return {(int(t), int(a), int(b)) for t, a, b in zip(t_ns[inside], lines[inside, 2], lines[inside, 3], strict=True)}


SIM_1KHZ = ("sim://?realtime=0&rate_hz=1000&cases=both&seed=11&rest_s=1&pull_s=0.8&hold_s=1.2&c1=2&c2=2"
            "&tail_s=0.5")


def _check_corrupted_run(tmp_path: Path, corrupted: Corrupted) -> None:
    n_injected = sum(corrupted.injected.values())
    capture = tmp_path / "corrupted.bin"
    capture.write_bytes(corrupted.stream)

    runs, counters = run_service(f"replay://{capture}?speed=max", tmp_path / "runs")

    assert counters.bad_lines == n_injected, (counters, corrupted.injected)
    assert counters.frames >= len(corrupted.intact)
    assert len(runs) == 1 and runs[0].complete, f"expected the one release recorded, got {len(runs)} runs"
    run = runs[0]
    t_ns = _unwrap_us(corrupted.intact[:, 1]) * 1000
    recorded, expected = _recorded(run), _expected(corrupted.intact, t_ns, run)
    assert recorded == expected, (len(expected - recorded), len(recorded - expected))
    # Corrupted lines fell inside the run: it has holes where they were.
    span_lines = round((run.t_ns[-1] - run.t_ns[0]) / 1e6) + 1
    assert len(recorded) < span_lines
    assert run.metadata is not None and run.metadata.counters.bad_lines > 0


def test_one_percent_corrupted_lines_outside_the_hold_are_rejected_and_every_intact_line_recorded(
        tmp_path: Path) -> None:
    clean = read_port(SIM_1KHZ)
    runs, _ = run_service_on_bytes(clean, tmp_path / "clean")
    assert len(runs) == 1 and runs[0].metadata is not None and runs[0].metadata.release_t_ns is not None
    release_us = runs[0].metadata.release_t_ns // 1000
    # Spare the 1.5 s before the release (the hold, when the detector arms): see the next test.
    corrupted = corrupt_capture(clean, fraction=0.01, seed=3,
                                spare=lambda t_us: release_us - 1_500_000 <= t_us <= release_us)
    assert all(n > 5 for n in corrupted.injected.values()), corrupted.injected
    assert len(corrupted.intact) == len(_intact_lines(clean)) - sum(corrupted.injected.values())
    _check_corrupted_run(tmp_path, corrupted)


@pytest.mark.xfail(strict=True, reason="BUG daq/pipeline.py Acquisition._gap: one lost line (a rejected "
                   "line is a seq gap) resets the release detector while no run is open, so a corrupted "
                   "line during the hold disarms it and the release is never recorded (0 runs at 0.1 %)")
def test_one_percent_corrupted_lines_anywhere_still_record_the_release(tmp_path: Path) -> None:
    corrupted = corrupt_capture(read_port(SIM_1KHZ), fraction=0.01, seed=3)
    _check_corrupted_run(tmp_path, corrupted)


def test_unplug_replug_ten_times_during_a_run_keeps_every_sample_and_marks_the_gaps(tmp_path: Path) -> None:
    capture = tmp_path / "delivered.bin"
    url = ("sim://?realtime=0&rate_hz=200&cases=cart1&seed=7&rest_s=0.6&pull_s=0.5&hold_s=0.8&c1=0.3&c2=0.3"
           f"&disconnect_every_s=1.0&disconnect_s=0.25&reopen_failures=1&ring_max_s=14&tail_s=0.5"
           f"&capture={capture}")
    runs, counters = run_service(url, tmp_path / "runs")

    assert len(runs) == 1 and runs[0].complete
    run = runs[0]
    assert run.metadata is not None
    gaps = [g for g in run.metadata.counters.gap_intervals if g.reason == "disconnect"
            and run.t_ns[0] <= g.start_t_ns <= run.t_ns[-1]]
    assert len(gaps) >= 10, run.metadata.counters.gap_intervals
    assert counters.reconnects >= len(gaps)
    # Every line the device delivered inside the run is in the file.
    lines = _intact_lines(capture.read_bytes())
    t_ns = _unwrap_us(lines[:, 1]) * 1000
    assert _recorded(run) == _expected(lines, t_ns, run)
    # Each marked gap is a real hole in the samples (the device was unplugged ~0.25 s).
    for gap in gaps:
        before = run.t_ns[run.t_ns <= gap.start_t_ns]
        after = run.t_ns[run.t_ns >= gap.end_t_ns]
        assert before.size and after.size
        assert 0.2e9 <= after[0] - before[-1] <= 0.5e9, gap


def test_device_clock_and_sequence_wrap_mid_run_give_continuous_time(tmp_path: Path) -> None:
    capture = tmp_path / "delivered.bin"
    rate = 200
    # The clock wraps ~3.2 s after boot and the sequence ~3.5 s after boot: both inside the
    # run (rest 0.5 + pull 0.5 + hold 0.8 s, release at ~1.8 s, the carts ring for seconds).
    url = (f"sim://?realtime=0&rate_hz={rate}&cases=cart1&seed=8&rest_s=0.5&pull_s=0.5&hold_s=0.8&c1=1"
           f"&clock0_us={2**32 - 3_200_000}&seq0={2**32 - 700}&tail_s=0.5&capture={capture}")
    runs, counters = run_service(url, tmp_path / "runs")

    assert len(runs) == 1
    run = runs[0]
    lines = _intact_lines(capture.read_bytes())
    t_us = lines[:, 1]
    wrap_at = int(np.argmax(np.diff(t_us) < 0)) + 1
    t_ns = _unwrap_us(t_us) * 1000
    assert run.t_ns[0] < t_ns[wrap_at] < run.t_ns[-1], "the clock wrap must fall inside the run"
    seq_wrap = int(np.argmax(np.diff(lines[:, 0]) < 0)) + 1
    assert run.t_ns[0] < t_ns[seq_wrap] < run.t_ns[-1], "the sequence wrap must fall inside the run"
    steps = np.diff(run.t_ns)
    period_ns = 1e9 / rate
    assert np.all(steps > 0.5 * period_ns) and np.all(steps < 1.5 * period_ns), (steps.min(), steps.max())
    assert _recorded(run) == _expected(lines, t_ns, run)
    assert counters.clock_wraps == 1 and counters.seq_gaps == 0 and counters.lost_frames == 0
    assert run.release_time_s is not None and 0.4 < run.release_time_s < 0.7
