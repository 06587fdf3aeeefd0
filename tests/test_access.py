"""Access: who may join the bus and who may publish what (issue 6, part 5). The default
configuration is checked in `tests/test_access_defaults.py`, TLS in `tests/test_access_tls.py`.

A real Zenoh router (`testkit.zenoh_router`, as `tools/zenoh_router.py` runs it, router mode in
this process) on an ephemeral
loopback port runs the shipped `tools/zenoh/router-secure.json5` with a credentials file
written here; clients use the shipped `tools/zenoh/*-client.json5` with the endpoint and
password replaced. Denials are checked with an ordering argument, never a sleep: a client's
forbidden put is followed by an allowed put on the same session (one link, reliable, in
order), so once a subscriber holds the allowed sample, the forbidden one would already be
there had the router forwarded it.
"""

from __future__ import annotations

import contextlib
import json
import queue
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
import zenoh
import zenoh.ext

from daq.bus import DaqBus
from ident.worker.bus import BusEvent, WorkerBus
from schemas import keys
from schemas.bus import BusConfig
from schemas.daq import DaqCounters, DaqStatus, RunFinished, RunList, ZeroReply
from schemas.fit import FitReport
from testkit import ports, zenoh_router
from testkit.secure_bus import (
    PASSWORDS,
    REFUSE_MS,
    WAIT_S,
    Inbox,
    Router,
    client_file,
    put_until_received,
)
from testkit.zenoh_router import DAQ_CLIENT, IDENT_CLIENT, SECURE_ROUTER, VIEWER_CLIENT, client_config


@pytest.fixture(scope="module")
def router(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Router]:
    credentials = tmp_path_factory.mktemp("zenoh") / "credentials.txt"
    credentials.write_text("".join(f"{user}:{pw}\n" for user, pw in PASSWORDS.items()))
    hub = Router(ports.endpoint(), credentials)
    try:
        yield hub
    finally:
        hub.close()


# --- authentication ---------------------------------------------------------------------------


@pytest.mark.parametrize(("user", "password"), [(None, None), ("ident", "wrong"), ("stranger", "pw")],
                         ids=["no-credentials", "wrong-password", "unknown-user"])
def test_a_client_without_valid_credentials_is_refused(router: Router, user: str | None,
                                                       password: str | None) -> None:
    if user is None:
        config = zenoh.Config.from_json5(json.dumps({
            "mode": "client", "connect": {"endpoints": [router.endpoint], "timeout_ms": REFUSE_MS,
                                          "exit_on_failure": True},
            "scouting": {"multicast": {"enabled": False}, "gossip": {"enabled": False}}}))
    else:
        config = client_config(VIEWER_CLIENT, connect=[router.endpoint], user=user, password=password,
                               fail_after_ms=REFUSE_MS)
    with pytest.raises(zenoh.ZError, match="Unable to connect"):
        zenoh.open(config)


def test_a_refused_peer_that_keeps_retrying_reaches_no_one(router: Router) -> None:
    """A client's open raises at once when refused (above); a peer's open returns and the
    peer retries in the background, but it stays alone: no router, no traffic."""
    config = client_config(DAQ_CLIENT, connect=[router.endpoint], user="daq-bench1", password="wrong")
    assert json.loads(config.get_json("mode")) == "peer"
    viewer = router.client("viewer")
    inbox = Inbox()
    router.keep(viewer.declare_subscriber("cartlab/**", inbox))
    daq = router.client("daq-bench1")
    with zenoh.open(config) as intruder:
        intruder.put(keys.samples("bench1"), "intruder")
        # A legitimate sample sent after the intruder's is received; the intruder's never was.
        seen = put_until_received(daq, inbox, keys.samples("bench1"), "legit",
                                   before=lambda: intruder.put(keys.samples("bench1"), "intruder"))
        assert list(intruder.info.routers_zid()) == []
        assert list(intruder.info.peers_zid()) == []
    assert all(payload != "intruder" for _, payload in seen)


# --- authorization ------------------------------------------------------------------------------


def test_ident_cannot_publish_run_records_but_can_publish_fits(router: Router) -> None:
    viewer = router.client("viewer")
    inbox = Inbox()
    router.keep(viewer.declare_subscriber("cartlab/**", inbox))
    ident = router.client("ident")
    forged = keys.run_finished("bench1", "r1")
    fit = keys.run_fit("bench1", "r1")
    seen = put_until_received(ident, inbox, fit, "fit",
                               before=lambda: (ident.put(forged, "forged"),
                                               ident.put(keys.samples("bench1"), "forged"),
                                               ident.put(keys.state("bench1"), "forged")))
    assert [k for k, p in seen if p == "forged"] == []
    assert any(k == fit for k, _ in seen)


