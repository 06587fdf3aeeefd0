"""The bench page server over real HTTP (uvicorn on an ephemeral loopback port) and a real
Zenoh session: a stand-in daq publishes real `schemas` records and answers the queryables.
No browser here (see test_web_browser.py)."""

from __future__ import annotations

import itertools
import json
import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from schemas.daq import RunFinished
from schemas.fit import FitReport, ModeRec, PemFitRec, TransferFunctionRec
from testkit.waiting import wait_until
from testkit.web_support import FakeDaq, PageServer, SseReader, page_settings, position_m

pytestmark = pytest.mark.timeout(60)


@pytest.fixture
def endpoint(free_port: int) -> str:
    return f"tcp/127.0.0.1:{free_port}"


@pytest.fixture
def daq(endpoint: str) -> Iterator[FakeDaq]:
    fake = FakeDaq("bench1", endpoint)
    yield fake
    fake.close()


@pytest.fixture
def runs_dir(tmp_path: Path) -> Path:
    runs = tmp_path / "runs"
    (runs / "r1.fit").mkdir(parents=True)
    (runs / "r1.mcap").write_bytes(b"\x89MCAP0\r\n-fake")
    (runs / "r1.fit" / "report.json").write_text("{}")
    (runs / "r1.fit" / "pem.png").write_bytes(b"\x89PNG")
    (tmp_path / "secret.txt").write_text("outside the runs dir")
    os.symlink(tmp_path / "secret.txt", runs / "r1.fit" / "link.png")
    return runs


@pytest.fixture
def page(endpoint: str, daq: FakeDaq, runs_dir: Path) -> Iterator[PageServer]:
    with PageServer(page_settings(endpoint, runs_dir)) as server:
        yield server


@pytest.fixture
def events(page: PageServer) -> Iterator[SseReader]:
    """The event stream of bench1 as a page opens it, seen alive (closed after the test)."""
    reader = SseReader(page.port, "/api/events?bench=bench1")
    try:
        first = reader.next()
        assert first.name == "snapshot" and first.data["bench"] == "bench1"
        wait_alive(reader)
        yield reader
    finally:
        reader.close()


def wait_alive(reader: SseReader) -> None:
    reader.until(lambda e: e.name == "status" and e.data["alive"], 10, "the daq to be seen alive")


def test_sse_delivers_decimated_batches_of_the_live_samples(
        page: PageServer, daq: FakeDaq, events: SseReader) -> None:
    reader = events
    daq.start_stream(rate_hz=1000.0, batch=20)
    batches = []
    reader.until(lambda e: e.name == "samples" and bool(batches.append(e) or len(batches) >= 15),
                 10, "15 sample batches")
    daq.stop_stream()
    points = [(t, p1, p2) for e in batches for t, p1, p2 in
              zip(e.data["t_s"], e.data["pos1_m"], e.data["pos2_m"])]
    raw = sum(e.data["n_raw"] for e in batches)
    # 1 kHz shown at 250 points/s: one point in four, evenly spaced, values as published
    assert len(points) == pytest.approx(raw / 4, abs=len(batches))
    steps = {round((b[0] - a[0]) * 1e3, 6) for a, b in itertools.pairwise(points)}
    assert steps == {4.0}
    for t, p1, p2 in points:
        assert p1 == pytest.approx(position_m(t, 1), abs=1e-12)
        assert p2 == pytest.approx(position_m(t, 2), abs=1e-12)
    # batched: ~20 samples of 1 ms each per batch on the wire, > 40 per page update here
    assert raw / len(batches) >= 40
    status, stats = page.json("GET", "/api/stats")
    assert status == 200 and stats["samples_in"] >= raw and stats["pages"] == 1


def test_zero_button_calls_the_daq_queryable(
        page: PageServer, daq: FakeDaq, events: SseReader) -> None:
    reader = events
    status, body = page.json("POST", "/api/bench/bench1/zero")
    assert status == 200 and body["ok"] is True
    assert daq.st.zero_calls == 1
    assert body["reply"]["zero_offsets_raw"] == daq.st.raw_now
    event = reader.until(lambda e: e.name == "status" and e.data["status"] is not None
                         and e.data["status"]["zero_offsets_raw"] == daq.st.raw_now, 10,
                         "a status showing the new zero")
    assert event.data["status"]["last_pos_m"] == [0.0, 0.0]
    status, body = page.json("POST", "/api/bench/bench1/arm")
    assert status == 200 and body["message"] == "detector armed" and daq.st.arm_calls == 1


