"""The rows of issue 14, each tried for real (loopback only) and scored: `tools/bench_faults.py --issue14`.

Each function makes one fault happen the way the independent fault test did, and returns a
`Row`: the fault, what was tried, the outcome, and the four scores the issue asks for (data
lost, crashes, double fits, runs left unfitted). Workers run as `ident worker` processes
connected as clients to a router in this process, which also plays the daq (`FakeDaq`), the
attacker, and the collector of every fit message.
"""

from __future__ import annotations

import contextlib
import errno
import itertools
import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np
import zenoh

from schemas import keys, run_file
from schemas.bus import BusConfig
from schemas.fit import FitReport
from testkit import ports
from testkit.waiting import wait_until
from testkit.worker_harness import FakeDaq, FitCollector, alive_workers, start_worker, stop

REPO = Path(__file__).resolve().parents[1]
BENCH = "bench1"
LEASE_MS = 3000


@dataclass
class Row:
    """One fault and its scores (the targets are all zero)."""

    fault: str
    tried: str
    outcome: str
    data_lost: str = "0"
    crashes: int = 0
    double_fits: int = 0
    unfitted: int = 0

    @property
    def ok(self) -> bool:
        return self.data_lost == "0" and not (self.crashes or self.double_fits or self.unfitted)


def print_table(rows: list[Row]) -> None:
    head = ("fault", "what was tried", "outcome", "data lost", "crashes", "double fits", "unfitted")
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for r in rows:
        print(f"| {r.fault} | {r.tried} | {r.outcome} | {r.data_lost} | {r.crashes} | {r.double_fits} | "
              f"{r.unfitted} |", flush=True)


# --- helpers ------------------------------------------------------------------------------------

def _run(args: list[str], cwd: Path, timeout_s: float = 600) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, *args], cwd=cwd, capture_output=True, text=True, timeout=timeout_s,
                          env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})


def record_sim(directory: Path, url: str) -> Path:
    _run(["-m", "daq.cli", "run", "--port", url, "--bench", BENCH, "--runs-dir", str(directory),
          "--no-zenoh", "--until-eof"], REPO).check_returncode()
    return next(directory.glob("*.mcap"))


def _client_config(path: Path, endpoint: str) -> list[str]:
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


def _rss_bytes(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) * 1024
    return 0


def _finals_score(collector: FitCollector, runs: list[Any]) -> tuple[int, int]:
    finals = collector.finals()
    return sum(max(0, len(finals.get(r, [])) - 1) for r in runs), sum(1 for r in runs if not finals.get(r))


# --- row 1: NaN-safe diagnosis --------------------------------------------------------------------

