"""The acquisition core on encoded synthetic streams, with a recording fake sink."""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import UTC, datetime

import numpy as np
import pytest

from daq.decode import encode_data, encode_info
from daq.pipeline import MAX_LIVE_GAPS, Acquisition, AcquisitionConfig
from schemas.daq import DetectorStateMsg, RunFinished, RunMetadata, SampleBatch
from testkit.student_records import student_records
from testkit.synth_runs import LAB_CASES, Trace, lab_run


@dataclass
class FakeOutputs:
    live_batches: list[SampleBatch] = field(default_factory=list)
    states: list[DetectorStateMsg] = field(default_factory=list)
    started: list[RunMetadata] = field(default_factory=list)
    run_batches: list[SampleBatch] = field(default_factory=list)
    finished: list[tuple[RunMetadata, RunFinished]] = field(default_factory=list)

    def live(self, batch: SampleBatch) -> None:
        self.live_batches.append(batch)

    def state(self, msg: DetectorStateMsg) -> None:
        self.states.append(msg)

    def run_started(self, metadata: RunMetadata) -> None:
        self.started.append(metadata)

    def run_samples(self, batch: SampleBatch) -> None:
        self.run_batches.append(batch)

    def run_finished(self, metadata: RunMetadata, finished: RunFinished) -> None:
        self.finished.append((metadata, finished))


def _stream(trace: Trace, t0_us: int = 0) -> bytes:
    lines = [encode_info("sim", "1.0", trace.counts_per_m, 100.0)]
    for i, (t, (c1, c2)) in enumerate(zip(trace.t_s.tolist(), trace.counts.tolist())):
        lines.append(encode_data(i, (t0_us + round(t * 1e6)) % (1 << 32), (int(c1), int(c2))))
    return b"".join(lines)


def t_ns_of_first(out: FakeOutputs) -> int:
    """Device time of the stream's first sample (from the live batches)."""
    return out.live_batches[0].t_ns[0]


def _acquire(data: bytes, chunk: int = 4096) -> FakeOutputs:
    out = FakeOutputs()
    acq = Acquisition(AcquisitionConfig(bench="b1", port="test://"), out,
                      wall_clock=lambda: datetime(2026, 11, 22, 1, 2, 3, tzinfo=UTC),
                      existing_run_ids=lambda run_id: run_id in {m.run_id for m in out.started})
    for i in range(0, len(data), chunk):
        acq.data(data[i:i + chunk])
    acq.finish("end of stream")
    return out


def test_one_run_with_pre_trigger_samples_zeroed_at_the_hold() -> None:
    trace = lab_run(LAB_CASES[2], 200, seed=4, after_s=14.0)
    assert trace.release_t_s is not None
    wrap_in_run = (1 << 32) - round((trace.release_t_s + 2.0) * 1e6)   # the device clock wraps mid-run
    out = _acquire(_stream(trace, t0_us=wrap_in_run))
    assert len(out.started) == 1 and len(out.finished) == 1
    meta, done = out.finished[0]
    assert done.status == "complete" and done.run_id == "r20261122-010203-000"
    assert meta.counters.clock_wraps == 1
    t_ns = np.array([t for b in out.run_batches for t in b.t_ns])
    raw1 = np.array([r for b in out.run_batches for r in b.raw1])
    pos1 = np.array([p for b in out.run_batches for p in b.pos1_m])
    assert done.n_samples == t_ns.size and np.all(np.diff(t_ns) > 0)
    # the samples are exactly the trace's from 0.5 s before the release
    assert meta.release_t_ns is not None and meta.first_t_ns == int(t_ns[0])
    assert meta.release_time_s == pytest.approx((meta.release_t_ns - int(t_ns[0])) / 1e9)
    assert 0.5 <= meta.release_time_s < 0.5 + 1 / 200
    first = \
        int(np.searchsorted(trace.t_s, trace.t_s[0] + (int(t_ns[0]) - t_ns_of_first(out)) / 1e9 - 1e-6))
    assert raw1.tolist() == trace.counts[first:first + t_ns.size, 0].tolist()
    # zeroed at the hold: the cart reads ~0 just before the release and +0.15 m once settled
    before = t_ns < meta.release_t_ns
    assert abs(pos1[before][-1]) < 1e-3
    assert pos1[-1] == pytest.approx(0.15, abs=2e-3)
    run_states = [(s.state, s.run_id) for s in out.states if s.run_id is not None]
    assert run_states == [("released", done.run_id), ("settled", done.run_id)]
    assert sum(len(b.t_ns) for b in out.live_batches) == trace.t_s.size


def test_stream_cut_mid_run_finishes_it_as_aborted() -> None:
    trace = lab_run(LAB_CASES[0], 100, seed=2, after_s=8.0)
    data = _stream(trace)
    assert trace.release_t_s is not None
    cut = int(np.searchsorted(trace.t_s, trace.release_t_s + 1.0))
    out = _acquire(data[: data.index(b"$D,%d," % cut)])
    (_meta, done), = out.finished
    assert done.status == "aborted" and done.reason == "end of stream"
    assert done.n_samples == pytest.approx(150, abs=3)


