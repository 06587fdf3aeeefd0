"""Test helpers for the bench page: a real page server in a thread, an SSE reader, and a
stand-in daq that is a real Zenoh peer publishing real `schemas` records and answering the
`status`, `zero`, `arm` and `runs` queryables.

Loopback only, ephemeral ports, no sleeps: waits are on events or bounded deadlines.
"""

from __future__ import annotations

import http.client
import json
import math
import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import zenoh
import zenoh.ext

from daq.web.server import ThreadedPageServer
from daq.web.service import WebSettings
from schemas import keys
from schemas.bus import BusConfig
from schemas.daq import (
    DaqCounters,
    DaqStatus,
    DetectorState,
    DetectorStateMsg,
    RunFinished,
    RunList,
    SampleBatch,
    ZeroReply,
)
from schemas.fit import FitReport, ModeRec, PemFitRec, SimpleFitRec, TransferFunctionRec

COUNTS_PER_M = 20000.0


# -- the page server --------------------------------------------------------------------
class PageServer(ThreadedPageServer):
    """The page server in a thread (ephemeral loopback port), with small HTTP helpers."""

    def request(self, method: str, path: str, timeout_s: float = 10,
                headers: dict[str, str] | None = None) -> tuple[int, bytes]:
        return self.request_on(self.port, method, path, timeout_s, headers)

    @staticmethod
    def request_on(port: int, method: str, path: str, timeout_s: float = 10,
                   headers: dict[str, str] | None = None) -> tuple[int, bytes]:
        if headers is None:
            headers = {"X-Cartlab-Action": "1"} if method == "POST" else {}
        conn = http.client.HTTPConnection("127.0.0.1", port, timeout=timeout_s)
        try:
            conn.request(method, path, headers=headers)
            resp = conn.getresponse()
            return resp.status, resp.read()
        finally:
            conn.close()

    def json(self, method: str, path: str) -> tuple[int, Any]:
        status, body = self.request(method, path)
        return status, json.loads(body)


@dataclass
class SseEvent:
    name: str
    data: Any


class SseReader:
    """Reads `text/event-stream` events from the page server."""

    def __init__(self, port: int, path: str, timeout_s: float = 10) -> None:
        self.conn = http.client.HTTPConnection("127.0.0.1", port, timeout=timeout_s)
        self.conn.request("GET", path, headers={"Accept": "text/event-stream"})
        self.resp = self.conn.getresponse()
        assert self.resp.status == 200, self.resp.status
        assert self.resp.getheader("content-type", "").startswith("text/event-stream")

    def next(self) -> SseEvent:
        name, data = "message", list[str]()
        while True:
            line = self.resp.readline()
            if not line:
                raise EOFError("event stream closed")
            text = line.decode().rstrip("\n")
            if text == "":
                if data:
                    return SseEvent(name, json.loads("\n".join(data)))
                name = "message"
                continue
            if text.startswith(":"):
                continue
            field_name, _, value = text.partition(": ")
            if field_name == "event":
                name = value
            elif field_name == "data":
                data.append(value)

    def until(self, predicate: Callable[[SseEvent], bool], timeout_s: float, what: str,
              seen: list[SseEvent] | None = None) -> SseEvent:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            event = self.next()
            if seen is not None:
                seen.append(event)
            if predicate(event):
                return event
        raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")

    def close(self) -> None:
        self.conn.close()


# -- the stand-in daq ---------------------------------------------------------------------
def position_m(t_s: float, channel: int) -> float:
    """The stand-in rig's trace: two damped oscillations (m) at known frequencies."""
    if channel == 1:
        return 0.15 * math.exp(-0.2 * t_s) * math.cos(2 * math.pi * 0.9 * t_s)
    return -0.05 * math.exp(-0.2 * t_s) * math.sin(2 * math.pi * 1.4 * t_s)


