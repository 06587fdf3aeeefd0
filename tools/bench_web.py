"""Benchmark of the bench page's display path at a real-time 1 kHz two-encoder stream.

A `daq run` on `sim://` (two carts, 1 kHz, real time, the `both` case repeated) publishes
batches on Zenoh; the page server (`python -m daq.web`, its own process) decimates them
for display and pushes them by server-sent events to one headless Chromium page and one
plain SSE client. Over a measurement window it reports:

- samples/s reaching the page server (its `/api/stats`);
- for the SSE client: samples/s represented, points/s delivered (after decimation),
  updates/s (events carrying samples) and bytes/s on the wire;
- for the browser page (its `window.cartlab` counters): samples/s, points/s, updates/s,
  canvas frames/s, milliseconds per frame spent drawing and the main-thread share spent in
  drawing plus event handling;
- CPU share of one core of the page server and of the daq;
- the page paused (its Pause button) for the same window: frames drawn, main-thread share
  and CPU of the whole Chromium process tree, against the same figures live;
- how long after navigation a freshly opened page has drawn its history (median of 5
  reloads), and how many points it held.

    .venv/bin/python tools/bench_web.py [--rate-hz 1000] [--seconds 15] [--display-hz 250]
"""

from __future__ import annotations

import argparse
import contextlib
import http.client
import json
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from testkit.benchkit import Bench, sim_url
from testkit.ports import endpoint, free_port
from testkit.waiting import wait_until
from testkit.web_harness import PageProcess, chromium_driver, cpu_seconds

BENCH = "bench1"
BROWSER_COUNTERS = ("samplesRaw", "pointsReceived", "sampleEvents", "framesDrawn", "drawMs", "handlerMs")


@dataclass
class SseCounts:
    samples: int = 0
    points: int = 0
    updates: int = 0
    wire_bytes: int = 0


class SseClient(threading.Thread):
    """Counts what one plain event-stream client receives."""

    def __init__(self, port: int) -> None:
        super().__init__(daemon=True)
        self.port = port
        self.counts = SseCounts()
        self.lock = threading.Lock()
        self.stop = threading.Event()

    def run(self) -> None:
        conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=10)
        conn.request("GET", f"/api/events?bench={BENCH}")
        resp = conn.getresponse()
        event = ""
        while not self.stop.is_set():
            line = resp.readline()
            if not line:
                return
            with self.lock:
                self.counts.wire_bytes += len(line)
            text = line.decode().rstrip("\n")
            if text.startswith("event: "):
                event = text[7:]
            elif text.startswith("data: ") and event == "samples":
                data = json.loads(text[6:])
                with self.lock:
                    self.counts.samples += data["n_raw"]
                    self.counts.points += len(data["t_s"])
                    self.counts.updates += 1
        conn.close()

    def snapshot(self) -> SseCounts:
        with self.lock:
            return SseCounts(**vars(self.counts))


def stats(port: int) -> dict[str, Any]:
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=5)
    conn.request("GET", "/api/stats")
    data: dict[str, Any] = json.loads(conn.getresponse().read())
    conn.close()
    return data


def browser_counters(driver: Any) -> dict[str, float]:
    return dict(driver.execute_script(
        "const c = window.cartlab; return {" + ", ".join(f"{k}: c.{k}" for k in BROWSER_COUNTERS) + "};"))


def tree_cpu_seconds(root: int) -> float:
    """CPU seconds of a process and all its descendants (Linux /proc): the whole browser."""
    children: dict[int, list[int]] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            own, rest = stat.read_text().split(" ", 1)
            children.setdefault(int(rest.rsplit(")", 1)[1].split()[1]), []).append(int(own))
        except (OSError, ValueError, IndexError):
            continue                                   # a process that ended meanwhile
    total, todo = 0.0, [root]
    while todo:
        pid = todo.pop()
        with contextlib.suppress(OSError, ValueError, IndexError):   # ended meanwhile
            total += cpu_seconds(pid)
        todo.extend(children.get(pid, []))
    return total


def browser_window(driver: Any, seconds: float) -> dict[str, float]:
    """Frames/s, main-thread busy % and browser-tree CPU % of one core over `seconds`."""
    root = driver.service.process.pid
    b0, c0, t0 = browser_counters(driver), tree_cpu_seconds(root), time.monotonic()
    threading.Event().wait(seconds)
    b1, c1, t1 = browser_counters(driver), tree_cpu_seconds(root), time.monotonic()
    wall = t1 - t0
    return {"frames_per_s": (b1["framesDrawn"] - b0["framesDrawn"]) / wall,
            "busy_percent": ((b1["drawMs"] - b0["drawMs"]) + (b1["handlerMs"] - b0["handlerMs"])) / wall / 10,
            "cpu_percent": 100 * (c1 - c0) / wall}


