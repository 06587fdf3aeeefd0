"""Helpers for the worker's multi-process tests: sessions, workers, a stand-in daq, a collector.

Every wait is bounded and polls a condition; nothing sleeps "to let things happen".
"""

from __future__ import annotations

import os
import queue
import signal
import subprocess
import sys
from collections import defaultdict
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import zenoh
import zenoh.ext

from ident.worker.schedule import RunRef
from schemas import keys
from schemas.bus import BusConfig
from schemas.daq import RunFinished
from schemas.errors import SchemaError
from schemas.fit import FitReport
from testkit.repo import REPO
from testkit.waiting import wait_until

#: Bound on a worker coming up (s): it is declared alive only once its fit process is ready,
#: a spawned interpreter importing numpy, scipy, zenoh and the fitter (about 6 s on a 2-core
#: machine at load 5, several times that in a full run on a loaded one).
STARTUP_S = 120.0


def open_session(bus: BusConfig) -> zenoh.Session:
    return zenoh.open(zenoh.Config.from_json5(bus.zenoh_json5()))


#: the `router` fixture of the worker tests: its endpoint and its session
Router = tuple[str, zenoh.Session]


def client_args(endpoint: str) -> list[str]:
    """A worker's command-line options to join the bus as a client of the router at `endpoint`."""
    return ["--mode", "client", "--connect", endpoint]


def alive_workers(session: zenoh.Session) -> set[str]:
    return {str(r.ok.key_expr).rsplit("/", 1)[-1]
            for r in session.liveliness().get(keys.ALL_IDENT_ALIVE, timeout=1.0) if r.ok}


class FitCollector:
    """Every message on `cartlab/*/runs/*/fit` (history included), parsed."""

    def __init__(self, session: zenoh.Session) -> None:
        self._queue: queue.Queue[bytes] = queue.Queue()
        self.messages: list[FitReport] = []
        self.rejected = 0
        self._sub = zenoh.ext.declare_advanced_subscriber(
            session, keys.ALL_FITS, lambda s: self._queue.put(s.payload.to_bytes()),
            history=zenoh.ext.HistoryConfig(detect_late_publishers=True, max_samples=64),
            recovery=zenoh.ext.RecoveryConfig(periodic_queries=None, heartbeat=True))

    def drain(self) -> None:
        while True:
            try:
                payload = self._queue.get_nowait()
            except queue.Empty:
                return
            try:
                self.messages.append(FitReport.from_json_bytes(payload))
            except SchemaError:
                self.rejected += 1   # garbage an abuse test put on the fit keys

    def finals(self) -> dict[RunRef, list[FitReport]]:
        self.drain()
        out: dict[RunRef, list[FitReport]] = defaultdict(list)
        for report in self.messages:
            if report.final:
                out[RunRef(report.bench, report.run_id)].append(report)
        return out

    def with_results(self) -> dict[RunRef, list[FitReport]]:
        """Reports with results, partial (`pending`) or complete, per run."""
        self.drain()
        out: dict[RunRef, list[FitReport]] = defaultdict(list)
        for report in self.messages:
            if report.has_results:
                out[RunRef(report.bench, report.run_id)].append(report)
        return out

    def wait_results(self, runs: Iterable[RunRef], timeout_s: float) -> dict[RunRef, list[FitReport]]:
        wanted = set(runs)
        wait_until(lambda: wanted <= set(self.with_results()), timeout_s,
                 f"fit results of {sorted(map(str, wanted))}")
        return self.with_results()

    def wait_finals(self, runs: Iterable[RunRef], timeout_s: float) -> dict[RunRef, list[FitReport]]:
        wanted = set(runs)
        wait_until(lambda: wanted <= set(self.finals()), timeout_s,
                 f"final fit reports of {sorted(map(str, wanted))}")
        return self.finals()

    def close(self) -> None:
        self._sub.undeclare()


class FakeDaq:
    """Announces runs as a daq would (advanced publisher with cache per run)."""

    def __init__(self, session: zenoh.Session, bench: str, runs_dir: Path) -> None:
        self.session, self.bench, self.runs_dir = session, bench, runs_dir
        self._publishers: list[Any] = []
        self.token = session.liveliness().declare_token(keys.daq_alive(bench))

    def announce(self, run_id: str, content: bytes | None = b"fake-run") -> RunRef:
        if content is not None:
            (self.runs_dir / f"{run_id}.mcap").write_bytes(content)
        finished = RunFinished(bench=self.bench, run_id=run_id, status="complete",
                               file=f"{run_id}.mcap", n_samples=100, release_time_s=0.5,
                               duration_s=1.0)
        pub = zenoh.ext.declare_advanced_publisher(
            self.session, keys.run_finished(self.bench, run_id),
            cache=zenoh.ext.CacheConfig(max_samples=1), publisher_detection=True,
            sample_miss_detection=zenoh.ext.MissDetectionConfig(heartbeat=0.5, sporadic_heartbeat=None))
        pub.put(finished.to_json_bytes())
        self._publishers.append(pub)
        return RunRef(self.bench, run_id)

    def come_back(self, files: dict[str, bytes]) -> None:
        """Leave and come back (a new liveliness token), now answering `run` queries from `files`."""
        def on_run(query: zenoh.Query) -> None:
            run_id = query.selector.parameters.get("id")
            if run_id in files:
                query.reply(query.key_expr, files[run_id])
            else:
                query.reply_err(f"no run {run_id!r}")

        self._publishers.append(self.session.declare_queryable(keys.daq_query(self.bench, "run"), on_run))
        self.token.undeclare()
        self.token = self.session.liveliness().declare_token(keys.daq_alive(self.bench))


def start_worker(name: str, bus_args: list[str], runs_dir: Path, log_dir: Path,
                 fitter: str | None = None, env: dict[str, str] | None = None) -> subprocess.Popen[bytes]:
    args = [sys.executable, "-m", "ident.cli", "worker", "--name", name,
            "--runs-dir", str(runs_dir), *bus_args]
    if fitter:
        args += ["--fitter", fitter]
    full_env = {**os.environ, **(env or {})}
    out = (log_dir / f"{name}.log").open("wb")
    return subprocess.Popen(args, cwd=REPO, env=full_env, stdout=out, stderr=subprocess.STDOUT)


def stop(proc: subprocess.Popen[bytes], timeout_s: float = 10.0) -> int:
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=timeout_s)
    return proc.returncode


def record_sim_run(directory: Path, cases: str = "cart1", seed: int = 9) -> bytes:
    """The bytes of one real run file: `daq run` on the simulated rig (100 Hz, no Zenoh)."""
    subprocess.run([sys.executable, "-m", "daq.cli", "run", "--port",
                    f"sim://?cases={cases}&rate_hz=100&seed={seed}&realtime=0", "--bench", "bench1",
                    "--runs-dir", str(directory), "--no-zenoh", "--until-eof"],
                   cwd=REPO, check=True, capture_output=True, timeout=60)
    return next(directory.glob("*.mcap")).read_bytes()


def fit_log_counts(path: Path) -> dict[str, dict[str, list[str]]]:
    """`{"start"|"done": {"bench/run": [worker, ...]}}` from a fake fitter's log."""
    counts: dict[str, dict[str, list[str]]] = {"start": defaultdict(list), "done": defaultdict(list)}
    if path.exists():
        for line in path.read_text().splitlines():
            kind, run, worker = line.split()
            counts[kind][run].append(worker)
    return counts
