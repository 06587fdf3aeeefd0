"""Run a bench as a service from Python: `daq` and `ident worker` processes, a Zenoh node, a watcher.

Used by `tools/demo_bench.py`, `tools/bench_service.py` and the end-to-end tests. Every
process is started with an explicit loopback config, its output captured to a log file,
and stopped (SIGTERM, then SIGKILL after a bounded wait) when the `Bench` context exits.
Every wait is bounded and reports which process died and the tail of its log.

Topology on one machine (no router; Zenoh peers with scouting off do not relay for each
other, so every pair that must talk is linked explicitly):

    this process (peer, listens A) <── worker (peer, listens W, connects A)
            ^                              ^
            └──────── daq (peer, listens D, connects A and W)

With a router (`router=True`): this process is a Zenoh router on A, and every daq and
worker is a client connected to A (the lab deployment with several benches).
"""

from __future__ import annotations

import os
import queue
import signal
import subprocess
import sys
import time
from collections import defaultdict
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import zenoh
import zenoh.ext

from schemas import keys
from schemas.bus import BusConfig
from schemas.daq import RunFinished
from schemas.fit import FitReport
from testkit.ports import endpoint
from testkit.repo import REPO
from testkit.waiting import ProcessDied, wait_until


@dataclass
class Proc:
    name: str
    popen: subprocess.Popen[bytes]
    log: Path

    def tail(self, lines: int = 25) -> str:
        try:
            text = self.log.read_text(errors="replace").splitlines()
        except OSError:
            return "(no log)"
        return "\n".join(text[-lines:])

    def check_alive(self) -> None:
        code = self.popen.poll()
        if code is not None:
            raise ProcessDied(f"{self.name} exited with code {code}; last lines of {self.log}:\n"
                              f"{self.tail()}")

    def stop(self, timeout_s: float = 10.0) -> int:
        if self.popen.poll() is None:
            self.popen.send_signal(signal.SIGTERM)
            try:
                self.popen.wait(timeout=timeout_s)
            except subprocess.TimeoutExpired:
                self.popen.kill()
                self.popen.wait(timeout=timeout_s)
        return self.popen.returncode

    def kill9(self) -> None:
        self.popen.send_signal(signal.SIGKILL)
        self.popen.wait(timeout=10)


@dataclass
class FitWatcher:
    """Collects `finished` records and fit messages from the bus (history included)."""

    session: zenoh.Session
    _queue: queue.Queue[tuple[str, bytes, float]] = field(default_factory=queue.Queue)
    finished: dict[tuple[str, str], RunFinished] = field(default_factory=dict)
    finished_at: dict[tuple[str, str], float] = field(default_factory=dict)
    fits: dict[tuple[str, str], list[FitReport]] = field(default_factory=lambda: defaultdict(list))
    fit_at: dict[tuple[str, str], float] = field(default_factory=dict)
    partial_at: dict[tuple[str, str], float] = field(default_factory=dict)
    results: dict[tuple[str, str], list[FitReport]] = field(default_factory=lambda: defaultdict(list))
    claims: list[FitReport] = field(default_factory=list)
    _subs: list[Any] = field(default_factory=list)

    def __post_init__(self) -> None:
        history = zenoh.ext.HistoryConfig(detect_late_publishers=True, max_samples=64)
        recovery = zenoh.ext.RecoveryConfig(periodic_queries=None, heartbeat=True)
        for key, kind in ((keys.ALL_FINISHED, "finished"), (keys.ALL_FITS, "fit")):
            self._subs.append(zenoh.ext.declare_advanced_subscriber(
                self.session, key, self._enqueue(kind), history=history, recovery=recovery))

    def _enqueue(self, kind: str) -> Callable[[zenoh.Sample], None]:
        def put(sample: zenoh.Sample) -> None:
            self._queue.put((kind, sample.payload.to_bytes(), time.monotonic()))
        return put

    def drain(self) -> None:
        while True:
            try:
                kind, payload, at = self._queue.get_nowait()
            except queue.Empty:
                return
            if kind == "finished":
                record = RunFinished.from_json_bytes(payload)
                self.finished.setdefault((record.bench, record.run_id), record)
                self.finished_at.setdefault((record.bench, record.run_id), at)
            else:
                report = FitReport.from_json_bytes(payload)
                key = (report.bench, report.run_id)
                if report.has_results:
                    self.partial_at.setdefault(key, at)    # first results, partial or not
                    self.results[key].append(report)
                if report.final:
                    self.fits[key].append(report)
                    self.fit_at.setdefault(key, at)
                elif not report.has_results:
                    self.claims.append(report)

    def final_reports(self) -> dict[tuple[str, str], list[FitReport]]:
        self.drain()
        return dict(self.fits)

    def first_results(self) -> dict[tuple[str, str], list[FitReport]]:
        """Every report with results (partial or complete) per run."""
        self.drain()
        return dict(self.results)

    def close(self) -> None:
        for sub in self._subs:
            sub.undeclare()