def test_daq_publishes_only_under_its_own_bench(router: Router) -> None:
    viewer = router.client("viewer")
    inbox = Inbox()
    router.keep(viewer.declare_subscriber("cartlab/**", inbox))
    daq = router.client("daq-bench1")
    own = keys.run_finished("bench1", "r2")
    seen = put_until_received(daq, inbox, own, "own",
                               before=lambda: (daq.put(keys.run_finished("bench2", "r2"), "forged"),
                                               daq.put(keys.samples("bench2"), "forged"),
                                               daq.put("cartlab/ident/w1", "forged"),
                                               daq.put("elsewhere/x", "forged")))
    assert [k for k, p in seen if p == "forged"] == []
    assert any(k == own for k, _ in seen)


def test_a_viewer_publishes_nothing(router: Router) -> None:
    listener = router.client("ident")
    inbox = Inbox()
    router.keep(listener.declare_subscriber("cartlab/**", inbox))
    viewer = router.client("viewer")
    daq = router.client("daq-bench1")
    for key in (keys.samples("bench1"), keys.run_finished("bench1", "r3"), keys.run_fit("bench1", "r3")):
        viewer.put(key, "forged")
    seen = put_until_received(daq, inbox, keys.state("bench1"), "legit")
    # Ordering holds per sender only: give the viewer's puts a second chance to show up, by
    # round-tripping a query through the router from the viewer's own session.
    list(viewer.get(keys.daq_query("bench1", "status"), timeout=0.5))
    while not inbox.queue.empty():
        seen.append(inbox.queue.get_nowait())
    assert [k for k, p in seen if p == "forged"] == []


def test_no_one_but_the_bench_daq_can_serve_its_queries_or_claim_its_liveliness(router: Router) -> None:
    ident = router.client("ident")
    other_daq = router.client("daq-bench2", config_file=DAQ_CLIENT)
    viewer = router.client("viewer")
    status = keys.daq_query("bench1", "status")

    def forged_reply(query: zenoh.Query) -> None:
        query.reply(query.key_expr, "forged")

    router.keep(ident.declare_queryable(status, forged_reply))
    router.keep(other_daq.declare_queryable(status, forged_reply))
    router.keep(ident.liveliness().declare_token(keys.daq_alive("bench1")))
    router.keep(other_daq.liveliness().declare_token(keys.daq_alive("bench1")))
    # The legitimate bench2 daq, on the same session, is seen: declarations do get through.
    router.keep(other_daq.liveliness().declare_token(keys.daq_alive("bench2")))
    deadline = time.monotonic() + WAIT_S
    alive: set[str] = set()
    while keys.daq_alive("bench2") not in alive and time.monotonic() < deadline:
        alive = {str(r.ok.key_expr) for r in viewer.liveliness().get(keys.ALL_DAQ_ALIVE, timeout=1.0)
                 if r.ok is not None}
    assert keys.daq_alive("bench2") in alive
    assert keys.daq_alive("bench1") not in alive
    replies = list(viewer.get(status, timeout=1.0))
    assert [r.ok.payload.to_string() for r in replies if r.ok is not None] == []


