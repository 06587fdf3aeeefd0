"""Rows 2-4 of issue 14: a worker and its peers (a stopped daq, a paused worker, abuse).

Workers run as `ident worker` processes connected as clients to a router in this process,
which also plays the daq (`FakeDaq`), the attacker, and the collector of every fit message.
The fitters are `testkit.fake_fitters` plug-ins: these rows are about scheduling, not numerics.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import zenoh

from ident.worker.bus import FETCH_TIMEOUT_S, MAX_QUEUED_BYTES
from schemas import keys
from schemas.bus import BusConfig
from schemas.fit import FitReport
from testkit import ports
from testkit.fault_table import BENCH, Row, failed_row, record_sim
from testkit.peak_memory import reset_peak, status_bytes
from testkit.waiting import wait_until
from testkit.worker_harness import STARTUP_S, FakeDaq, FitCollector, alive_workers, start_worker, stop

LEASE_MS = 3000
#: What a forged run may stall the worker beyond the fetch bound: its claim and withdrawal (s).
CLAIM_SLACK_S = 3.0


def client_config(path: Path, endpoint: str) -> list[str]:
    config = BusConfig(mode="client", listen=[], connect=[endpoint]).zenoh_dict()
    config["transport"]["link"] = {"tx": {"lease": LEASE_MS, "keep_alive": 4}}
    path.write_text(json.dumps(config))
    return ["--zenoh-config", str(path)]


@contextmanager
def router() -> Iterator[tuple[str, zenoh.Session]]:
    endpoint = f"tcp/127.0.0.1:{ports.free_port()}"
    config = BusConfig(mode="router", listen=[endpoint]).zenoh_dict()
    config["transport"]["link"] = {"tx": {"lease": LEASE_MS, "keep_alive": 4}}
    session = zenoh.open(zenoh.Config.from_json5(json.dumps(config)))
    try:
        yield endpoint, session
    finally:
        session.close()


def _finals_score(collector: FitCollector, runs: list[Any]) -> tuple[int, int]:
    """(final reports beyond one per run, runs without an `ok` final): a run whose only final
    says `failed` was left unfitted (the stopped daq's fault before its fix)."""
    finals = collector.finals()
    doubles = sum(max(0, len(finals.get(r, [])) - 1) for r in runs)
    return doubles, sum(1 for r in runs if not any(f.status == "ok" for f in finals.get(r, [])))


# --- row 2: transient failures retried ----------------------------------------------------------------

def row2_daq_gone(work: Path) -> Row:
    runs_dir = work / "r2"
    runs_dir.mkdir()
    with router() as (endpoint, session):
        daq = FakeDaq(session, BENCH, runs_dir)
        collector = FitCollector(session)
        worker = start_worker("w2", client_config(work / "w2.json5", endpoint), runs_dir / "worker", work,
                              "testkit.fake_fitters:instant_fit", {"FAKE_FIT_LOG": str(work / "r2.log")})
        try:
            wait_until(lambda: "w2" in alive_workers(session), STARTUP_S, "worker up", worker)
            run = daq.announce("aborted", content=None)   # the daq is stopped: no file, no reply
            wait_until(lambda: _withdrawn(collector, "aborted"), 60, "the fetch given up for now", worker)
            early_final = bool(collector.finals().get(run))
            daq.come_back({"aborted": b"fake-run served after the daq came back"})
            collector.wait_finals([run], timeout_s=60)
            doubles, unfitted = _finals_score(collector, [run])
            status = collector.finals()[run][0].status
        finally:
            code = stop(worker)
            collector.close()
    return Row("2 stopped daq", "run announced, its daq gone (no file, no reply), then the daq back",
               f"deferred (no final while away: {not early_final}), fitted {status} once the daq was back",
               crashes=int(code != 0), double_fits=doubles, unfitted=unfitted)


def row11_worker_start(work: Path) -> Row:
    """A worker with the real fitter, handed a run the moment its token appears: the first
    results must not wait for the fit process's start-up (its imports take seconds)."""
    run_bytes = record_sim(work / "r11-daq", "sim://?cases=cart1&rate_hz=200&seed=4&realtime=0").read_bytes()
    runs_dir = work / "r11"
    runs_dir.mkdir()
    with router() as (endpoint, session):
        daq = FakeDaq(session, BENCH, runs_dir)
        collector = FitCollector(session)
        started = time.monotonic()
        worker = start_worker("w11", client_config(work / "w11.json5", endpoint), runs_dir, work)
        try:
            wait_until(lambda: "w11" in alive_workers(session), STARTUP_S, "worker up", worker)
            alive = time.monotonic()
            run = daq.announce("first", content=run_bytes)
            collector.wait_results([run], timeout_s=120)
            first = time.monotonic()
            collector.wait_finals([run], timeout_s=300)
            doubles, unfitted = _finals_score(collector, [run])
            status = collector.finals()[run][0].status
        finally:
            code = stop(worker)
            collector.close()
    return Row("11 worker start", "a worker (the real fitter) handed a run the moment its liveliness token appears",
               f"alive {alive - started:.1f} s after its start (once its fit process was ready); first results "
               f"{first - alive:.2f} s after the run was announced; final {status}",
               crashes=int(code != 0), double_fits=doubles, unfitted=unfitted)


def _withdrawn(collector: FitCollector, run_id: str) -> bool:
    collector.drain()
    return any(r.run_id == run_id and r.status == "withdrawn" for r in collector.messages)


# --- row 3: pauses longer than the lease ------------------------------------------------------------

def row3_pause(work: Path, n_runs: int = 18, pause_s: float = 15.0) -> Row:
    runs_dir = work / "r3"
    runs_dir.mkdir()
    gate = work / "r3.gate"
    env = {"FAKE_FIT_LOG": str(work / "r3.log"), "FAKE_FIT_GATE": str(gate)}
    with router() as (endpoint, session):
        daq = FakeDaq(session, BENCH, runs_dir)
        collector = FitCollector(session)
        workers = {n: start_worker(n, client_config(work / f"{n}.json5", endpoint), runs_dir, work,
                                   "testkit.fake_fitters:gated_fit", env) for n in ("wa", "wb")}
        try:
            wait_until(lambda: alive_workers(session) == {"wa", "wb"}, STARTUP_S, "both workers up", workers.values())
            runs = [daq.announce(f"p{i:02d}") for i in range(n_runs)]
            wait_until(lambda: (work / "r3.log").exists() and
                       (work / "r3.log").read_text().count("start") >= 2, 60, "both mid-fit", workers.values())
            workers["wa"].send_signal(signal.SIGSTOP)
            paused_at = time.monotonic()
            gate.touch()
            wait_until(lambda: time.monotonic() - paused_at >= pause_s, pause_s + 5, "the pause")
            workers["wa"].send_signal(signal.SIGCONT)
            collector.wait_finals(runs, timeout_s=120)
            # its fit may have ended before the take-over: then the finals alone say what happened
            with contextlib.suppress(TimeoutError):
                wait_until(lambda: "(fenced)" in (work / "wa.log").read_text(), 30, "wa's stale fit fenced")
            doubles, unfitted = _finals_score(collector, runs)
            fenced = (work / "wa.log").read_text().count("(fenced)")
        finally:
            gate.touch()
            workers["wa"].send_signal(signal.SIGCONT)
            codes = [stop(w) for w in workers.values()]
            collector.close()
    return Row("3 paused worker", f"SIGSTOP of one of two workers mid-fit for {pause_s:.0f} s (lease "
               f"{LEASE_MS / 1000:g} s), {n_runs} runs", f"every run reported once; the paused worker fenced "
               f"{fenced}x", crashes=sum(c != 0 for c in codes), double_fits=doubles, unfitted=unfitted)


# --- row 4: abuse of a worker ------------------------------------------------------------------------

def row4_abuse(work: Path) -> list[Row]:
    runs_dir = work / "r4"
    runs_dir.mkdir()
    rows = []
    with router() as (endpoint, session):
        daq = FakeDaq(session, BENCH, runs_dir)
        collector = FitCollector(session)
        worker = start_worker("w4", client_config(work / "w4.json5", endpoint), runs_dir, work,
                              "testkit.fake_fitters:instant_fit", {"FAKE_FIT_LOG": str(work / "r4.log")})
        try:
            wait_until(lambda: "w4" in alive_workers(session), STARTUP_S, "worker up", worker)
            trials: list[tuple[str, Callable[[], Row]]] = [
                ("4a forged final report", lambda: _forged_final(session, daq, collector, worker)),
                ("4b rogue run replier", lambda: _rogue_replier(session, daq, worker, runs_dir, work / "w4.log")),
                ("4c silent replier", lambda: _silent_replier(session, daq, collector, worker)),
                ("4d flood", lambda: _flood(session, daq, collector, worker))]
            for fault, trial in trials:   # one trial that raises is scored, the others still run
                try:
                    rows.append(trial())
                except Exception as exc:  # noqa: BLE001 - scored as a crash of its row
                    rows.append(failed_row(fault, exc))
        finally:
            code = stop(worker)
            collector.close()
    if code != 0:
        rows[-1].crashes += 1
    return rows


def _forged_final(session: zenoh.Session, daq: FakeDaq, collector: FitCollector, worker: Any) -> Row:
    forged = FitReport(bench=BENCH, run_id="forged", worker="mallory", status="ok")
    session.put(keys.run_fit(BENCH, "forged"), forged.to_json_bytes())
    run = daq.announce("forged")
    wait_until(lambda: any(r.worker == "w4" for r in collector.finals().get(run, [])), 60, "the real fit", worker)
    real = [r for r in collector.finals()[run] if r.worker == "w4"]
    return Row("4a forged final report", "a final 'ok' report for a run put before the run is announced",
               f"the run fitted anyway by the worker ({len(real)} real report, {real[0].status})",
               double_fits=len(real) - 1, unfitted=int(real[0].status != "ok"))


def _rogue_replier(session: zenoh.Session, daq: FakeDaq, worker: Any, runs_dir: Path, log: Path) -> Row:
    blob = os.urandom(60 << 20)
    rogue = session.declare_queryable(keys.daq_query(BENCH, "run"), lambda q: q.reply(q.key_expr, blob))
    try:
        before = status_bytes(worker.pid, "VmRSS")
        reset_peak(worker.pid)
        daq.announce("rogue", content=None)   # claims 100 samples: at most 1.2 MB may be fetched
        wait_until(lambda: f"{BENCH}/rogue:" in log.read_text(), 60, "the fetch refused", worker)
        written = sum(p.stat().st_size for p in runs_dir.rglob("rogue*"))
        grown = status_bytes(worker.pid, "VmHWM") - before
    finally:
        rogue.undeclare()
    return Row("4b rogue run replier", "a `daq/run` replier answering 60 MB for a run that claims 100 samples",
               f"refused before writing ({written} bytes on disk); worker peak RSS +{grown / 1e6:.0f} MB over "
               f"{before / 1e6:.0f} MB (the reply Zenoh delivered)",
               over_bound="0" if written == 0 else f"{written} bytes of a refused reply on disk")


def _silent_replier(session: zenoh.Session, daq: FakeDaq, collector: FitCollector, worker: Any) -> Row:
    held: list[zenoh.Query] = []
    silent = session.declare_queryable(keys.daq_query("silent", "run"), held.append)
    other = FakeDaq(session, "silent", daq.runs_dir / "silent-none")
    try:
        started = time.monotonic()
        other.announce("s1", content=None)
        wait_until(lambda: _withdrawn(collector, "s1"), 60, "the silent fetch given up", worker)
        stalled = time.monotonic() - started
        real = daq.announce("after-silent")
        collector.wait_finals([real], timeout_s=60)
        _, unfitted = _finals_score(collector, [real])
    finally:
        held.clear()
        silent.undeclare()
    bound = FETCH_TIMEOUT_S + CLAIM_SLACK_S
    return Row("4c silent replier", "a `daq/run` replier that never answers, then a real run",
               f"the forged run given up after {stalled:.1f} s (fetch bound {FETCH_TIMEOUT_S:g} s, plus the "
               "claim) and deferred; the real run fitted", unfitted=unfitted,
               over_bound="0" if stalled <= bound else f"stalled {stalled:.1f} s > {bound:g} s")


def _flood(session: zenoh.Session, daq: FakeDaq, collector: FitCollector, worker: Any) -> Row:
    before = status_bytes(worker.pid, "VmRSS")
    reset_peak(worker.pid)   # its peak from here on is the flood's (the kernel's high-water mark)
    blob = os.urandom(3 << 20)
    for i in range(600):
        session.put(keys.run_fit(BENCH, f"flood{i % 50}"), blob)
    real = daq.announce("after-flood")
    collector.wait_finals([real], timeout_s=90)
    peak = status_bytes(worker.pid, "VmHWM")
    _, unfitted = _finals_score(collector, [real])
    grown, bound = peak - before, 2 * MAX_QUEUED_BYTES
    return Row("4d flood", "600 puts of 3 MB on the fit keys, then a real run",
               f"worker RSS {before / 1e6:.0f} MB -> peak {peak / 1e6:.0f} MB (kernel high-water mark); the real "
               "run fitted", unfitted=unfitted,
               over_bound="0" if grown <= bound else f"+{grown / 1e6:.0f} MB > {bound / 1e6:.0f} MB")



__all__ = ["LEASE_MS", "router", "row2_daq_gone", "row3_pause", "row4_abuse", "row11_worker_start"]
