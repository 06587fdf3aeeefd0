"""Abuse of a running `daq` over Zenoh: malformed and oversized payloads on every queryable,
run ids that try to walk out of the runs directory (issue 6, part 4).

One `daq` service runs in this process (thread) on a `sim://` rig (as fast as possible,
one run) with an embedded peer on an ephemeral loopback port; a second session plays the
attacker. After every kind of abuse a valid request must still be answered, and no reply
may carry the bytes of a file outside the runs directory.
"""

from __future__ import annotations

import logging
import os
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest
import zenoh

from daq.service import Service, ServiceConfig
from schemas import keys
from schemas.bus import BusConfig
from schemas.daq import DaqStatus, RunList, ZeroReply
from testkit import ports
from testkit.waiting import wait_until

BENCH = "abuse"
SIM = ("sim://?realtime=0&rate_hz=100&cases=cart1&seed=5&rest_s=0.3&pull_s=0.5&hold_s=0.8&c1=3"
       "&tail_s=0.5")
SECRET = b"secret bytes outside the runs directory"
REPLY_S = 5.0


@dataclass
class Running:
    service: Service
    runs_dir: Path
    secret: Path
    session: zenoh.Session
    run_id: str


def _ok_payloads(session: zenoh.Session, selector: str, payload: bytes | None = None) -> tuple[list[bytes], list[str]]:
    oks, errs = [], []
    for reply in session.get(selector, payload=payload, timeout=REPLY_S):
        if reply.ok is not None:
            oks.append(reply.ok.payload.to_bytes())
        else:
            errs.append(reply.err.payload.to_bytes().decode(errors="replace"))
    return oks, errs


@pytest.fixture(scope="module")
def running(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Running]:
    root = tmp_path_factory.mktemp("abuse")
    runs_dir = root / "runs"
    secret = root / "secret.mcap"
    secret.write_bytes(SECRET)
    endpoint = ports.endpoint()
    service = Service(ServiceConfig(port=SIM, runs_dir=runs_dir, bench=BENCH, bus=BusConfig.listener(endpoint)))
    errors: list[BaseException] = []

    def serve() -> None:
        try:
            service.run()
        except BaseException as exc:  # noqa: BLE001 - reported by the test
            errors.append(exc)

    thread = threading.Thread(target=serve, name="daq-service", daemon=True)
    thread.start()
    session = zenoh.open(zenoh.Config.from_json5(BusConfig.connector(endpoint).zenoh_json5()))
    try:
        def listed() -> RunList | None:
            assert not errors and thread.is_alive(), f"daq service died: {errors}"
            oks, _ = _ok_payloads(session, keys.daq_query(BENCH, "runs"))
            found = RunList.from_json_bytes(oks[0]) if oks else None
            return found if found is not None and found.runs else None

        runs = wait_until(listed, 60, "a finished run listed by the daq", poll_s=0.05)
        # A symlink inside the runs directory that points outside it.
        os.symlink(secret, runs_dir / "escape.mcap")
        yield Running(service, runs_dir, secret, session, runs.runs[0].run_id)
    finally:
        session.close()
        service.request_stop()
        thread.join(timeout=20)
    assert not thread.is_alive(), "daq service did not stop"
    assert errors == []


def _assert_still_serving(running: Running) -> None:
    oks, errs = _ok_payloads(running.session, keys.daq_query(BENCH, "status"))
    assert errs == [] and len(oks) == 1
    assert DaqStatus.from_json_bytes(oks[0]).bench == BENCH
    assert running.service.bus is not None


GARBAGE = [b"", b"\xff\xfe\xfd", b"{", b'{"id": "../secret"}', b"\x00" * 100, os.urandom(4096),
           b"x" * (5 * 1024 * 1024)]


