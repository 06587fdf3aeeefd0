"""Release detection on simulated students: % recorded, release-instant error, false runs.

For each rate, `--records` seeded `sim://?student=releases` records (1-4 releases each:
flicks from rest, pull-hold-releases, nudges, touches of the held cart, starts in motion,
see `daq/sim/student.py`) and `--idle-s` of `student=handling` (nudges, other-cart moves,
slow pulls brought back: no release) are streamed as bytes, decoded and fed to
`daq.detector.ReleaseDetector`. A true release (the instant the simulated hand lets go) is
recorded when a detected release lies within `--match-s` of it; the error is their
difference. Every other detected release is a false run.

A release's instant is "in the data" when the hand's force as it lets go (the jump in the
cart's acceleration, known to the simulated hand) moves the cart by at least 10 noise RMS
within one sample period, ½ |Δa| T² (`testkit.release_tally.Record.in_data`); a softer
let-go leaves the free response indistinguishable from the hand's motion for more than a
sample, and no estimator can place it within one. The last two columns count those releases
and how many of them were dated within one sample (a missed one counts against).

    python tools/bench_releases.py                       # 200 records per rate, 600 s idle
    python tools/bench_releases.py --records 20 --idle-s 60 --rates 100
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from testkit.release_tally import Tally, detect, record, samples

RATES = (50, 100, 200, 1000)


def run_rate(rate: int, records: int, idle_s: float, match_s: float, seed0: int) -> tuple[Tally, int]:
    tally = Tally()
    for k in range(records):
        seed = seed0 + 1000 * rate + k
        rec = record(f"sim://?realtime=0&rate_hz={rate}&student=releases&seed={seed}")
        tally.add(rec.releases, detect(rec.stream), match_s, f"seed={seed}", rec.in_data(rate))
    idle_url = f"sim://?realtime=0&rate_hz={rate}&student=handling&duration_s={idle_s}&seed={seed0 + rate}"
    stream, truth = samples(idle_url)
    assert truth == []
    return tally, len(detect(stream))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--records", type=int, default=200, help="student records per rate (default 200)")
    parser.add_argument("--idle-s", type=float, default=600.0, help="seconds of idle handling per rate (600)")
    parser.add_argument("--rates", type=int, nargs="+", default=list(RATES))
    parser.add_argument("--match-s", type=float, default=0.25, help="a detection this close counts (0.25 s)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--show-misses", action="store_true")
    args = parser.parse_args(argv)
    print(f"{'rate Hz':>8} {'releases':>9} {'recorded %':>11} {'within 1 sample %':>18} {'|err| p50 ms':>13} "
          f"{'p95 ms':>8} {'max ms':>8} {'false runs':>11} {'idle runs':>10} {'in the data':>12} "
          f"{'of them within 1 sample %':>26}")
    for rate in args.rates:
        tally, idle_runs = run_rate(rate, args.records, args.idle_s, args.match_s, args.seed)
        err = np.abs(np.array(tally.errors_s or [np.nan])) * 1e3
        within = 100.0 * float(np.mean(err <= 1e3 / rate)) if tally.errors_s else float("nan")
        seen = np.abs(np.array(tally.errors_in_data_s)) * 1e3
        within_seen = 100.0 * float(np.sum(seen <= 1e3 / rate)) / tally.in_data if tally.in_data else float("nan")
        print(f"{rate:>8} {tally.releases:>9} {100.0 * tally.recorded / max(tally.releases, 1):>11.2f} "
              f"{within:>18.1f} {np.median(err):>13.2f} {np.percentile(err, 95):>8.2f} {np.max(err):>8.1f} "
              f"{tally.false_runs:>11} {idle_runs:>10} {tally.in_data:>12} {within_seen:>26.1f}", flush=True)
        if args.show_misses:
            for miss in tally.misses:
                print("   missed:", miss)
            for false in tally.false:
                print("   false run:", false)
    return 0


if __name__ == "__main__":
    sys.exit(main())