class Bench:
    """Processes of a bench service; a context manager that always cleans up."""

    def __init__(self, workdir: Path, router: bool = False) -> None:
        self.workdir = workdir
        self.workdir.mkdir(parents=True, exist_ok=True)
        self.router = router
        self.endpoint = endpoint()
        self.procs: list[Proc] = []
        mode: Literal["router", "peer"] = "router" if router else "peer"
        self.session = zenoh.open(zenoh.Config.from_json5(
            BusConfig(mode=mode, listen=[self.endpoint]).zenoh_json5()))
        self.watcher = FitWatcher(self.session)
        self._worker_endpoints: list[str] = []

    def __enter__(self) -> Bench:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        for proc in reversed(self.procs):
            proc.stop()
        self.watcher.close()
        self.session.close()

    def _spawn(self, name: str, args: list[str], env: dict[str, str] | None = None) -> Proc:
        log = self.workdir / f"{name}.log"
        full_env = {**os.environ, "PYTHONUNBUFFERED": "1", **(env or {})}
        popen = subprocess.Popen(args, cwd=REPO, env=full_env, stdout=log.open("wb"),
                                 stderr=subprocess.STDOUT)
        proc = Proc(name, popen, log)
        self.procs.append(proc)
        return proc

    def _bus_args(self, listen: str | None, connect: list[str]) -> list[str]:
        if self.router:
            return ["--mode", "client", "--connect", self.endpoint]
        args = []
        if listen is not None:
            args += ["--listen", listen]
        for point in connect:
            args += ["--connect", point]
        return args

    def start_worker(self, name: str, runs_dir: Path, extra: list[str] | None = None,
                     env: dict[str, str] | None = None) -> Proc:
        """An `ident worker` (peer: listens on its own port and links to every other node)."""
        listen = endpoint()
        bus = self._bus_args(listen, [self.endpoint, *self._worker_endpoints])
        self._worker_endpoints.append(listen)
        return self._spawn(name, [sys.executable, "-m", "ident.cli", "worker", "--name", name,
                                  "--runs-dir", str(runs_dir), *bus, *(extra or [])], env)

    def start_daq(self, name: str, port_url: str, bench: str, runs_dir: Path,
                  extra: list[str] | None = None) -> Proc:
        """A `daq run` (peer: links to this process and to every worker started before)."""
        bus = self._bus_args(endpoint(), [self.endpoint, *self._worker_endpoints])
        return self._spawn(name, [sys.executable, "-m", "daq.cli", "run", "--port", port_url,
                                  "--bench", bench, "--runs-dir", str(runs_dir), *bus,
                                  *(extra or [])])

    def alive_workers(self) -> set[str]:
        return {str(r.ok.key_expr).rsplit("/", 1)[-1]
                for r in self.session.liveliness().get(keys.ALL_IDENT_ALIVE, timeout=1.0) if r.ok}

    def wait_workers(self, names: set[str], timeout_s: float = 60.0) -> None:
        wait_until(lambda: names <= self.alive_workers(), timeout_s,
                   f"workers {sorted(names)} alive on the bus", self.procs, poll_s=0.1)


def sim_url(cases: Iterable[str], *, friction_n: float = 0.15, rate_hz: float = 200.0,
            seed: int = 1, realtime: bool = False, **options: Any) -> str:
    """A `sim://` URL for the lab cases with dry friction on both carts."""
    query = {"cases": ",".join(cases), "fc1": friction_n, "fc2": friction_n, "rate_hz": rate_hz,
             "seed": seed, "realtime": int(realtime), **options}
    return "sim://?" + "&".join(f"{k}={v}" for k, v in query.items())


__all__ = ["Bench", "FitWatcher", "Proc", "sim_url"]