def row1_diagnosis(work: Path) -> Row:
    run = record_sim(work / "r1", "sim://?cases=cart1&rate_hz=1000&seed=3&realtime=0")
    half = work / "r1" / "half.mcap"
    data = run.read_bytes()
    half.write_bytes(data[: len(data) // 2])
    outcomes = []
    crashes = 0
    for path in (run, half):
        done = _run(["-m", "ident.cli", "diagnose", str(path), "--json"], REPO)
        ok = done.returncode == 0 and "Traceback" not in done.stderr
        crashes += not ok
        if ok:
            report = json.loads(done.stdout)
            outcomes.append(f"{path.name.split('.')[0][:4]}: cause {report.get('cause')}, "
                            f"fit {report['baseline']['fit_percent']:.2f} %")
        else:
            outcomes.append(f"{path.name}: exit {done.returncode}")
    return Row("1 diagnosis crash", "ident diagnose on a clean 1 kHz one-cart sim:// run and a half-truncated copy",
               "; ".join(outcomes), crashes=crashes)


# --- row 2: transient failures retried ----------------------------------------------------------------

def row2_daq_gone(work: Path) -> Row:
    runs_dir = work / "r2"
    runs_dir.mkdir()
    with router() as (endpoint, session):
        daq = FakeDaq(session, BENCH, runs_dir)
        collector = FitCollector(session)
        worker = start_worker("w2", _client_config(work / "w2.json5", endpoint), runs_dir / "worker", work,
                              "testkit.fake_fitters:instant_fit", {"FAKE_FIT_LOG": str(work / "r2.log")})
        try:
            wait_until(lambda: "w2" in alive_workers(session), 60, "worker up", worker)
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
        workers = {n: start_worker(n, _client_config(work / f"{n}.json5", endpoint), runs_dir, work,
                                   "testkit.fake_fitters:gated_fit", env) for n in ("wa", "wb")}
        try:
            wait_until(lambda: alive_workers(session) == {"wa", "wb"}, 60, "both workers up", workers.values())
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
        worker = start_worker("w4", _client_config(work / "w4.json5", endpoint), runs_dir, work,
                              "testkit.fake_fitters:instant_fit", {"FAKE_FIT_LOG": str(work / "r4.log")})
        try:
            wait_until(lambda: "w4" in alive_workers(session), 60, "worker up", worker)
            rows.append(_forged_final(session, daq, collector, worker))
            rows.append(_rogue_replier(session, daq, worker, runs_dir, work / "w4.log"))
            rows.append(_silent_replier(session, daq, collector, worker))
            rows.append(_flood(session, daq, collector, worker))
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
               f"the run fitted anyway by the worker ({len(real)} real report)", double_fits=len(real) - 1)


def _rogue_replier(session: zenoh.Session, daq: FakeDaq, worker: Any, runs_dir: Path, log: Path) -> Row:
    blob = os.urandom(60 << 20)
    rogue = session.declare_queryable(keys.daq_query(BENCH, "run"), lambda q: q.reply(q.key_expr, blob))
    try:
        before = _rss_bytes(worker.pid)
        daq.announce("rogue", content=None)   # claims 100 samples: at most 1.2 MB may be fetched
        wait_until(lambda: f"{BENCH}/rogue:" in log.read_text(), 60, "the fetch refused", worker)
        written = sum(p.stat().st_size for p in runs_dir.rglob("rogue*"))
        grown = _rss_bytes(worker.pid) - before
    finally:
        rogue.undeclare()
    return Row("4b rogue run replier", "a `daq/run` replier answering 60 MB for a run that claims 100 samples",
               f"refused before writing ({written} bytes on disk), worker RSS +{grown / 1e6:.0f} MB",
               data_lost="0")


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
    finally:
        held.clear()
        silent.undeclare()
    return Row("4c silent replier", "a `daq/run` replier that never answers, then a real run",
               f"the forged run given up after {stalled:.1f} s (bound 5 s + claim) and deferred; the real run fitted")


def _flood(session: zenoh.Session, daq: FakeDaq, collector: FitCollector, worker: Any) -> Row:
    before = _rss_bytes(worker.pid)
    blob = os.urandom(3 << 20)
    peak = before
    for i in range(600):
        session.put(keys.run_fit(BENCH, f"flood{i % 50}"), blob)
        if i % 50 == 0:
            peak = max(peak, _rss_bytes(worker.pid))
    real = daq.announce("after-flood")
    collector.wait_finals([real], timeout_s=90)
    peak = max(peak, _rss_bytes(worker.pid))
    return Row("4d flood", "600 puts of 3 MB on the fit keys, then a real run",
               f"worker RSS {before / 1e6:.0f} -> peak {peak / 1e6:.0f} MB; the real run fitted")


# --- row 5: full disk --------------------------------------------------------------------------------

class _Disk:
    def __init__(self, budget: int, refusals_until_space: int) -> None:
        self.budget, self.refusals, self.until = budget, 0, refusals_until_space

    def take(self, n: int) -> None:
        if n > self.budget:
            self.refusals += 1
            if self.refusals >= self.until:
                self.budget = 1 << 40
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        self.budget -= n

    def opener(self, path: Path) -> BinaryIO:
        self.take(1)
        handle = open(path, "xb")  # noqa: SIM115 - returned to the writer, which closes it
        disk = self

        class _OnDisk:
            def write(self, data: bytes) -> int:
                disk.take(len(data))
                return handle.write(data)

            def __getattr__(self, name: str) -> Any:
                return getattr(handle, name)

        return _OnDisk()  # type: ignore[return-value]


def _service_run(url: str, runs_dir: Path, disk: _Disk) -> tuple[Any, int]:
    from daq.serial_link import SerialLink
    from daq.service import Service, ServiceConfig

    ticks = itertools.count()
    service = Service(ServiceConfig(port=url, runs_dir=runs_dir, bench=BENCH, bus=None, until_eof=True),
                      clock=lambda: next(ticks) * 1e-2, link=SerialLink(url, sleep=lambda _s: None),
                      opener=disk.opener)
    try:
        service.run()
    except Exception:  # noqa: BLE001 - a crash is what this row counts
        return service, 1
    return service, 0


def row5_full_disk(work: Path) -> Row:
    from daq.run_file import load_run

    url = "sim://?realtime=0&rate_hz=500&cases=cart1&seed=21&rest_s=1&pull_s=0.6&hold_s=1&tail_s=1"
    _, crashed = _service_run(url, work / "r5", _Disk(60_000, 3))
    _service_run(url, work / "r5-clean", _Disk(1 << 40, 1 << 30))
    recorded = [load_run(p) for p in sorted((work / "r5").glob("*.mcap"))]
    written = set().union(*(set(r.t_ns.tolist()) for r in recorded))
    whole = set().union(*(set(load_run(p).t_ns.tolist()) for p in (work / "r5-clean").glob("*.mcap")))
    missing = len(whole - written)
    gaps = [g for r in recorded if r.metadata for g in r.metadata.counters.gap_intervals if g.reason == "disk_full"]
    statuses = ", ".join(r.finished.status for r in recorded if r.finished)
    return Row("5 full disk", "ENOSPC injected at the file layer mid-run, space back after 3 refused writes",
               f"run kept going (live stream untouched): {len(recorded)} files ({statuses}), the batches kept in "
               f"memory while full written first; {len(gaps)} gaps marked; path and run named in the log",
               data_lost=str(missing), crashes=crashed)


# --- rows 6 and 7: recovery ---------------------------------------------------------------------------

def row6_recover(work: Path) -> Row:
    runs = work / "r6"
    run = record_sim(runs, "sim://?cases=cart1&rate_hz=1000&seed=5&realtime=0")
    before = run.read_bytes()
    stale = runs / f"{run_file.run_id_of(run)}{run_file.PART_SUFFIX}"
    stale.write_bytes(before[: len(before) // 3])          # a stale part beside the finished file
    junk = runs / "junk.mcap.part"
    junk.write_bytes(os.urandom(4096))
    done = _run(["-m", "daq.cli", "recover", str(runs)], REPO)
    intact = run.read_bytes() == before
    quarantined = (runs / run_file.QUARANTINE_DIR / "junk.mcap.part").is_file()
    recovered = list(runs.glob("*-r1.mcap"))
    lost = "0" if intact and quarantined and recovered else "finished run or part lost"
    return Row("6 daq recover", "a finished run with a stale .part beside it, and an unreadable .part",
               f"finished file intact: {intact}; stale part into {recovered[0].name if recovered else '-'}; "
               f"unreadable part quarantined: {quarantined}", data_lost=lost, crashes=int(done.returncode != 0))


def row7_odd_entries(work: Path) -> Row:
    runs = work / "r7"
    runs.mkdir()
    (runs / "dir.mcap.part").mkdir()
    (runs / "loop.mcap.part").symlink_to(runs / "loop.mcap.part")
    done = _run(["-m", "daq.cli", "recover", str(runs)], REPO)
    started = _run(["-m", "daq.cli", "run", "--port", "sim://?cases=cart1&rate_hz=200&seed=2&realtime=0",
                    "--bench", BENCH, "--runs-dir", str(runs), "--no-zenoh", "--until-eof"], REPO)
    return Row("7 odd entries", "a directory and a symlink loop named *.mcap.part in the runs directory",
               f"daq recover exit {done.returncode} (skipped, named), daq run exit {started.returncode}, "
               f"{len(list(runs.glob('*.mcap')))} run recorded", crashes=int(done.returncode != 0)
               + int(started.returncode != 0))


# --- row 8: memory per input --------------------------------------------------------------------------

_PEAK = """
import resource, sys
from pathlib import Path
import ident.io
from ident.errors import IdentError
ident.io.load(Path(sys.argv[2]), release_time_s=1.0)
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
try:
    data = ident.io.load(Path(sys.argv[1]), release_time_s=1.0)
    outcome = f"loaded {data.y.shape[0]} samples"
except (IdentError, ValueError) as exc:
    outcome = f"refused: {str(exc)[:70]}"
print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024 - base)
print(outcome)
"""


def _peak(path: Path, small: Path) -> tuple[int, str]:
    out = _run(["-c", _PEAK, str(path), str(small)], REPO, timeout_s=1800).stdout.splitlines()
    return int(out[0]), out[1]


def row8_memory(work: Path, csv_mb: float) -> list[Row]:
    folder = work / "r8"
    folder.mkdir()
    small = folder / "small.csv"
    t = np.arange(3000) / 1000.0
    x = np.where(t < 1.0, 0.0, 0.1 * (1 - np.cos(11 * np.clip(t - 1.0, 0.0, None))))
    np.savetxt(small, np.column_stack([t, x, 0.3 * x]), delimiter=",", header="time_s,pos1_m,pos2_m", comments="")
    big = folder / "big.csv"
    n = int(csv_mb * 1e6 / 32)
    with big.open("w") as out:
        out.write("time_s,pos1_m,pos2_m\n")
        rng = np.random.default_rng(1)
        for start in range(0, n, 200_000):
            tt = np.arange(start, min(n, start + 200_000)) / 1000.0
            xx = np.where(tt < 1.0, 0.0, 0.15 * (1 - np.exp(-0.01 * (tt - 1.0)) * np.cos(11 * (tt - 1.0))))
            block = np.column_stack([tt, xx, 0.3 * xx + rng.normal(0, 1e-6, tt.size)])
            np.savetxt(out, block, delimiter=",", fmt="%.9g")
    sparse = folder / "sparse.csv"
    with sparse.open("wb") as handle:
        handle.truncate(1 << 30)
    bomb = folder / "bomb.mcap"
    _write_bomb(bomb)
    rows = []
    for label, path in (("CSV", big), ("1 GiB sparse file", sparse), ("compressed MCAP bomb", bomb)):
        size = path.stat().st_size
        grown, outcome = _peak(path, small)
        data = size if path is not sparse else 0
        within = grown <= 2 * max(data, 1) or outcome.startswith("refused")
        rows.append(Row(f"8 memory: {label}", f"ident.io.load of a {size / 1e6:.1f} MB {label}",
                        f"{outcome}; peak RSS +{grown / 1e6:.0f} MB"
                        + (f" ({grown / size:.2f}x the file)" if data else ""),
                        data_lost="0" if within else f"over 2x ({grown / 1e6:.0f} MB)"))
    return rows


def _write_bomb(path: Path) -> None:
    """A valid daq-style MCAP whose chunks hold the same sample batch over and over: ~2.5 MB on
    disk, well over a GB decompressed (zstd squeezes the repeats)."""
    import struct

    import zstandard

    from schemas import topics
    from schemas.daq import SampleBatch

    def record(opcode: int, body: bytes) -> bytes:
        return struct.pack("<BQ", opcode, len(body)) + body

    def string(text: str) -> bytes:
        raw = text.encode()
        return struct.pack("<I", len(raw)) + raw

    batch = SampleBatch(bench=BENCH, batch_seq=0, t_ns=list(range(2000)), pos1_m=[0.0] * 2000,
                        raw1=[0.0] * 2000).to_json_bytes()
    message = record(0x05, struct.pack("<HIQQ", 1, 0, 0, 0) + batch)
    inner = message * 1500
    packed = zstandard.ZstdCompressor(level=19).compress(inner)
    chunk = record(0x06, struct.pack("<QQQI", 0, 0, len(inner), 0) + string("zstd")
                   + struct.pack("<Q", len(packed)) + packed)
    channel = record(0x04, struct.pack("<HH", 1, 0) + string(topics.SAMPLES) + string("json") + struct.pack("<I", 0))
    with path.open("wb") as out:
        out.write(b"\x89MCAP0\r\n" + record(0x01, string("") + string("bomb")) + channel)
        while out.tell() < 2_500_000:
            out.write(chunk)


# --- row 10: the suite under load ---------------------------------------------------------------------

def row10_load(work: Path, repeat: int) -> Row:
    done = _run(["tools/suite_under_load.py", "--burners", "2", "--repeat", str(repeat),
                 "tests/ident/test_worker_abuse.py", "-q"], REPO, timeout_s=3600)
    lines = [line for line in done.stdout.splitlines() if line.startswith("run ")]
    failed = sum("exit 0" not in line for line in lines)
    outcome = "; ".join(line.split(": ", 1)[-1] for line in lines) or done.stderr[-200:]
    return Row("10 suite under load", f"tests/ident/test_worker_abuse.py {repeat}x with two CPU burners "
               "(tools/suite_under_load.py)", outcome, crashes=failed)


def all_rows(work: Path, csv_mb: float = 224.0, load_repeat: int = 3) -> list[Row]:
    rows = [row1_diagnosis(work), row2_daq_gone(work), row3_pause(work), *row4_abuse(work), row5_full_disk(work),
            row6_recover(work), row7_odd_entries(work), *row8_memory(work, csv_mb), row10_load(work, load_repeat)]
    return rows


__all__ = ["Row", "all_rows", "print_table"]