@pytest.mark.parametrize("query", ["status", "runs", "zero", "arm"])
def test_garbage_payloads_on_each_queryable_get_a_normal_answer(running: Running, query: str) -> None:
    for payload in GARBAGE:
        oks, errs = _ok_payloads(running.session, f"{keys.daq_query(BENCH, query)}?x=%00&&=&id=..",  # type: ignore[arg-type]
                                 payload)
        assert len(oks) == 1 and errs == [], (query, payload[:20])
        record = {"status": DaqStatus, "runs": RunList, "zero": ZeroReply, "arm": DaqStatus}[query]
        assert record.from_json_bytes(oks[0]).bench == BENCH
    _assert_still_serving(running)


BAD_RUN_IDS = ["..", ".", "../secret", "..%2fsecret", "%2e%2e%2fsecret", "%2e%2e", "/etc/passwd",
               "secret\x00", "a/b", "", " ", "*", "**", "escape", "x" * 10_000, "../runs/../secret",
               "-rf", "\u202e" + "secret"]


def test_run_ids_that_walk_out_of_the_runs_directory_are_refused(running: Running,
                                                                 caplog: pytest.LogCaptureFixture) -> None:
    absolute = str(running.secret.with_suffix(""))
    for run_id in [*BAD_RUN_IDS, absolute]:
        for selector, payload in ((f"{keys.daq_query(BENCH, 'run')}?id={run_id}", None),
                                  (keys.daq_query(BENCH, "run"), run_id.encode())):
            try:
                oks, errs = _ok_payloads(running.session, selector, payload)
            except zenoh.ZError:
                continue   # Zenoh itself refused the selector: nothing reached the daq
            assert oks == [], (run_id, [o[:40] for o in oks])
            assert all(SECRET not in o for o in oks)
            assert len(errs) == 1 and "expected" in errs[0], (run_id, errs)
    _assert_still_serving(running)
    # The legitimate id still works and returns exactly the file.
    oks, errs = _ok_payloads(running.session, f"{keys.daq_query(BENCH, 'run')}?id={running.run_id}")
    assert errs == [] and oks == [(running.runs_dir / f"{running.run_id}.mcap").read_bytes()]


def test_an_undecodable_run_id_payload_is_answered_with_an_error(running: Running) -> None:
    oks, errs = _ok_payloads(running.session, keys.daq_query(BENCH, "run"), b"\xff\xfe")
    assert oks == []
    assert len(errs) == 1, "expected an error reply, got no reply at all (the Zenoh callback raised?)"
    _assert_still_serving(running)


def test_a_refused_run_request_is_logged_with_its_reason(running: Running, caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.INFO, logger="daq"):
        _, errs = _ok_payloads(running.session, f"{keys.daq_query(BENCH, 'run')}?id=../secret")
    assert errs
    assert any("secret" in r.getMessage() for r in caplog.records), \
        "expected the daq to log the refused request with its reason, got no log record"


def test_wildcard_queries_get_only_well_formed_answers(running: Running) -> None:
    for selector in (keys.ALL_FINISHED, f"cartlab/{BENCH}/runs/**", f"cartlab/{BENCH}/runs/nonexistent/finished"):
        oks, errs = _ok_payloads(running.session, selector)
        assert errs == []
        assert all(b'"run_id"' in o for o in oks)
    # `cartlab/**` reaches every queryable at once (zero and arm included: a wildcard query
    # acts on the bench): each answers or refuses in its own way (`run` without an id refuses
    # with its reason).
    oks, errs = _ok_payloads(running.session, "cartlab/**")
    assert oks and all(o.startswith(b"{") for o in oks)
    assert all(e.startswith("run: run_id: expected") for e in errs)
    _assert_still_serving(running)


def test_puts_of_garbage_on_every_daq_key_leave_it_running(running: Running) -> None:
    """daq subscribes to nothing; garbage put on its own keys must not reach or upset it."""
    for key in (keys.samples(BENCH), keys.state(BENCH), keys.run_finished(BENCH, "r"),
                keys.daq_query(BENCH, "zero"), keys.daq_query(BENCH, "run"), keys.daq_alive(BENCH)):
        for payload in GARBAGE[:6]:
            running.session.put(key, payload)
    _assert_still_serving(running)