def sample_batch(bench: str, batch_seq: int, first: int, n: int, rate_hz: float) -> SampleBatch:
    t_ns = [round((first + i) * 1e9 / rate_hz) for i in range(n)]
    p1 = [position_m(t * 1e-9, 1) for t in t_ns]
    p2 = [position_m(t * 1e-9, 2) for t in t_ns]
    return SampleBatch(bench=bench, batch_seq=batch_seq, t_ns=t_ns, pos1_m=p1, pos2_m=p2,
                       raw1=[p * COUNTS_PER_M for p in p1], raw2=[p * COUNTS_PER_M for p in p2])


@dataclass
class FakeDaqState:
    state: DetectorState = "idle"
    connected: bool = True
    zero_offsets_raw: list[float] = field(default_factory=lambda: [0.0, 0.0])
    raw_now: list[float] = field(default_factory=lambda: [1234.0, -567.0])
    zero_calls: int = 0
    arm_calls: int = 0
    runs: list[RunFinished] = field(default_factory=list)


class FakeDaq:
    """A real Zenoh peer standing in for `daq run`: queryables, liveliness, publishers."""

    def __init__(self, bench: str, listen: str, connect: bool = False) -> None:
        """Listen on `listen`, or connect to it when `connect`."""
        self.bench = bench
        self.st = FakeDaqState()
        self.lock = threading.Lock()
        bus = BusConfig.connector(listen) if connect else BusConfig.listener(listen)
        self.session = zenoh.open(zenoh.Config.from_json5(bus.zenoh_json5()))
        s = self.session
        self.handles: list[Any] = [
            s.declare_queryable(keys.daq_query(bench, "status"), self._on_status),
            s.declare_queryable(keys.daq_query(bench, "zero"), self._on_zero),
            s.declare_queryable(keys.daq_query(bench, "arm"), self._on_arm),
            s.declare_queryable(keys.daq_query(bench, "runs"), self._on_runs),
            s.declare_queryable(keys.daq_query(bench, "run"), self._on_run),
        ]
        self.samples_pub = s.declare_publisher(keys.samples(bench))
        self.state_pub = s.declare_publisher(keys.state(bench))
        self.token: Any = s.liveliness().declare_token(keys.daq_alive(bench))
        self.publishers: list[Any] = []
        self._stream_stop = threading.Event()
        self._stream: threading.Thread | None = None
        self.batches_sent = 0

    def status(self) -> DaqStatus:
        with self.lock:
            st = self.st
            pos = [(r - z) / COUNTS_PER_M for r, z in zip(st.raw_now, st.zero_offsets_raw)]
            return DaqStatus(bench=self.bench, state=st.state, run_id=None, port="sim://fake",
                             dialect="cartlab", connected=st.connected, counts_per_m=COUNTS_PER_M,
                             zero_offsets_raw=list(st.zero_offsets_raw), last_t_ns=1,
                             last_pos_m=pos, n_runs=len(st.runs), counters=DaqCounters(lines=10),
                             software_version="test")

    # queryable callbacks: answer at once from memory (they never block)
    def _on_status(self, query: zenoh.Query) -> None:
        query.reply(query.key_expr, self.status().to_json_bytes())

    def _on_zero(self, query: zenoh.Query) -> None:
        with self.lock:
            self.st.zero_calls += 1
            self.st.zero_offsets_raw = list(self.st.raw_now)
            offsets = list(self.st.zero_offsets_raw)
        reply = ZeroReply(bench=self.bench, ok=True, zero_offsets_raw=offsets)
        query.reply(query.key_expr, reply.to_json_bytes())

    def _on_arm(self, query: zenoh.Query) -> None:
        with self.lock:
            self.st.arm_calls += 1
            self.st.state = "armed"
        query.reply(query.key_expr, self.status().to_json_bytes())

    def _on_runs(self, query: zenoh.Query) -> None:
        with self.lock:
            runs = RunList(bench=self.bench, runs=list(self.st.runs))
        query.reply(query.key_expr, runs.to_json_bytes())

    def _on_run(self, query: zenoh.Query) -> None:
        """MCAP bytes of a run (`?id=<run_id>`), as the daq's `run` queryable answers."""
        run_id = query.parameters.get("id")
        with self.lock:
            known = any(r.run_id == run_id for r in self.st.runs)
        if known:
            query.reply(query.key_expr, b"\x89MCAP0\r\n" + str(run_id).encode())
        else:
            query.reply_err(f"run: expected a known run id, got {run_id!r}".encode())

    # publishing
    def publish_state(self, state: DetectorState, run_id: str | None = None) -> None:
        with self.lock:
            self.st.state = state
        self.state_pub.put(DetectorStateMsg(bench=self.bench, state=state, t_ns=1,
                                            run_id=run_id).to_json_bytes())

    def _advanced_put(self, key: str, payload: bytes) -> None:
        pub = zenoh.ext.declare_advanced_publisher(
            self.session, key, cache=zenoh.ext.CacheConfig(max_samples=1), publisher_detection=True,
            sample_miss_detection=zenoh.ext.MissDetectionConfig(heartbeat=1.0, sporadic_heartbeat=None))
        self.publishers.append(pub)
        pub.put(payload)

    def publish_finished(self, rec: RunFinished) -> None:
        with self.lock:
            self.st.runs.append(rec)
        self._advanced_put(keys.run_finished(rec.bench, rec.run_id), rec.to_json_bytes())

    def publish_fit(self, report: FitReport) -> None:
        self._advanced_put(keys.run_fit(report.bench, report.run_id), report.to_json_bytes())

    def start_stream(self, rate_hz: float = 1000.0, batch: int = 20) -> None:
        """Publish batches of `batch` samples paced at `rate_hz` (real time) until stopped."""
        def run() -> None:
            seq, first, t0 = 0, 0, time.monotonic()
            while not self._stream_stop.is_set():
                self.samples_pub.put(sample_batch(self.bench, seq, first, batch, rate_hz)
                                     .to_json_bytes())
                seq, first = seq + 1, first + batch
                self.batches_sent = seq
                self._stream_stop.wait(max(0.0, t0 + first / rate_hz - time.monotonic()))

        self._stream = threading.Thread(target=run, daemon=True)
        self._stream.start()

    def stop_stream(self) -> None:
        self._stream_stop.set()
        if self._stream is not None:
            self._stream.join(5)

    def leave(self) -> None:
        """Drop the liveliness token (the daq 'dies' as far as the page can tell)."""
        if self.token is not None:
            self.token.undeclare()
            self.token = None

    def close(self) -> None:
        self.stop_stream()
        for handle in [*self.publishers, *self.handles, self.samples_pub, self.state_pub]:
            handle.undeclare()
        self.leave()
        self.session.close()


