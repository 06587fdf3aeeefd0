"""Process faults (issue 6, part 2): kill -9 of `daq` at seeded random moments mid-run, and
the Zenoh router gone and back while `daq` records.

The kill trials are `tools/faultkit.py`'s (the benchmark `tools/bench_faults.py` runs 20+
of them); three run here, concurrently. The router is `tools/zenoh_router.py` in its own
process, killed with SIGKILL and started again on the same port.
"""

from __future__ import annotations

import queue
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import zenoh
from zenoh import ext

from daq.run_file import load_run
from schemas import keys
from schemas.bus import BusConfig
from schemas.daq import RunFinished
from testkit.faultkit import PERIOD_NS, RATE_HZ, daq_process, kill9_trials
from testkit.ports import endpoint as free_endpoint
from testkit.repo import REPO
from testkit.waiting import wait_until


def test_kill_9_at_random_moments_loses_at_most_half_a_second_and_restart_recovers(tmp_path: Path) -> None:
    results = kill9_trials(tmp_path, n=3, seed=6, parallel=3, max_after_s=3.0)
    for result in results:
        assert result.samples_before_kill > 0, result
        assert result.holes == 0, result
        assert result.lost_s <= 0.5, result   # negative: the file is ahead of what reached the bus
        assert result.recovered, result
    # The moments really differ (seeded, not hand-picked).
    assert len({r.kill_after_s for r in results}) == 3


def _start_router(endpoint: str, log: Path) -> subprocess.Popen[bytes]:
    proc = subprocess.Popen([sys.executable, str(REPO / "tools" / "zenoh_router.py"), "--listen", endpoint],
                            cwd=REPO, stdout=log.open("wb"), stderr=subprocess.STDOUT)
    wait_until(lambda: "listening on" in log.read_text(errors="replace"), 30, "the router to listen", proc)
    return proc


def _client(endpoint: str) -> zenoh.Session:
    return zenoh.open(zenoh.Config.from_json5(BusConfig(mode="client", listen=[], connect=[endpoint]).zenoh_json5()))


def test_daq_keeps_recording_while_the_router_is_gone_and_announces_the_run_when_it_is_back(
        tmp_path: Path) -> None:
    router_ep = free_endpoint()
    runs = tmp_path / "runs"
    router = _start_router(router_ep, tmp_path / "router1.log")
    sim = (f"sim://?realtime=1&rate_hz={RATE_HZ}&cases=cart1&seed=12&rest_s=0.3&pull_s=0.4&hold_s=0.7&c1=2"
           "&tail_s=30")
    daq = daq_process(["run", "--port", sim, "--bench", "rb", "--runs-dir", str(runs), "--mode", "peer",
                       "--connect", router_ep], tmp_path / "daq.log")
    router2: subprocess.Popen[bytes] | None = None
    try:
        viewer = _client(router_ep)
        live: queue.SimpleQueue[bytes] = queue.SimpleQueue()
        sub = viewer.declare_subscriber(keys.samples("rb"), lambda s: live.put(s.payload.to_bytes()))
        wait_until(lambda: not live.empty(), 60, "live samples through the router", daq)
        wait_until(lambda: bool(list(runs.glob("*.mcap.part"))), 60, "the run to start", daq)
        sub.undeclare()
        viewer.close()
        # The router dies mid-run; the run ends while it is gone.
        router.send_signal(signal.SIGKILL)
        router.wait(timeout=10)
        wait_until(lambda: bool(list(runs.glob("*.mcap"))), 60, "the run to finish without the router", daq)
        router2 = _start_router(router_ep, tmp_path / "router2.log")
        # A subscriber that joins after the router is back still gets the run's finished record.
        viewer = _client(router_ep)
        announced: queue.SimpleQueue[bytes] = queue.SimpleQueue()
        late = ext.declare_advanced_subscriber(
            viewer, keys.ALL_FINISHED, lambda s: announced.put(s.payload.to_bytes()),
            history=ext.HistoryConfig(detect_late_publishers=True),
            recovery=ext.RecoveryConfig(heartbeat=True))
        wait_until(lambda: not announced.empty(), 30, "the finished record after the router came back", daq)
        finished = RunFinished.from_json_bytes(announced.get())
        late.undeclare()
        viewer.close()
        assert daq.poll() is None, "daq must keep running through the router's absence"
    finally:
        for proc in (daq, router, router2):
            if proc is not None and proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
                try:
                    proc.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    proc.kill()
    run = load_run(runs / finished.file)
    assert finished.status == "complete" and run.complete
    assert run.t_ns.size == finished.n_samples > RATE_HZ
    assert np.all(np.diff(run.t_ns) == PERIOD_NS), "samples missing from the run while the router was gone"
    assert run.metadata is not None and run.metadata.counters.lost_frames == 0
