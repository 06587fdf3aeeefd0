"""Benchmark: time from a run's end (its `finished` record) to its fit report on Zenoh.

    .venv/bin/python tools/bench_service.py [--runs 5] [--rate-hz 200]

One `ident worker` stays up; for each run a fresh `daq run` records one two-cart run
(`sim://` case `both`, c1 = c2 = 0.5 N·s/m so the carts ring for about 15 s at 200 Hz, as
fast as the simulator computes). Both records are timestamped on arrival at this process's
subscriber, so the figure is what a user waiting for the fit sees:

    latency = t(fit report received) - t(finished record received)

The fit report with the transfer functions, wn, zeta and fit % (simple ID, PEM of order 4)
is published first, with `pending: [diagnosis, figures]`; it includes the worker's claim
settle window (0.2 s), loading the MCAP and the fits. The complete report follows after the
diagnosis and the figures; both latencies are printed. Runs are recorded one
after the other (each fitted before the next starts), so no queueing is measured.
Target: ≤ 2 s. Prints one line per run and the median/max.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path

from testkit.benchkit import Bench, sim_url
from testkit.waiting import wait_until

TARGET_S = 2.0


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--rate-hz", type=float, default=200.0)
    parser.add_argument("--damping", type=float, default=0.5, help="c1 = c2, N·s/m")
    args = parser.parse_args(argv)
    latencies: list[float] = []
    completes: list[float] = []
    with tempfile.TemporaryDirectory(prefix="bench-service-") as tmp, Bench(Path(tmp)) as bench:
        runs = Path(tmp) / "runs"
        worker = bench.start_worker("bench-worker", runs)
        bench.wait_workers({"bench-worker"})
        print(f"{'run':24s} {'samples':>7s} {'length':>8s} {'fits':>8s} {'complete':>9s}  "
              "worker stages s (load/simple/pem/diagnose/figures)")
        for i in range(args.runs):
            url = sim_url(["both"], friction_n=0.0, rate_hz=args.rate_hz, seed=100 + i,
                          c1=args.damping, c2=args.damping)
            daq = bench.start_daq(f"daq-{i}", url, "bench", runs)
            wait_until(lambda i=i: len(bench.watcher.final_reports()) > i, 120, f"fit of run {i + 1}",
                       [worker], poll_s=0.02)
            daq.stop()
            key = sorted(bench.watcher.fit_at)[i]
            report = bench.watcher.fits[key][0]
            finished = bench.watcher.finished[key]
            latency = bench.watcher.partial_at[key] - bench.watcher.finished_at[key]
            complete = bench.watcher.fit_at[key] - bench.watcher.finished_at[key]
            latencies.append(latency)
            completes.append(complete)
            tm = report.timings
            print(f"{key[1]:24s} {finished.n_samples:7d} {finished.duration_s:7.2f}s "
                  f"{latency:7.3f}s {complete:8.3f}s  {tm.load_s:.3f}/{tm.simple_s:.3f}/"
                  f"{tm.pem_s:.3f}/{tm.diagnose_s:.3f}/{tm.figures_s:.3f}  {report.status}"
                  f" {report.diagnosis.cause if report.diagnosis else ''}")
    median, worst = statistics.median(latencies), max(latencies)
    verdict = "meets" if median <= TARGET_S else "misses"
    print(f"\nend of run -> fit report (TFs, wn, zeta, fit %) published: median {median:.3f} s, "
          f"max {worst:.3f} s over {len(latencies)} runs ({verdict} the {TARGET_S:.0f} s target)")
    print(f"end of run -> complete report (with diagnosis and figures): median "
          f"{statistics.median(completes):.3f} s, max {max(completes):.3f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
