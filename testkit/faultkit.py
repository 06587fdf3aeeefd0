"""Process-fault trials shared by `tests/daq/test_faults_process.py` and `tools/bench_faults.py`.

`kill9_trial`: a `daq run` process on a real-time `sim://` rig (one run with light damping,
so it rings for many seconds) is killed with SIGKILL at a chosen moment after its run file
appeared; a Zenoh subscriber records the last sample the daq published before it died
(the reference for "samples before the kill"). Then `daq` is started again on the same
runs directory (a short finite rig, `--until-eof`), which recovers the `.part` at start-up.

Measured per trial: seconds of samples lost (last published sample minus last sample in
the recovered file), holes inside the file (any step other than one sample period), and
whether the recovered file is complete and announced as `recovered`.
"""

from __future__ import annotations

import queue
import random
import signal
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import zenoh

from daq.run_file import load_run
from schemas import keys
from schemas.bus import BusConfig
from schemas.daq import SampleBatch
from testkit import ports
from testkit.repo import REPO
from testkit.waiting import wait_until

RATE_HZ = 200
PERIOD_NS = 1_000_000_000 // RATE_HZ


def daq_process(args: list[str], log: Path) -> subprocess.Popen[bytes]:
    return subprocess.Popen([sys.executable, "-m", "daq.cli", *args], cwd=REPO,
                            stdout=log.open("wb"), stderr=subprocess.STDOUT)


@dataclass(frozen=True)
class Kill9Result:
    seed: int
    kill_after_s: float
    samples_before_kill: int      # in the salvaged .part
    lost_s: float                 # last sample received from the bus - last sample kept; negative when
                                  # the file is ahead: batches still in the killed daq's send queue die with it
    holes: int                    # steps != one period inside the file
    recovered: bool               # .part gone, .mcap complete, status "recovered", same samples

    @property
    def ok(self) -> bool:
        return self.recovered and self.holes == 0 and self.lost_s <= 0.5


def kill9_trial(workdir: Path, seed: int, kill_after_s: float) -> Kill9Result:
    """One kill -9 mid-run and a restart; see the module docstring."""
    runs = workdir / "runs"
    workdir.mkdir(parents=True, exist_ok=True)
    bench = f"kill{seed}"
    endpoint = ports.endpoint()
    sim = (f"sim://?realtime=1&rate_hz={RATE_HZ}&cases=cart1&seed={seed}&rest_s=0.3&pull_s=0.4&hold_s=0.7"
           "&c1=0.2&ring_max_s=30")
    proc = daq_process(["run", "--port", sim, "--bench", bench, "--runs-dir", str(runs), "--listen", endpoint],
                       workdir / "daq.log")
    latest = [0]
    arrived: queue.SimpleQueue[int] = queue.SimpleQueue()

    def on_sample(sample: zenoh.Sample) -> None:
        t_last = SampleBatch.from_json_bytes(sample.payload.to_bytes()).t_ns[-1]
        latest[0] = max(latest[0], t_last)
        arrived.put(t_last)

    session = zenoh.open(zenoh.Config.from_json5(BusConfig.connector(endpoint).zenoh_json5()))
    try:
        sub = session.declare_subscriber(keys.samples(bench), on_sample)
        wait_until(lambda: latest[0] > 0, 60, "live samples from the daq", proc)
        part = wait_until(lambda: sorted(runs.glob("*.mcap.part")), 60, "a run file to be opened", proc)[0]
        deadline = time.monotonic() + kill_after_s
        wait_until(lambda: time.monotonic() >= deadline, kill_after_s + 5, "the kill moment", proc)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)
        # What the daq got onto the wire before it died has arrived once its liveliness token is gone.
        wait_until(lambda: not list(session.liveliness().get(keys.daq_alive(bench), timeout=0.5)), 10,
                   "the killed daq's liveliness token to go")
        sub.undeclare()
    finally:
        session.close()
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=10)
    salvaged = load_run(part)
    lost_s = (latest[0] - int(salvaged.t_ns[-1])) / 1e9 if salvaged.t_ns.size else float("inf")
    holes = int(np.count_nonzero(np.diff(salvaged.t_ns) != PERIOD_NS))
    restart = daq_process(["run", "--port", "sim://?realtime=0&cases=none&duration_s=0.1", "--bench", bench,
                           "--runs-dir", str(runs), "--no-zenoh", "--until-eof"], workdir / "restart.log")
    code = restart.wait(timeout=60)
    final = part.with_name(part.name.removesuffix(".part"))
    recovered = code == 0 and not part.exists() and final.is_file()
    if recovered:
        run = load_run(final)
        recovered = (run.complete and run.finished is not None and run.finished.status == "recovered"
                     and run.t_ns.tolist() == salvaged.t_ns.tolist())
    return Kill9Result(seed, kill_after_s, int(salvaged.t_ns.size), lost_s, holes, recovered)


def kill9_trials(workdir: Path, n: int, seed: int = 0, parallel: int = 3,
                 max_after_s: float = 4.0) -> list[Kill9Result]:
    """`n` trials at seeded random moments in [0.05, max_after_s] s after the run file appeared."""
    rng = random.Random(seed)
    moments = [(seed * 1000 + i, round(rng.uniform(0.05, max_after_s), 3)) for i in range(n)]
    with ThreadPoolExecutor(max_workers=parallel) as pool:
        futures = [pool.submit(kill9_trial, workdir / f"trial{i:02d}", s, after)
                   for i, (s, after) in enumerate(moments)]
        return [f.result() for f in futures]


__all__ = ["PERIOD_NS", "RATE_HZ", "Kill9Result", "daq_process", "kill9_trial", "kill9_trials"]
