"""Issue 14 row 5: a full disk is an event, not a crash (ENOSPC injected at the file layer).

The daq keeps its stream going, names the path and the run, marks the gap, records again in a
continuation file once space returns, and recovers the part that was cut into a finished file.
"""

from __future__ import annotations

import itertools
import logging
from pathlib import Path

import numpy as np
import pytest

from daq.recording import BACKLOG_SAMPLES
from daq.run_file import load_run
from daq.serial_link import SerialLink
from daq.service import Service, ServiceConfig
from schemas import run_file
from testkit.full_disk import Disk

SIM = "sim://?realtime=0&rate_hz=500&cases=cart1&seed=21&rest_s=1&pull_s=0.6&hold_s=1&tail_s=1"


def _run(runs_dir: Path, disk: Disk, backlog_samples: int = BACKLOG_SAMPLES) -> Service:
    ticks = itertools.count()
    service = Service(ServiceConfig(port=SIM, runs_dir=runs_dir, bench="b1", bus=None, until_eof=True,
                                    disk_backlog_samples=backlog_samples),
                      clock=lambda: next(ticks) * 1e-2, link=SerialLink(SIM, sleep=lambda _s: None),
                      opener=disk.opener)
    service.run()
    return service


def test_a_full_disk_mid_run_loses_nothing_and_recording_resumes_when_space_returns(
        tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.INFO):
        service = _run(tmp_path / "full", Disk(budget=60_000, refusals_until_space=3))
    clean = _run(tmp_path / "clean", Disk(budget=1 << 40, refusals_until_space=None))
    (first,) = [r for r in service.finished_runs if r.status == "recovered"]
    (rest,) = [r for r in service.finished_runs if r.status == "complete"]
    assert rest.run_id == f"{first.run_id}-p2"
    part = tmp_path / "full" / (first.run_id + run_file.PART_SUFFIX)
    assert f"disk full writing {part} (run {first.run_id})" in caplog.text
    head, tail = load_run(tmp_path / "full" / first.file), load_run(tmp_path / "full" / rest.file)
    assert head.t_ns.size > 0 and tail.t_ns.size > 0
    (whole,) = [load_run(tmp_path / "clean" / r.file) for r in clean.finished_runs]
    # every sample of the run is in one of the two files (the kept batches start the second)
    assert set(whole.t_ns.tolist()) <= set(head.t_ns.tolist()) | set(tail.t_ns.tolist())
    assert tail.t_ns[0] > head.t_ns[-1]   # the kept batches resume after the part: no sample twice
    assert tail.t_ns[-1] == whole.t_ns[-1]
    assert not [g for g in tail.metadata.counters.gap_intervals if g.reason == "disk_full"]  # type: ignore[union-attr]
    assert not list((tmp_path / "full").glob("*.part"))


def test_a_disk_that_stays_full_ends_the_run_aborted_and_keeps_its_part(
        tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.INFO):
        service = _run(tmp_path, Disk(budget=60_000, refusals_until_space=None))
    assert "disk full writing" in caplog.text
    (run,) = service.finished_runs
    assert run.status == "aborted" and "disk full" in (run.reason or "")
    assert "not recorded" in (run.reason or "")   # what the run loses is said, not only that it stopped
    part = tmp_path / f"{run.run_id}{run_file.PART_SUFFIX}"
    assert part.is_file() and load_run(part).t_ns.size > 0


def test_a_disk_full_longer_than_the_backlog_marks_exactly_the_samples_it_lost(
        tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    """The bound: 100 samples (0.2 s at 500 Hz) kept in memory while the disk is full for
    seconds. Every sample is in the cut part, in the continuation, or strictly inside the one
    gap marked between them; the log names the part, the run and the lost span."""
    with caplog.at_level(logging.INFO):
        service = _run(tmp_path / "full", Disk(budget=60_000, refusals_until_space=5), backlog_samples=100)
    clean = _run(tmp_path / "clean", Disk(budget=1 << 40, refusals_until_space=None))
    (first,) = [r for r in service.finished_runs if r.status == "recovered"]
    (rest,) = [r for r in service.finished_runs if r.status == "complete"]
    head, tail = load_run(tmp_path / "full" / first.file), load_run(tmp_path / "full" / rest.file)
    (whole,) = [load_run(tmp_path / "clean" / r.file) for r in clean.finished_runs]
    assert tail.metadata is not None
    (gap,) = [g for g in tail.metadata.counters.gap_intervals if g.reason == "disk_full"]
    assert (gap.start_t_ns, gap.end_t_ns) == (head.t_ns[-1], tail.t_ns[0])
    lost = set(whole.t_ns.tolist()) - set(head.t_ns.tolist()) - set(tail.t_ns.tolist())
    assert lost and all(gap.start_t_ns < t < gap.end_t_ns for t in lost)
    inside = whole.t_ns[(whole.t_ns > gap.start_t_ns) & (whole.t_ns < gap.end_t_ns)]
    assert len(lost) == inside.size   # the gap holds nothing that was kept
    assert np.unique(np.concatenate([head.t_ns, tail.t_ns])).size == head.t_ns.size + tail.t_ns.size
    assert tail.t_ns[-1] == whole.t_ns[-1]
    part = tmp_path / "full" / (first.run_id + run_file.PART_SUFFIX)
    assert f"disk full writing {part} (run {first.run_id})" in caplog.text
    assert f"samples {gap.start_t_ns / 1e9:.3f}-{gap.end_t_ns / 1e9:.3f} s (device clock) lost" in caplog.text
    assert not list((tmp_path / "full").glob("*.part"))