def test_a_daq_started_during_the_hold_records_the_first_release_from_its_pre_trigger() -> None:
    trace = lab_run(LAB_CASES[0], 200, seed=9, after_s=14.0)
    assert trace.release_t_s is not None
    start = int(np.searchsorted(trace.t_s, trace.release_t_s - 0.9))   # held still from the first sample
    held = Trace(trace.t_s[start:], trace.counts[start:], trace.counts_per_m, trace.release_t_s)
    out = _acquire(_stream(held))
    (meta, done), = out.finished
    assert done.status == "complete" and meta.pulled_cart == 1 and meta.lab_case == "cart1"
    assert meta.release_time_s is not None and 0.5 <= meta.release_time_s < 0.5 + 1 / 200
    t_ns = np.array([t for b in out.run_batches for t in b.t_ns])
    # every sample from 0.5 s before the release on, none missing around the (late) confirmation
    assert done.n_samples == t_ns.size and np.all(np.diff(t_ns) == np.diff(t_ns).min())
    release_ns = t_ns_of_first(out) + round((trace.release_t_s - held.t_s[0]) * 1e9)
    assert abs(meta.release_t_ns - release_ns) < 1e9 / 200
    pos1 = np.array([p for b in out.run_batches for p in b.pos1_m])
    assert abs(pos1[t_ns < meta.release_t_ns][-1]) < 1e-3 and pos1[-1] == pytest.approx(0.15, abs=2e-3)


def test_lost_lines_all_day_keep_the_live_gap_list_bounded_and_each_run_its_own_gaps() -> None:
    trace = lab_run(LAB_CASES[0], 200, seed=6, after_s=14.0)
    assert trace.release_t_s is not None
    keep = np.ones(trace.t_s.size, dtype=bool)
    keep[5::10] = False                           # one line in ten lost, before, during and after the run
    lines = [line for i, line in enumerate(_stream(trace).splitlines(keepends=True)[1:]) if keep[i]]
    out = FakeOutputs()
    acq = Acquisition(AcquisitionConfig(bench="b1", port="test://"), out,
                      wall_clock=lambda: datetime(2026, 11, 22, 1, 2, 3, tzinfo=UTC), existing_run_ids=lambda _: False)
    acq.data(b"".join(lines))
    acq.finish("end of stream")
    lost = int((~keep).sum())
    status = acq.counters()
    assert status.seq_gaps == status.lost_frames == lost > MAX_LIVE_GAPS
    ends_ns = [round(t * 1e6) * 1000 for t in trace.t_s[np.flatnonzero(~keep) + 1].tolist()]
    assert [g.end_t_ns for g in status.gap_intervals] == ends_ns[-MAX_LIVE_GAPS:]   # the latest ones
    (meta, done), = out.finished
    assert done.status == "complete"
    run_t = [t for b in out.run_batches for t in b.t_ns]
    gaps = meta.counters.gap_intervals
    assert meta.counters.seq_gaps == len(gaps) > MAX_LIVE_GAPS   # a run keeps every gap of its own
    assert all(run_t[0] <= g.start_t_ns < g.end_t_ns <= run_t[-1] for g in gaps)


def test_a_release_the_stream_cuts_before_it_is_dated_is_recorded_as_an_aborted_run() -> None:
    """A student's last release cut by the record's end (`testkit.student_records` seed 6019, a
    free pair's hold let go 0.84 s before the end): its ringing was confirmed but not dated when
    the stream ended, and no run was written. Its run (started at the end of the stream by the
    ringing, or at once by the hold armed on that cart alone) ends with the stream."""
    rec = student_records(6019, (100.0,))[100.0]
    counts_per_m = 56000.0
    trace = Trace(rec.t - rec.t[0], np.round(rec.y * counts_per_m), counts_per_m, None)
    out = _acquire(_stream(trace))
    meta, done = out.finished[-1]
    assert done.status == "aborted" and done.reason == "end of stream"
    assert meta.release_t_ns is not None
    release_s = (meta.release_t_ns - t_ns_of_first(out)) / 1e9 + rec.t[0]
    assert abs(release_s - rec.releases[-1].time_s) < 0.02
    assert meta.release_time_s is not None and 0.5 <= meta.release_time_s < 0.5 + 1 / 100


def test_a_cart_held_while_the_other_swings_is_zeroed_alone() -> None:
    """A free pair's cart held pulled while the other swings (`testkit.student_records` seed
    11303: cart 1 held 96 mm out from 1.3 s, let go at 2.04 s, cart 2 swinging ±30 mm): the hold
    is armed on cart 1 alone, which reads 0 there; cart 2 keeps the zero it had where both carts
    were first still (its rest), not a point of its swing."""
    rec = student_records(11303, (100.0,))[100.0]
    counts_per_m = 56000.0
    trace = Trace(rec.t - rec.t[0], np.round(rec.y * counts_per_m), counts_per_m, None)
    out = _acquire(_stream(trace))
    first = out.started[0]
    assert first.release_t_ns is not None
    release_s = (first.release_t_ns - t_ns_of_first(out)) / 1e9 + rec.t[0]
    assert abs(release_s - rec.releases[0].time_s) < 0.01
    batches = [b for b in out.run_batches if b.run_id == first.run_id]
    t_ns = np.array([t for b in batches for t in b.t_ns])
    pos = np.array([(p, q) for b in batches for p, q in zip(b.pos1_m, b.pos2_m, strict=True)])
    before = np.flatnonzero(t_ns < first.release_t_ns)[-1]
    assert abs(pos[before, 0]) < 1e-3
    k = int(np.searchsorted(trace.t_s, (t_ns[before] - t_ns_of_first(out)) / 1e9 - 1e-6))
    assert pos[before, 1] == pytest.approx(rec.y[k, 1] - rec.y[0, 1], abs=1e-3)
