"""Fitter plug-ins for the worker's scheduling tests (loaded with `--fitter testkit.fake_fitters:...`).

They log `start`/`done` lines to `$FAKE_FIT_LOG` so a test can count fits per run. The
gated one waits, bounded, until the file `$FAKE_FIT_GATE` exists (a test opens the gate
once it has seen what it wanted, e.g. after killing a worker mid-fit).

Start-up (`_load_in_fit_process`, run when the worker's fit process loads this module, not
when the worker itself does): with `$FAKE_FIT_START_GATE` set it writes `<gate>.loading` and
waits, bounded, for the gate (a slow start-up the test ends); with `$FAKE_FIT_START_FAIL` set
it raises (a fitter that cannot load).
"""

from __future__ import annotations

import multiprocessing
import os
import time
from pathlib import Path

from ident.worker.job import FitJob
from schemas.fit import FitReport

GATE_WAIT_S = 30.0


def _log(kind: str, job: FitJob) -> None:
    line = f"{kind} {job.finished.bench}/{job.finished.run_id} {job.worker}\n"
    fd = os.open(os.environ["FAKE_FIT_LOG"], os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
    try:
        os.write(fd, line.encode())
    finally:
        os.close(fd)


def _report(job: FitJob) -> FitReport:
    payload = job.run_file.read_bytes()
    if not payload.startswith(b"fake-run"):
        return FitReport(bench=job.finished.bench, run_id=job.finished.run_id, worker=job.worker,
                         status="failed", reason=f"expected a fake run, got {payload[:8]!r}")
    return FitReport(bench=job.finished.bench, run_id=job.finished.run_id, worker=job.worker,
                     status="ok", case="cart1", release_time_s=job.finished.release_time_s)


def instant_fit(job: FitJob) -> FitReport:
    _log("start", job)
    report = _report(job)
    _log("done", job)
    return report


def gated_fit(job: FitJob) -> FitReport:
    _log("start", job)
    gate = Path(os.environ["FAKE_FIT_GATE"])
    deadline = time.monotonic() + GATE_WAIT_S
    while not gate.exists() and time.monotonic() < deadline:
        time.sleep(0.01)  # a stand-in for a long fit, ended by the test's gate
    report = _report(job)
    _log("done", job)
    return report


def _load_in_fit_process() -> None:
    # the fit process is a spawned interpreter that imports this module while unpickling its
    # target; spawn has named it by then (`ident-fit`), the worker itself is `MainProcess`
    if multiprocessing.current_process().name == "MainProcess":   # the worker resolving --fitter
        return
    if os.environ.get("FAKE_FIT_START_FAIL"):
        raise ImportError("the fake fitter refuses to load (FAKE_FIT_START_FAIL)")
    gate = os.environ.get("FAKE_FIT_START_GATE")
    if gate:
        Path(f"{gate}.loading").touch()
        deadline = time.monotonic() + GATE_WAIT_S
        while not Path(gate).exists() and time.monotonic() < deadline:
            time.sleep(0.01)  # a stand-in for a slow start-up, ended by the test's gate


_load_in_fit_process()