def page_settings(endpoint: str, runs_dir: Any = None, **kw: Any) -> WebSettings:
    """Settings of a page server that connects to `endpoint`, fast timeouts for tests."""
    kw.setdefault("query_timeout_s", 1.0)
    kw.setdefault("status_every_s", 0.3)
    return WebSettings(bus=BusConfig.connector(endpoint), runs_dir=runs_dir, **kw)


# -- headless Chromium --------------------------------------------------------------------
CHROMIUM_FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync",
                  "--disable-dev-shm-usage", "--window-size=1280,1000")


def chromium_paths() -> tuple[str | None, str | None]:
    """Debian's chromium and chromedriver, or None for what is missing."""
    import shutil

    browser = shutil.which("chromium") or ("/usr/bin/chromium" if os.path.exists("/usr/bin/chromium") else None)
    driver = shutil.which("chromedriver") or (
        "/usr/bin/chromedriver" if os.path.exists("/usr/bin/chromedriver") else None)
    return browser, driver


def chromium_driver(user_data_dir: str, extra_flags: tuple[str, ...] = ()) -> Any:
    """A Selenium driver on Debian's headless Chromium (Selenium Manager downloads nothing).

    `extra_flags`: more command-line flags, e.g. ``--host-resolver-rules=MAP name 127.0.0.1``
    to play a DNS-rebinding page."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    browser, driver = chromium_paths()
    assert browser and driver, "chromium and chromedriver must be installed"
    options = webdriver.ChromeOptions()
    options.binary_location = browser
    for flag in (*CHROMIUM_FLAGS, *extra_flags, f"--user-data-dir={user_data_dir}"):
        options.add_argument(flag)
    return webdriver.Chrome(service=Service(executable_path=driver), options=options)


# -- the real daq on a simulated rig --------------------------------------------------------
class DaqProcess:
    """`daq run --port sim://...` in a subprocess, listening on `endpoint`."""

    def __init__(self, sim_url: str, bench: str, runs_dir: Any, endpoint: str,
                 extra: tuple[str, ...] = ()) -> None:
        import subprocess
        import sys
        from pathlib import Path

        script = Path(sys.executable).with_name("daq")
        cmd = [str(script)] if script.exists() else [sys.executable, "-m", "daq.cli"]
        self.log_path = Path(runs_dir).parent / f"daq-{bench}.log"
        self.log = open(self.log_path, "wb")  # noqa: SIM115 - closed in stop()
        self.proc = subprocess.Popen([*cmd, "run", "--port", sim_url, "--bench", bench,
                                      "--runs-dir", str(runs_dir), "--listen", endpoint, *extra],
                                     stdout=self.log, stderr=subprocess.STDOUT)

    def stop(self) -> str:
        import signal
        import subprocess

        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(5)
        self.log.close()
        return self.log_path.read_text(errors="replace")


def diagnosis_record(cause: str, gain_points: float, base_fit: float) -> Any:
    """A `DiagnosisReport` as `ident diagnose` would publish it (values set by the test)."""
    from schemas.diagnosis import Candidate, DiagnosisReport, Evidence, ModelFit

    base = ModelFit(model="linear", fit_percent=base_fit, parameters={"wn_rad_s": 5.5, "zeta": 0.04})
    ext = ModelFit(model=f"linear+{cause}", fit_percent=base_fit + gain_points,
                   parameters={"wn_rad_s": 5.5, "zeta": 0.03})
    cand = Candidate(effect=cause, parameters={}, fit_percent=base_fit + gain_points,  # type: ignore[arg-type]
                     gain_points=gain_points, extra_parameters=1, lr_train=50.0, lr_validation=40.0,
                     threshold_train=6.6, threshold_validation=6.6, significant=True)
    evidence = Evidence(residual_rms_m=1e-4, noise_std_m=5e-5, whiteness_fraction_outside=0.3,
                        residual_is_white=False, residual_peak_hz=0.9,
                        residual_peak_to_baseline_ratio=4.0, envelope_shape="constant_step",
                        envelope_peaks=8, envelope_step_m=0.004, envelope_ratio=0.9,
                        frequency_drift_per_m2=0.0, rest_offset_m=0.001, stuck_for_s=0.4,
                        lattice_coherence=0.1)
    return DiagnosisReport(carts=1, sample_rate_hz=1000.0, release_time_s=0.5, window_start_s=0.5,
                           window_end_s=4.0, step_m=[0.15], step_estimated=False, baseline=base,
                           candidates=[cand], cause=cause, extended=ext,  # type: ignore[arg-type]
                           gain_points=gain_points, corrected_linear={}, evidence=evidence,
                           validation="second half", explanation=f"the peaks decay by a constant step: {cause}",
                           elapsed_s=0.1)


def fit_record(bench: str, run_id: str, release_time_s: float, figures: list[str]) -> FitReport:
    """A cart-1 `FitReport` as a worker would publish it (values set by the test): simple and
    PEM fits of a 5.5 rad/s, ζ 0.04 cart, 97.3 % PEM fit, Coulomb friction diagnosed (+0.8 pts)."""
    tf = TransferFunctionRec(output=1, num=[30.25], den=[1.0, 0.44, 30.25])
    return FitReport(
        bench=bench, run_id=run_id, worker="test", status="ok", case="cart1", release_time_s=release_time_s,
        simple=[SimpleFitRec(method="rk4", output=1, tf=tf, wn_rad_s=5.49, zeta=0.041, gain=1.0,
                             fit_percent=96.1)],
        pem=PemFitRec(order=2, tfs=[tf], modes=[ModeRec(wn_rad_s=5.5, zeta=0.04)],
                      fit_percent=[97.3], outputs=[1]),
        diagnosis=diagnosis_record("coulomb_friction", 0.8, 97.3), figures=figures)
