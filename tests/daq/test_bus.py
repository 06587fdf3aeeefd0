"""`daq run` on a real-time `sim://` rig seen from other processes over Zenoh (loopback, ephemeral port)."""

from __future__ import annotations

import queue
import signal
import subprocess
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest
import zenoh
from zenoh import ext

from schemas import keys
from schemas.bus import BusConfig
from schemas.daq import DaqStatus, RunFinished, RunList, SampleBatch, ZeroReply
from testkit import ports
from testkit.daq_process import start_daq
from testkit.waiting import wait_until

BENCH = "e2e"
SIM = ("sim://?realtime=1&rate_hz=100&cases=cart1&seed=9&rest_s=0.3&pull_s=0.5&hold_s=0.8&c1=4&c2=4"
       "&tail_s=1")


@dataclass
class Live:
    proc: subprocess.Popen[bytes]
    endpoint: str
    runs_dir: Path
    session: zenoh.Session
    samples: queue.SimpleQueue[SampleBatch]
    finished: queue.SimpleQueue[RunFinished]


def _history_subscriber(session: zenoh.Session, sink: queue.SimpleQueue[RunFinished]) -> ext.AdvancedSubscriber:
    return ext.declare_advanced_subscriber(
        session, keys.ALL_FINISHED, lambda s: sink.put(RunFinished.from_json_bytes(s.payload.to_bytes())),
        history=ext.HistoryConfig(detect_late_publishers=True),
        recovery=ext.RecoveryConfig(periodic_queries=None, heartbeat=True))


@pytest.fixture(scope="module")
def live(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Live]:
    root = tmp_path_factory.mktemp("bus")
    endpoint = ports.endpoint()
    proc = start_daq("run", "--port", SIM, "--bench", BENCH, "--runs-dir", str(root / "runs"),
                     "--listen", endpoint, log_path=root / "daq.log")
    session = zenoh.open(zenoh.Config.from_json5(BusConfig.connector(endpoint).zenoh_json5()))
    samples: queue.SimpleQueue[SampleBatch] = queue.SimpleQueue()
    finished: queue.SimpleQueue[RunFinished] = queue.SimpleQueue()
    handles = []
    try:
        handles.append(session.declare_subscriber(
            keys.samples(BENCH), lambda s: samples.put(SampleBatch.from_json_bytes(s.payload.to_bytes()))))
        handles.append(_history_subscriber(session, finished))
        yield Live(proc, endpoint, root / "runs", session, samples, finished)
    finally:
        for handle in handles:
            handle.undeclare()
        session.close()
        if proc.poll() is None:
            proc.kill()
        proc.wait(timeout=10)


@pytest.fixture(scope="module")
def first_run(live: Live) -> RunFinished:
    try:
        return live.finished.get(timeout=40)
    except queue.Empty:
        log = (live.runs_dir.parent / "daq.log").read_text()
        raise AssertionError("no finished record within 40 s: " + log) from None


def test_a_subscriber_in_another_process_gets_samples_and_the_finished_record(live: Live,
                                                                             first_run: RunFinished) -> None:
    assert first_run.bench == BENCH and first_run.status == "complete"
    assert (live.runs_dir / first_run.file).is_file()
    batches = []
    while not live.samples.empty():
        batches.append(live.samples.get())
    assert len(batches) > 50
    t_ns = [t for b in batches for t in b.t_ns]
    assert t_ns == sorted(t_ns)
    in_run = [b for b in batches if b.run_id == first_run.run_id]
    assert in_run and all(b.pos2_m is not None for b in in_run)


def test_a_late_joiner_still_gets_the_finished_record(live: Live, first_run: RunFinished) -> None:
    late: queue.SimpleQueue[RunFinished] = queue.SimpleQueue()
    session = zenoh.open(zenoh.Config.from_json5(BusConfig.connector(live.endpoint).zenoh_json5()))
    try:
        sub = _history_subscriber(session, late)
        try:
            assert late.get(timeout=10) == first_run
        finally:
            sub.undeclare()
        # the same record also answers a plain get on the finished keys
        replies = list(session.get(keys.ALL_FINISHED, timeout=5))
        assert [RunFinished.from_json_bytes(r.ok.payload.to_bytes()) for r in replies if r.ok] == [first_run]
    finally:
        session.close()


def _get(session: zenoh.Session, selector: str) -> list[zenoh.Reply]:
    return list(session.get(selector, timeout=5))


def test_queryables_answer_from_the_service(live: Live, first_run: RunFinished) -> None:
    s = live.session
    (status,) = _get(s, keys.daq_query(BENCH, "status"))
    assert status.ok is not None
    snapshot = DaqStatus.from_json_bytes(status.ok.payload.to_bytes())
    assert snapshot.bench == BENCH and snapshot.n_runs == 1 and snapshot.counts_per_m == 20000.0
    (runs,) = _get(s, keys.daq_query(BENCH, "runs"))
    assert runs.ok is not None
    assert RunList.from_json_bytes(runs.ok.payload.to_bytes()).runs == [first_run]
    (run,) = _get(s, keys.daq_query(BENCH, "run") + f"?id={first_run.run_id}")
    assert run.ok is not None
    assert run.ok.payload.to_bytes() == (live.runs_dir / first_run.file).read_bytes()
    (zero,) = _get(s, keys.daq_query(BENCH, "zero"))
    assert zero.ok is not None and ZeroReply.from_json_bytes(zero.ok.payload.to_bytes()).ok
    (arm,) = _get(s, keys.daq_query(BENCH, "arm"))
    assert arm.ok is not None and DaqStatus.from_json_bytes(arm.ok.payload.to_bytes()).state == "armed"


@pytest.mark.parametrize("bad_id", ["..", "../../etc/passwd", "nope", ".hidden", ""])
def test_bad_run_ids_are_refused(live: Live, first_run: RunFinished, bad_id: str) -> None:
    (reply,) = _get(live.session, keys.daq_query(BENCH, "run") + f"?id={bad_id}")
    assert reply.ok is None and reply.err is not None
    assert "expected" in reply.err.payload.to_string()


def test_liveliness_token_then_clean_exit_on_sigterm(live: Live, first_run: RunFinished) -> None:
    alive = [str(r.ok.key_expr) for r in live.session.liveliness().get(keys.ALL_DAQ_ALIVE, timeout=5) if r.ok]
    assert alive == [keys.daq_alive(BENCH)]
    live.proc.send_signal(signal.SIGTERM)
    assert live.proc.wait(timeout=20) == 0
    wait_until(lambda: not list(live.session.liveliness().get(keys.ALL_DAQ_ALIVE, timeout=1)), 10,
             "the liveliness token to go")
