"""Issue 14 row 5: a full disk is an event, not a crash (ENOSPC injected at the file layer).

The daq keeps its stream going, names the path and the run, marks the gap, records again in a
continuation file once space returns, and recovers the part that was cut into a finished file.
"""

from __future__ import annotations

import errno
import itertools
import logging
import os
from pathlib import Path
from typing import Any, BinaryIO

import pytest

from daq.run_file import load_run
from daq.serial_link import SerialLink
from daq.service import Service, ServiceConfig
from schemas import run_file

SIM = "sim://?realtime=0&rate_hz=500&cases=cart1&seed=21&rest_s=1&pull_s=0.6&hold_s=1&tail_s=1"


class Disk:
    """A disk of `budget` bytes; it refuses (ENOSPC) until `refusals_left` refusals were made,
    then space returns."""

    def __init__(self, budget: int, refusals_until_space: int | None) -> None:
        self.budget = budget
        self.refusals = 0
        self.refusals_until_space = refusals_until_space

    def take(self, n: int) -> None:
        if n > self.budget:
            self.refusals += 1
            if self.refusals_until_space is not None and self.refusals >= self.refusals_until_space:
                self.budget = 1 << 40     # someone freed space
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        self.budget -= n

    def opener(self, path: Path) -> BinaryIO:
        self.take(1)
        return _OnDisk(open(path, "xb"), self)


class _OnDisk:
    def __init__(self, handle: BinaryIO, disk: Disk) -> None:
        self._handle, self._disk = handle, disk

    def write(self, data: bytes) -> int:
        self._disk.take(len(data))
        return self._handle.write(data)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._handle, name)


def _run(runs_dir: Path, disk: Disk) -> Service:
    ticks = itertools.count()
    service = Service(ServiceConfig(port=SIM, runs_dir=runs_dir, bench="b1", bus=None, until_eof=True),
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
    part = tmp_path / f"{run.run_id}{run_file.PART_SUFFIX}"
    assert part.is_file() and load_run(part).t_ns.size > 0
