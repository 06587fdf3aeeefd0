"""Benchmark of the `daq` service: end-to-end throughput and CPU share at a real-time 1 kHz stream.

1. Throughput: a `sim://` capture (two encoders, 1 kHz, the three lab cases repeated) is
   replayed through `replay://<file>?speed=max` by the real service (decode, zero, detect,
   publish on Zenoh to a subscriber in another process, record MCAP), in this process,
   pinned to one core. Prints lines/s (decoder lines / wall time, start-up included) and
   lines per CPU-second (the same over this process's CPU time: steadier on a shared machine).
2. CPU share: the same capture is written at real time (1,000 lines/s) into a pseudo-terminal
   by this process; `daq run` reads the pty as a serial port in a child process and publishes
   to a subscriber in another process; the child's
   CPU time (utime + stime from /proc) over a window, divided by the wall time, is its share
   of one core.

    .venv/bin/python tools/bench_daq.py [--lines 200000] [--realtime-s 15]

Targets (issue 2): >= 50,000 lines/s; <= 5 % of a core at 1 kHz.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from testkit import ports
from testkit.repo import REPO

SIM = ("sim://?realtime=0&rate_hz=1000&cases=cart1,cart2,both&repeat={repeat}&seed=1&c1=2&c2=2"
       "&rest_s=1&hold_s=1.5&substep_hz=2000")
SUBSCRIBER = """
import sys, time, zenoh
conf = zenoh.Config.from_json5(sys.argv[1])
count = [0]
with zenoh.open(conf) as s:
    sub = s.declare_subscriber(sys.argv[2], lambda smp: count.__setitem__(0, count[0] + 1))
    sys.stdout.write("ready\\n"); sys.stdout.flush()
    sys.stdin.readline()
    sub.undeclare()
    print(count[0])
"""


def make_capture(path: Path, min_lines: int) -> int:
    """A deterministic `sim://` byte stream with at least `min_lines` lines; returns the line count."""
    from daq.sim.options import parse_sim_url
    from daq.sim.rig import Rig

    repeat = max(1, min_lines // 30_000 + 1)
    rig = Rig(parse_sim_url(SIM.format(repeat=repeat)))
    with open(path, "wb") as out:
        for _ in range(10_000_000):
            if rig.finished:
                break
            rig.produce_bytes(1 << 20)
            out.write(rig.take(1 << 20))
    return path.read_bytes().count(b"\n")


def start_subscriber(endpoint: str, key: str) -> subprocess.Popen[str]:
    from schemas.bus import BusConfig

    proc = subprocess.Popen([sys.executable, "-c", SUBSCRIBER, BusConfig.connector(endpoint).zenoh_json5(), key],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None and proc.stdout.readline().strip() == "ready"
    return proc


def stop_subscriber(proc: subprocess.Popen[str]) -> int:
    out, _ = proc.communicate("\n", timeout=30)
    return int(out.strip() or 0)


def throughput(capture: Path, workdir: Path) -> None:
    from daq.service import Service, ServiceConfig
    from schemas import keys
    from schemas.bus import BusConfig

    os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})   # this thread and Zenoh's: one core
    endpoint = ports.endpoint()
    config = ServiceConfig(port=f"replay://{capture}?speed=max", runs_dir=workdir / "runs_max", bench="bench",
                           bus=BusConfig.listener(endpoint), until_eof=True)
    service = Service(config)
    subscriber: subprocess.Popen[str] | None = None

    def connect_subscriber_when_up() -> None:
        nonlocal subscriber
        subscriber = start_subscriber(endpoint, keys.samples("bench"))

    # the subscriber connects while the service starts (its first batches may go unseen)
    starter = threading.Thread(target=connect_subscriber_when_up)
    starter.start()
    cpu0, wall0 = time.process_time(), time.perf_counter()
    n_runs = service.run()
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    starter.join()
    received = stop_subscriber(subscriber) if subscriber is not None else 0
    lines = service.acq.decoder.counters.lines
    print(f"throughput  replay speed=max, 1 core: {lines} lines in {wall:.2f} s wall = {lines / wall:,.0f} lines/s; "
          f"{cpu:.2f} s CPU = {lines / cpu:,.0f} lines per CPU-second; {n_runs} runs recorded; "
          f"{received} sample batches received by a subscriber in another process")


def cpu_share(capture: Path, workdir: Path, seconds: float) -> None:
    from schemas import keys

    master, slave = os.openpty()
    pty_path = os.ttyname(slave)
    lines = capture.read_bytes().splitlines(keepends=True)
    endpoint = ports.endpoint()
    child = subprocess.Popen([sys.executable, "-m", "daq.cli", "run", "--port", pty_path, "--listen", endpoint,
                              "--runs-dir", str(workdir / "runs_rt"), "--bench", "bench"], cwd=REPO,
                             stderr=subprocess.PIPE, text=True)
    stop = threading.Event()

    def feed() -> None:
        start = time.monotonic()
        sent = 0
        while not stop.is_set() and sent < len(lines):
            due = min(len(lines), int((time.monotonic() - start) * 1000.0))
            if due > sent:
                os.write(master, b"".join(lines[sent:due]))
                sent = due
            stop.wait(0.005)

    feeder = threading.Thread(target=feed, daemon=True)
    subscriber: subprocess.Popen[str] | None = None
    try:
        time.sleep(1.5)   # benchmark script, not a test: let the child import and open the pty
        subscriber = start_subscriber(endpoint, keys.samples("bench"))
        feeder.start()
        time.sleep(1.0)
        cpu0, t0 = _proc_cpu_s(child.pid), time.monotonic()
        time.sleep(seconds)
        cpu1, t1 = _proc_cpu_s(child.pid), time.monotonic()
        share = (cpu1 - cpu0) / (t1 - t0)
        print(f"cpu share   real-time 1 kHz, 2 encoders, pty: {share * 100:.2f} % of one core "
              f"({cpu1 - cpu0:.2f} s CPU over {t1 - t0:.1f} s)")
    finally:
        stop.set()
        received = stop_subscriber(subscriber) if subscriber is not None else 0
        child.terminate()
        _, err = child.communicate(timeout=30)
        os.close(master)
        os.close(slave)
    runs = [line for line in err.splitlines() if " run " in line]
    print(f"            {received} sample batches received by a subscriber in another process; "
          f"daq log: {len(runs)} run lines, e.g. {runs[:1]}")


def _proc_cpu_s(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    ticks = int(fields[11]) + int(fields[12])   # utime, stime
    return ticks / os.sysconf("SC_CLK_TCK")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--lines", type=int, default=200_000)
    parser.add_argument("--realtime-s", type=float, default=15.0)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        workdir = Path(tmp)
        capture = workdir / "capture.bin"
        n = make_capture(capture, args.lines)
        print(f"machine     {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f} (wall figures suffer "
              "when others use the cores; CPU-second figures much less)")
        print(f"capture     {n} lines, {capture.stat().st_size / 1e6:.1f} MB (sim, 1 kHz, 2 encoders)")
        cpu_share(capture, workdir, args.realtime_s)
        throughput(capture, workdir)
    return 0


if __name__ == "__main__":
    sys.exit(main())