def test_the_allowed_flows_of_a_bench_work_through_the_secure_router(router: Router, tmp_path: Path) -> None:
    """daq (real `DaqBus`): samples, status, finished for a late joiner; ident: fit reports."""
    daq_session = router.client("daq-bench1")
    bus = DaqBus("bench1", BusConfig(), session=daq_session)
    try:
        finished = RunFinished(bench="bench1", run_id="r10", status="complete", file="r10.mcap",
                               n_samples=10, release_time_s=0.5, duration_s=2.0)
        bus.publish_finished(finished)
        status = DaqStatus(bench="bench1", state="idle", run_id=None, port="sim://", dialect="cartlab",
                           connected=True, counts_per_m=1e4, zero_offsets_raw=[0.0, 0.0], last_t_ns=None,
                           last_pos_m=None, n_runs=1, counters=DaqCounters(), software_version="test")
        bus.set_snapshot(status, RunList(bench="bench1", runs=[finished]))
        # A late joiner (after the put) still receives the finished record.
        viewer = router.client("viewer")
        late = Inbox()
        router.keep(zenoh.ext.declare_advanced_subscriber(
            viewer, keys.ALL_FINISHED, late,
            history=zenoh.ext.HistoryConfig(detect_late_publishers=True, max_samples=8),
            recovery=zenoh.ext.RecoveryConfig(heartbeat=True)))
        late.wait_for(keys.run_finished("bench1", "r10"), finished.model_dump_json())
        replies = [r.ok for r in viewer.get(keys.daq_query("bench1", "status"), timeout=WAIT_S)
                   if r.ok is not None]
        assert [DaqStatus.from_json_bytes(r.payload.to_bytes()) for r in replies] == [status]
        catch_up = [r.ok for r in viewer.get(keys.ALL_FINISHED, timeout=WAIT_S) if r.ok is not None]
        assert [RunFinished.from_json_bytes(r.payload.to_bytes()) for r in catch_up] == [finished]
        live = Inbox()
        router.keep(viewer.declare_subscriber(keys.samples("bench1"), live))
        deadline = time.monotonic() + WAIT_S
        while not live.seen and time.monotonic() < deadline:
            bus.publish_samples(b"{}")
            with contextlib.suppress(queue.Empty):
                live.seen.append(live.queue.get(timeout=0.1))
        assert live.seen and live.seen[0][0] == keys.samples("bench1")
        # ident (real `WorkerBus`): its cached fit publisher, received by a late subscriber,
        # and its liveliness token.
        ident_file = tmp_path / "ident.json5"
        ident_file.write_text(IDENT_CLIENT.read_text().replace("tcp/127.0.0.1:7447", router.endpoint)
                              .replace("change-me-ident", PASSWORDS["ident"]))
        events: queue.Queue[BusEvent] = queue.Queue()
        with WorkerBus(BusConfig(config_file=str(ident_file)), "w1", events) as worker:
            worker.declare_alive()
            report = FitReport(bench="bench1", run_id="r10", worker="w1", status="failed", reason="test")
            worker.publish_fit(report)
            fits = Inbox()
            router.keep(zenoh.ext.declare_advanced_subscriber(
                viewer, keys.ALL_FITS, fits,
                history=zenoh.ext.HistoryConfig(detect_late_publishers=True, max_samples=8)))
            fits.wait_for(keys.run_fit("bench1", "r10"), report.model_dump_json())
            assert worker.list_runs("bench1", timeout_s=WAIT_S) == RunList(bench="bench1", runs=[finished])
            deadline = time.monotonic() + WAIT_S
            workers: set[str] = set()
            while keys.ident_alive("w1") not in workers and time.monotonic() < deadline:
                workers = {str(r.ok.key_expr) for r in viewer.liveliness().get(keys.ALL_IDENT_ALIVE, timeout=1.0)
                           if r.ok is not None}
            assert keys.ident_alive("w1") in workers
            # The worker's advanced subscriber catches up with the finished record too.
            kinds: list[str] = []
            deadline = time.monotonic() + WAIT_S
            while "finished" not in kinds and time.monotonic() < deadline:
                with contextlib.suppress(queue.Empty):
                    kinds.append(events.get(timeout=0.1).kind)
            assert "finished" in kinds
    finally:
        bus.close()


