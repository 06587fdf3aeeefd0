"""kill -9 of `daq` mid-run: at most 0.5 s of samples lost, the file recovered on restart."""

from __future__ import annotations

import queue
import signal
from pathlib import Path

import numpy as np
import zenoh
from zenoh import ext

from daq.run_file import load_run
from schemas import keys
from schemas.bus import BusConfig
from schemas.daq import RunFinished, SampleBatch
from testkit import ports
from testkit.daq_process import start_daq
from testkit.waiting import wait_until

BENCH = "crash"
RATE_HZ = 200
# light damping: the carts ring for many seconds, so the kill lands mid-run
SIM = f"sim://?realtime=1&rate_hz={RATE_HZ}&cases=cart1&seed=4&rest_s=0.3&pull_s=0.5&hold_s=0.8"


def _connect(endpoint: str) -> zenoh.Session:
    return zenoh.open(zenoh.Config.from_json5(BusConfig.connector(endpoint).zenoh_json5()))


def test_kill_9_loses_at_most_half_a_second_and_restart_recovers(tmp_path: Path) -> None:
    runs = tmp_path / "runs"
    endpoint = ports.endpoint()
    proc = start_daq("run", "--port", SIM, "--bench", BENCH, "--runs-dir", str(runs), "--listen", endpoint,
                     log_path=tmp_path / "daq1.log")
    live_t: queue.SimpleQueue[int] = queue.SimpleQueue()
    latest = [0]

    def on_sample(sample: zenoh.Sample) -> None:
        t_last = SampleBatch.from_json_bytes(sample.payload.to_bytes()).t_ns[-1]
        latest[0] = max(latest[0], t_last)
        live_t.put(t_last)

    session = _connect(endpoint)
    try:
        sub = session.declare_subscriber(keys.samples(BENCH), on_sample)
        part = wait_until(lambda: list(runs.glob("*.mcap.part")), 30, "a run file to be opened")[0]
        start_size = part.stat().st_size
        wait_until(lambda: part.stat().st_size > start_size + 20_000, 30, "the run file to grow")
        # growth is seen right after a flush: let 0.15 s more of samples go out so the kill
        # lands between flushes, not just after one
        grown_at = latest[0]
        wait_until(lambda: latest[0] >= grown_at + 150_000_000, 10, "0.15 s more of live samples")
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)
        wait_until(lambda: not list(session.liveliness().get(keys.ALL_DAQ_ALIVE, timeout=1)), 10,
                 "the killed daq's token to go")   # everything sent before the kill has arrived
        sub.undeclare()
    finally:
        session.close()
        if proc.poll() is None:
            proc.kill()
    last_published = max(live_t.get() for _ in range(live_t.qsize()))
    salvaged = load_run(part)
    assert not salvaged.complete
    lost_s = (last_published - int(salvaged.t_ns[-1])) / 1e9
    print(f"lost {lost_s:.3f} s")
    assert 0 <= lost_s <= 0.5
    assert np.all(np.diff(salvaged.t_ns) == 1_000_000_000 // RATE_HZ)   # nothing missing inside

    restart_endpoint = ports.endpoint()
    proc2 = start_daq("run", "--port", "sim://?realtime=0&cases=none&duration_s=0.2", "--bench", BENCH,
                      "--runs-dir", str(runs), "--listen", restart_endpoint, log_path=tmp_path / "daq2.log")
    session = _connect(restart_endpoint)
    announced: queue.SimpleQueue[RunFinished] = queue.SimpleQueue()
    try:
        sub2 = ext.declare_advanced_subscriber(
            session, keys.ALL_FINISHED, lambda s: announced.put(RunFinished.from_json_bytes(s.payload.to_bytes())),
            history=ext.HistoryConfig(detect_late_publishers=True))
        record = announced.get(timeout=20)
        sub2.undeclare()
        proc2.send_signal(signal.SIGTERM)
        assert proc2.wait(timeout=20) == 0
    finally:
        session.close()
        if proc2.poll() is None:
            proc2.kill()
    assert record.status == "recovered" and record.n_samples == salvaged.t_ns.size
    assert not part.exists()
    recovered = load_run(runs / record.file)
    assert recovered.complete and recovered.t_ns.tolist() == salvaged.t_ns.tolist()
    assert recovered.finished == record
    assert recovered.release_time_s is not None and 0.5 <= recovered.release_time_s < 0.5 + 1 / RATE_HZ


def test_sigint_mid_run_finishes_the_run_file(tmp_path: Path) -> None:
    runs = tmp_path / "runs"
    proc = start_daq("run", "--port", SIM, "--bench", BENCH, "--runs-dir", str(runs), "--no-zenoh",
                     log_path=tmp_path / "daq.log")
    try:
        wait_until(lambda: bool(list(runs.glob("*.mcap.part"))), 30, "a run file to be opened")
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=20) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
    assert not list(runs.glob("*.part"))
    (path,) = runs.glob("*.mcap")
    run = load_run(path)
    assert run.complete and run.finished is not None
    assert run.finished.status == "aborted" and run.finished.reason == "stopped by signal"
    assert run.finished.n_samples == run.t_ns.size > 0.5 * RATE_HZ