def test_a_bench_without_daq_says_so_and_zero_fails_with_the_reason(page: PageServer) -> None:
    status, body = page.json("POST", "/api/bench/nobody/zero")
    assert status == 502 and body["ok"] is False and "no reply" in body["message"]
    status, snap = page.json("GET", "/api/snapshot?bench=nobody")
    assert "daq for bench nobody is not running" in snap["status"]["problems"][0]
    assert page.request("POST", "/api/bench/bench1/reboot")[0] == 404


def test_unplugged_port_and_lost_daq_are_reported(
        page: PageServer, daq: FakeDaq, events: SseReader) -> None:
    reader = events
    daq.st.connected = False
    event = reader.until(lambda e: e.name == "status" and bool(e.data["problems"]), 10,
                         "a problem to be reported")
    assert "sim://fake is not connected" in event.data["problems"][0]
    daq.leave()
    event = reader.until(lambda e: e.name == "status" and not e.data["alive"], 10,
                         "the daq to be seen gone")
    assert "not running" in event.data["problems"][0]


def test_runs_and_fits_reach_the_page_with_a_failed_fit_reason(
        page: PageServer, daq: FakeDaq, events: SseReader) -> None:
    reader = events
    daq.publish_finished(RunFinished(bench="bench1", run_id="r1", status="complete", file="r1.mcap",
                                     n_samples=7000, release_time_s=0.5, duration_s=7.0))
    row = reader.until(lambda e: e.name == "run" and e.data["run_id"] == "r1", 10, "run r1").data
    assert row["status"] == "complete" and row["release_time_s"] == 0.5
    assert row["fit_files"] == ["pem.png", "report.json"]     # link.png leaves the dir: not listed
    tf = TransferFunctionRec(output=1, num=[29.9], den=[1.0, 0.35, 29.9])
    daq.publish_fit(FitReport(bench="bench1", run_id="r1", worker="w", status="ok",
                              pem=PemFitRec(order=2, tfs=[tf], modes=[ModeRec(wn_rad_s=5.47, zeta=0.032)],
                                            fit_percent=[96.5], outputs=[1])))
    row = reader.until(lambda e: e.name == "run" and e.data["fit"] is not None, 10, "r1's fit").data
    assert row["fit"]["pem"]["wn_rad_s"] == [5.47] and row["fit"]["pem"]["zeta"] == [0.032]
    daq.publish_finished(RunFinished(bench="bench1", run_id="r2", status="aborted", file="r2.mcap",
                                     n_samples=10, release_time_s=None, duration_s=0.01,
                                     reason="port lost"))
    daq.publish_fit(FitReport(bench="bench1", run_id="r2", worker="w", status="failed",
                              reason="run too short: expected at least 1 s, got 0.01 s"))
    row = reader.until(lambda e: e.name == "run" and e.data["run_id"] == "r2"
                       and e.data["fit"] is not None, 10, "r2's failed fit").data
    assert row["fit"]["status"] == "failed" and "too short" in row["fit"]["reason"]
    # a page that connects later gets both rows in its snapshot
    _status, snap = page.json("GET", "/api/snapshot?bench=bench1")
    assert [r["run_id"] for r in snap["runs"]] == ["r1", "r2"]


def test_run_files_are_served_and_path_traversal_is_refused(page: PageServer) -> None:
    status, body = page.request("GET", "/files/r1/mcap")
    assert status == 200 and body == b"\x89MCAP0\r\n-fake"
    assert page.request("GET", "/files/r1/fit/pem.png") == (200, b"\x89PNG")
    assert json.loads(page.request("GET", "/files/r1/fit/report.json")[1]) == {}
    refused = [
        "/files/r1/fit/link.png",             # a symlink out of the runs dir
        "/files/r1/fit/..%2F..%2Fsecret.txt",
        "/files/..%2Fsecret.txt/mcap",
        "/files/r1/fit/%2E%2E",
        "/files/..%2F..%2Fetc%2Fpasswd/mcap",
        "/files/r9/mcap",                     # absent, and no bench to fetch it from
        "/files/r1/fit/..",
        "/files/r1/../../secret.txt",
    ]
    for path in refused:
        status, body = page.request("GET", path)
        assert status in (400, 404), (path, status)
        assert b"outside the runs dir" not in body, path


def test_the_page_and_its_assets_come_from_the_package(page: PageServer) -> None:
    status, html = page.request("GET", "/")
    assert status == 200 and b"/static/app.js" in html and b"<canvas" in html
    for asset in ("/static/app.js", "/static/style.css"):
        status, body = page.request("GET", asset)
        assert status == 200 and len(body) > 500
    assert b"http" not in html.replace(b"http-equiv", b"")  # no CDN: nothing fetched elsewhere


