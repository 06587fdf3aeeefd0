"""Serial faults through the whole acquisition (issue 6, part 1).

- 1 % of the lines of a clean `sim://` capture corrupted (`tools/serialfaults.py`: bit flips, truncation,
  random bytes, NUL bytes, 10 kB lines without a newline) and replayed with `replay://`:
  every intact line inside a run is recorded, every corrupted one is counted and rejected.
- 10+ unplug/replug cycles during one run (`sim://` `disconnect_every_s`): reconnected each
  time, every delivered sample kept, each gap marked in the run metadata.
- the device clock and sequence counter wrap mid-run: continuous time in the recording.

The truth is the bytes themselves: lines are decoded here by a regular expression with
their checksum verified (`serialfaults.intact_lines`), never by `daq.decode`. The `daq` service runs
in this process, without Zenoh, on an injected no-wait back-off.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from testkit.serialfaults import (
    Corrupted,
    corrupt_capture,
    expected,
    intact_lines,
    read_port,
    recorded,
    run_service,
    run_service_on_bytes,
    unwrap_us,
)

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
    t_ns = unwrap_us(corrupted.intact[:, 1]) * 1000
    got, want = recorded(run), expected(corrupted.intact, t_ns, run)
    assert got == want, (len(want - got), len(got - want))
    # Corrupted lines fell inside the run: it has holes where they were.
    span_lines = round((run.t_ns[-1] - run.t_ns[0]) / 1e6) + 1
    assert len(got) < span_lines
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
    assert len(corrupted.intact) == len(intact_lines(clean)) - sum(corrupted.injected.values())
    _check_corrupted_run(tmp_path, corrupted)


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
    lines = intact_lines(capture.read_bytes())
    t_ns = unwrap_us(lines[:, 1]) * 1000
    assert recorded(run) == expected(lines, t_ns, run)
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
    lines = intact_lines(capture.read_bytes())
    t_us = lines[:, 1]
    wrap_at = int(np.argmax(np.diff(t_us) < 0)) + 1
    t_ns = unwrap_us(t_us) * 1000
    assert run.t_ns[0] < t_ns[wrap_at] < run.t_ns[-1], "the clock wrap must fall inside the run"
    seq_wrap = int(np.argmax(np.diff(lines[:, 0]) < 0)) + 1
    assert run.t_ns[0] < t_ns[seq_wrap] < run.t_ns[-1], "the sequence wrap must fall inside the run"
    steps = np.diff(run.t_ns)
    period_ns = 1e9 / rate
    assert np.all(steps > 0.5 * period_ns) and np.all(steps < 1.5 * period_ns), (steps.min(), steps.max())
    assert recorded(run) == expected(lines, t_ns, run)
    assert counters.clock_wraps == 1 and counters.seq_gaps == 0 and counters.lost_frames == 0
    assert run.release_time_s is not None and 0.4 < run.release_time_s < 0.7