def test_only_an_operator_can_zero_or_arm_a_bench(router: Router) -> None:
    """`zero` and `arm` act on the bench: ident and viewers may not query them, not even
    through a wildcard; an operator may. A request reaching the daq lands on its queue."""
    daq_session = router.client("daq-bench1")
    bus = DaqBus("bench1", BusConfig(), session=daq_session)
    try:
        status = DaqStatus(bench="bench1", state="idle", run_id=None, port="sim://", dialect="cartlab",
                           connected=True, counts_per_m=1e4, zero_offsets_raw=[0.0], last_t_ns=None,
                           last_pos_m=None, n_runs=0, counters=DaqCounters(), software_version="test")
        bus.set_snapshot(status, RunList(bench="bench1", runs=[]))
        for user in ("viewer", "ident"):
            session = router.client(user)
            # The read-only queryable answers this user (so the daq is reachable) ...
            deadline = time.monotonic() + WAIT_S
            while not [r for r in session.get(keys.daq_query("bench1", "status"), timeout=1.0) if r.ok]:
                assert time.monotonic() < deadline, f"{user}: no status reply"
            # ... but zero and arm, named or through a wildcard, never reach it.
            for selector in (keys.daq_query("bench1", "zero"), keys.daq_query("bench1", "arm"),
                             keys.daq_queries("bench1"), "cartlab/bench1/**"):
                replies = list(session.get(selector, timeout=0.5))
                assert [r for r in replies if r.ok is not None and b"zero_offsets_raw" in r.ok.payload.to_bytes()
                        and b'"ok"' in r.ok.payload.to_bytes()] == []
            assert bus.requests.empty(), f"{user} reached {bus.requests.get_nowait().kind}"
        operator = router.client("operator")
        replies = operator.get(keys.daq_query("bench1", "zero"), timeout=WAIT_S)
        request = bus.requests.get(timeout=WAIT_S)
        assert request.kind == "zero"
        DaqBus.reply_record(request, ZeroReply(bench="bench1", ok=True, zero_offsets_raw=[12.0]))
        answers = [ZeroReply.from_json_bytes(r.ok.payload.to_bytes()) for r in replies if r.ok is not None]
        assert answers == [ZeroReply(bench="bench1", ok=True, zero_offsets_raw=[12.0])]
    finally:
        bus.close()


def test_router_main_rejects_missing_files(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert zenoh_router.main(["--config", str(tmp_path / "absent.json5")]) == 2
    assert "expected an existing JSON5 file" in capsys.readouterr().err
    assert zenoh_router.main(["--config", str(SECURE_ROUTER), "--credentials", str(tmp_path / "none")]) == 2


def test_real_daq_and_worker_processes_run_a_bench_through_the_secure_router(router: Router, tmp_path: Path) -> None:
    """`daq run` and `ident worker` with the shipped client configs: the run is announced,
    fetched over Zenoh by the worker (its runs directory is empty) and its fit published."""
    repo = Path(__file__).resolve().parents[1]
    daq_conf = client_file(DAQ_CLIENT, tmp_path / "daq.json5", router.endpoint, "daq-bench1")
    ident_conf = client_file(IDENT_CLIENT, tmp_path / "ident.json5", router.endpoint, "ident")
    viewer = router.client("viewer")
    fits = Inbox()
    router.keep(zenoh.ext.declare_advanced_subscriber(
        viewer, keys.ALL_FITS, fits, history=zenoh.ext.HistoryConfig(detect_late_publishers=True, max_samples=8)))
    sim = "sim://?realtime=0&rate_hz=100&cases=cart1&seed=3&rest_s=0.3&pull_s=0.5&hold_s=0.8&c1=3&tail_s=0.3"
    logs = [(tmp_path / name).open("wb") for name in ("worker.log", "daq.log")]
    worker = subprocess.Popen([sys.executable, "-m", "ident.cli", "worker", "--name", "w-secure", "--runs-dir",
                               str(tmp_path / "worker-runs"), "--zenoh-config", str(ident_conf),
                               "--fitter", "tests.ident.test_worker_abuse:stand_in_fit"],
                              cwd=repo, stdout=logs[0], stderr=subprocess.STDOUT)
    daq = subprocess.Popen([sys.executable, "-m", "daq.cli", "run", "--port", sim, "--bench", "bench1",
                            "--runs-dir", str(tmp_path / "daq-runs"), "--zenoh-config", str(daq_conf)],
                           cwd=repo, stdout=logs[1], stderr=subprocess.STDOUT)
    try:
        deadline = time.monotonic() + 60
        report = None
        while report is None:
            for proc, name in ((worker, "worker"), (daq, "daq")):
                assert proc.poll() is None, f"{name} exited: {(tmp_path / f'{name}.log').read_text()[-2000:]}"
            assert time.monotonic() < deadline, "no fit report through the secure router within 60 s"
            try:
                key, payload = fits.queue.get(timeout=0.2)
            except queue.Empty:
                continue
            candidate = FitReport.model_validate_json(payload)
            report = candidate if candidate.final else None
        run_file = next((tmp_path / "daq-runs").glob("*.mcap"))
        assert key == keys.run_fit("bench1", report.run_id) and report.status == "ok"
        assert report.worker == "w-secure" and report.extra == {"bytes": run_file.stat().st_size}
    finally:
        for proc in (daq, worker):
            proc.terminate()
            try:
                proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                proc.kill()
        for log in logs:
            log.close()