def test_cross_site_posts_cannot_press_the_buttons(page: PageServer, daq: FakeDaq, events: SseReader) -> None:
    status, body = page.request("POST", "/api/bench/bench1/zero", headers={})
    assert status == 403 and b"X-Cartlab-Action" in body
    assert daq.st.zero_calls == 0


def test_a_fit_written_in_the_runs_dir_reaches_the_page_without_zenoh(
        page: PageServer, daq: FakeDaq, events: SseReader, runs_dir: Path) -> None:
    daq.publish_finished(RunFinished(bench="bench1", run_id="r3", status="complete", file="r3.mcap",
                                     n_samples=5000, release_time_s=0.4, duration_s=5.0))
    events.until(lambda e: e.name == "run" and e.data["run_id"] == "r3", 10, "run r3")
    (runs_dir / "r3.fit").mkdir()
    report = FitReport(bench="bench1", run_id="r3", worker="w", status="failed",
                       reason="no release found: expected a step of at least 0.01 m, got 0.002 m")
    (runs_dir / "r3.fit" / "report.json").write_bytes(report.to_json_bytes())
    row = events.until(lambda e: e.name == "run" and e.data["run_id"] == "r3"
                       and e.data["fit"] is not None, 10, "r3's fit from its folder").data
    assert row["fit"]["status"] == "failed" and row["fit"]["reason"] == report.reason
    assert row["fit_files"] == ["report.json"]


def test_an_mcap_not_on_this_machine_is_fetched_from_the_daq(
        page: PageServer, daq: FakeDaq, events: SseReader) -> None:
    daq.publish_finished(RunFinished(bench="bench1", run_id="far1", status="complete", file="far1.mcap",
                                     n_samples=10, release_time_s=0.1, duration_s=0.2))
    status, body = page.request("GET", "/files/far1/mcap?bench=bench1")
    assert status == 200 and body == b"\x89MCAP0\r\nfar1"
    status, body = page.request("GET", "/files/nope/mcap?bench=bench1")
    assert status == 404 and b"expected a known run id" in body


def test_the_command_serves_and_stops_cleanly_on_a_signal_with_a_page_open(
        free_port: int, endpoint: str) -> None:
    proc = subprocess.Popen([sys.executable, "-m", "daq.web", "--port", str(free_port),
                             "--connect", endpoint], stderr=subprocess.PIPE)
    try:
        def serving() -> bool:
            try:
                return PageServer.request_on(free_port, "GET", "/api/stats")[0] == 200
            except OSError:
                assert proc.poll() is None, proc.stderr.read() if proc.stderr else ""
                return False

        wait_until(serving, 20, "python -m daq.web to serve")
        reader = SseReader(free_port, "/api/events")
        first = reader.next()
        assert first.name == "snapshot" and "no daq found" in first.data["status"]["problems"][0]
        proc.send_signal(signal.SIGINT)
        assert proc.wait(10) == 0
        with pytest.raises(EOFError):
            reader.next()                                   # the open stream was ended, not cut
        reader.close()
        assert b"Traceback" not in (proc.stderr.read() if proc.stderr else b"")
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(5)


def test_a_foreign_host_header_is_refused_on_every_route(page: PageServer, daq: FakeDaq,
                                                          events: SseReader) -> None:
    """DNS rebinding: a foreign name resolved to 127.0.0.1 sends its own Host; it gets nothing."""
    routes = [("GET", "/"), ("GET", "/api/snapshot?bench=bench1"), ("GET", "/api/events?bench=bench1"),
              ("GET", "/api/stats"), ("GET", "/files/r1/mcap"), ("GET", "/files/r1/fit/report.json"),
              ("GET", "/static/app.js"), ("POST", "/api/bench/bench1/zero"), ("POST", "/api/bench/bench1/arm")]
    for host in ("evil.example", f"evil.example:{page.port}", "127.0.0.1.evil.example", ""):
        for method, path in routes:
            headers = {"Host": host, "X-Cartlab-Action": "1"}
            status, body = page.request(method, path, headers=headers)
            assert status == 403 and b"expected one of" in body, (host, method, path, status)
    assert daq.st.zero_calls == 0
    for host in (f"127.0.0.1:{page.port}", f"localhost:{page.port}", "LOCALHOST", f"[::1]:{page.port}"):
        assert page.request("GET", "/api/stats", headers={"Host": host})[0] == 200, host
    status, _ = page.request("POST", "/api/bench/bench1/zero", headers={"Host": f"localhost:{page.port}"})
    assert status == 403 and daq.st.zero_calls == 0      # the cross-site header is still needed
    status, _ = page.request("POST", "/api/bench/bench1/zero",
                             headers={"Host": f"localhost:{page.port}", "X-Cartlab-Action": "1"})
    assert status == 200 and daq.st.zero_calls == 1