def history_load_ms(driver: Any, url: str, times: int = 5) -> tuple[float, float]:
    """Median ms from navigation to the history drawn, and the points it held."""
    loads, points = [], 0.0
    for _ in range(times):
        driver.get(url)
        ms = wait_until(lambda: driver.execute_script("return window.cartlab.historyLoadedMs"), 20, "the history")
        wait_until(lambda: driver.execute_script("return !window.cartlab.trace.dirty"), 5, "the first frame")
        loads.append(float(ms))
        points = float(driver.execute_script("return window.cartlab.historyPoints"))
    return sorted(loads)[len(loads) // 2], points


def measure(rate_hz: float, seconds: float, display_hz: float) -> None:
    with tempfile.TemporaryDirectory(prefix="cartlab-benchweb-") as tmp:
        work = Path(tmp)
        runs = work / "runs"
        runs.mkdir()
        page_ep = endpoint()
        with Bench(work) as bench:
            page = PageProcess(free_port(), ["--listen", page_ep, "--connect", bench.endpoint,
                                             "--display-hz", str(display_hz)], runs, work / "page.log")
            driver = None
            sse = None
            try:
                wait_until(page.ready, 20, "the page server")
                url = sim_url(["both"], rate_hz=rate_hz, realtime=True, repeat=1000, rest_s=1,
                              pull_s=1.0, hold_s=1.5)
                daq = bench.start_daq("daq", url, BENCH, runs, extra=["--connect", page_ep])
                wait_until(lambda: stats(page.port)["samples_in"] > 0, 30, "samples at the page server")
                driver = chromium_driver(work / "profile")
                driver.get(page.url + "/")
                sse = SseClient(page.port)
                sse.start()
                wait_until(lambda: driver.execute_script("return window.cartlab.framesDrawn") > 10, 20,
                           "the page drawing")
                pause = threading.Event()
                pause.wait(1.0)                      # warm-up: JIT, first layout
                s0, b0, e0 = stats(page.port), browser_counters(driver), sse.snapshot()
                cpu0 = (cpu_seconds(page.proc.pid), cpu_seconds(daq.popen.pid), time.monotonic())
                pause.wait(seconds)
                s1, b1, e1 = stats(page.port), browser_counters(driver), sse.snapshot()
                cpu1 = (cpu_seconds(page.proc.pid), cpu_seconds(daq.popen.pid), time.monotonic())
                live = browser_window(driver, seconds)
                driver.find_element("id", "pause-btn").click()
                paused = browser_window(driver, seconds)
                load_ms, load_points = history_load_ms(driver, page.url + "/")
            finally:
                if sse is not None:
                    sse.stop.set()
                if driver is not None:
                    driver.quit()
                page.stop()
    wall = cpu1[2] - cpu0[2]
    rate = {k: (b1[k] - b0[k]) / wall for k in BROWSER_COUNTERS}
    frames = max(b1["framesDrawn"] - b0["framesDrawn"], 1)
    print(f"display path at a {rate_hz:g} Hz two-encoder stream, {wall:.1f} s window, "
          f"display decimation {display_hz:g} points/s per cart")
    print(f"  into the page server      {(s1['samples_in'] - s0['samples_in']) / wall:8.0f} samples/s")
    print(f"  SSE client                {(e1.samples - e0.samples) / wall:8.0f} samples/s  "
          f"{(e1.points - e0.points) / wall:6.0f} points/s  {(e1.updates - e0.updates) / wall:5.1f} updates/s  "
          f"{(e1.wire_bytes - e0.wire_bytes) / wall / 1024:6.1f} KiB/s")
    print(f"  browser page              {rate['samplesRaw']:8.0f} samples/s  {rate['pointsReceived']:6.0f} points/s  "
          f"{rate['sampleEvents']:5.1f} updates/s  {rate['framesDrawn']:5.1f} frames/s")
    print(f"  browser main thread       {(b1['drawMs'] - b0['drawMs']) / frames:8.2f} ms per frame drawn  "
          f"{((b1['drawMs'] - b0['drawMs']) + (b1['handlerMs'] - b0['handlerMs'])) / wall / 10:5.2f} % busy "
          "(drawing + event handlers)")
    for name, w in (("live", live), ("paused", paused)):
        print(f"  browser page {name:<7}      {w['frames_per_s']:5.1f} frames/s  "
              f"main thread {w['busy_percent']:5.2f} % busy  "
              f"Chromium processes {w['cpu_percent']:5.1f} % of a core")
    print(f"  page opened               history drawn {load_ms:6.0f} ms after navigation (median of 5), "
          f"{load_points:.0f} points")
    print(f"  CPU, one core             page server {100 * (cpu1[0] - cpu0[0]) / wall:5.1f} %   "
          f"daq {100 * (cpu1[1] - cpu0[1]) / wall:5.1f} %   (1 browser page + 1 SSE client)")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--rate-hz", type=float, default=1000.0, help="encoder sample rate (default 1000)")
    parser.add_argument("--seconds", type=float, default=15.0, help="measurement window (default 15)")
    parser.add_argument("--display-hz", type=float, default=250.0,
                        help="points/s per cart sent to pages (the server's --display-hz, default 250)")
    args = parser.parse_args(argv)
    measure(args.rate_hz, args.seconds, args.display_hz)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
