"""The worker loop's message handling, without Zenoh (the bus is never touched here)."""

from __future__ import annotations

import json
import queue
from pathlib import Path
from typing import Any

from ident.worker.bus import BusEvent
from ident.worker.service import Worker, WorkerOptions
from schemas.daq import RunFinished


def _worker(tmp_path: Path) -> Worker:
    bus: Any = None
    return Worker(WorkerOptions(name="w1", runs_dir=tmp_path), bus, queue.Queue(),
                  fitter=lambda job: None)  # type: ignore[arg-type, return-value]


def _finished(**changes: object) -> bytes:
    record = RunFinished(bench="b1", run_id="r1", status="complete", file="r1.mcap",
                         n_samples=10, release_time_s=0.5, duration_s=1.0)
    return json.dumps({**json.loads(record.to_json_bytes()), **changes}).encode()


def test_records_whose_names_would_escape_keys_or_directories_are_dropped(tmp_path: Path) -> None:
    worker = _worker(tmp_path)
    for bad in ({"bench": ".."}, {"run_id": "../../etc"}, {"run_id": "a/b"}, {"bench": "*"}):
        worker.handle(BusEvent("finished", "cartlab/x/runs/y/finished", _finished(**bad)))
    worker.handle(BusEvent("finished", "cartlab/b1/runs/r1/finished", b"{not json"))
    worker.handle(BusEvent("fit", "cartlab/b1/runs/r1/fit",
                           b'{"bench":"..","run_id":"r1","worker":"w","status":"ok"}'))
    assert worker.sched.runs == {}
    worker.handle(BusEvent("finished", "cartlab/b1/runs/r1/finished", _finished()))
    assert [str(r) for r in worker.sched.pending()] == ["b1/r1"]


def test_worker_events_track_who_is_alive(tmp_path: Path) -> None:
    worker = _worker(tmp_path)
    worker.handle(BusEvent("worker", "cartlab/ident/w2", up=True))
    assert worker.sched.alive == {"w1", "w2"}
    worker.handle(BusEvent("worker", "cartlab/ident/w2", up=False))
    worker.handle(BusEvent("worker", "cartlab/ident/w1", up=False))   # never drops itself
    assert worker.sched.alive == {"w1"}
