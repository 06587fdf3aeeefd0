"""Unwrapping the u32 device clock and sequence counter."""

from __future__ import annotations

from daq.decode import make_decoder
from daq.frames import DataFrame
from daq.timeline import Timeline, TimelineStep
from testkit.sim_support import read_all

U32 = 2**32


def test_unwraps_clock_and_seq_across_the_u32_wrap() -> None:
    timeline = Timeline()
    seqs = [U32 - 2, U32 - 1, 0, 1]
    times = [U32 - 15_000, U32 - 5_000, 5_000, 15_000]
    steps = [timeline.push(s, t) for s, t in zip(seqs, times)]
    assert [s.t_ns for s in steps] == [(U32 - 15_000 + 10_000 * i) * 1000 for i in range(4)]
    assert timeline.counters.clock_wraps == 1 and timeline.counters.seq_wraps == 1
    assert timeline.counters.lost_lines == 0


def test_several_wraps_accumulate() -> None:
    timeline = Timeline()
    step_us = 1_500_000_000                       # three steps per wrap
    raw = [(i * step_us) % U32 for i in range(10)]
    out = [timeline.push(i, t).t_ns for i, t in enumerate(raw)]
    assert out == [i * step_us * 1000 for i in range(10)]
    assert timeline.counters.clock_wraps == 3


def test_seq_gaps_duplicates_and_resets() -> None:
    timeline = Timeline()
    got = [timeline.push(s, t) for s, t in [(10, 0), (11, 10), (15, 50), (15, 50), (3, 60)]]
    assert got[2] == TimelineStep(50_000, lost=3)
    assert got[3].duplicate and got[4].anomaly == "seq_reset"
    c = timeline.counters
    assert (c.seq_gaps, c.lost_lines, c.duplicates, c.seq_resets) == (1, 3, 1, 1)


def test_clock_going_back_keeps_time_increasing() -> None:
    timeline = Timeline(nominal_period_us=10)
    out = [timeline.push(i, t) for i, t in enumerate([1000, 1010, 1020, 5, 15])]
    assert [s.t_ns for s in out] == [1_000_000, 1_010_000, 1_020_000, 1_030_000, 1_040_000]
    assert out[3].anomaly == "clock_backwards" and timeline.counters.clock_backwards == 1


def test_no_seq_counter_gaps_from_the_clock() -> None:
    timeline = Timeline(clock_bits=None, nominal_period_us=10_000)
    out = [timeline.push(None, t) for t in [0, 10_000, 40_000, 50_000]]
    assert [s.lost for s in out] == [0, 0, 2, 0]
    assert out[-1].t_ns == 50_000_000


def test_sim_started_near_the_wrap_decodes_to_continuous_time() -> None:
    start = U32 - 3_000_000                      # wraps 3 s after boot
    stream = read_all(f"sim://?realtime=0&cases=none&duration_s=6&rate_hz=200&clock0_us={start}"
                      f"&seq0={U32 - 500}")
    frames = [f for f in make_decoder("cartlab").feed(stream) if isinstance(f, DataFrame)]
    assert min(f.t_us for f in frames) < 10_000 and min(f.seq or 0 for f in frames) == 0
    timeline = Timeline()
    t_ns = [timeline.push(f.seq, f.t_us).t_ns for f in frames]
    assert t_ns == [(start + 5_000 * i) * 1000 for i in range(len(frames))]
    assert len(frames) == 1201
    assert timeline.counters.clock_wraps == 1 and timeline.counters.seq_wraps == 1


def test_clock_jump_against_the_sequence_is_flagged() -> None:
    timeline = Timeline()
    pairs = [(0, 0), (1, 10_000), (2, 20_000), (3, 5_020_000), (4, 5_030_000), (6, 5_050_000), (7, 5_052_000)]
    steps = [timeline.push(s, t) for s, t in pairs]
    assert [s.anomaly for s in steps] == [None, None, None, "clock_jump", "clock_jump", None, "clock_jump"]
    assert steps[3].t_ns == 5_020_000_000            # kept as sent
    assert timeline.counters.clock_jumps == 3 and timeline.counters.lost_lines == 1
    nominal = Timeline(nominal_period_us=10_000)
    flags = [nominal.push(s, t).anomaly for s, t in pairs]
    assert flags == [None, None, None, "clock_jump", None, None, "clock_jump"]
