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

`--generator testkit` scores the detector on another generator's students instead,
`testkit.student_records` (the offline finder's benchmark, written apart from daq: softer
rigs, 0.6-3.5 Hz, and both carts free in a fifth of the records), seeds from `--seed`, and
breaks each rate's releases down by kind (flick or hold, the other cart held or free). Its
nudges sometimes take a cart that still rings and let it go away from its rest, where it rings
again (`StudentRecord.catches_s`: physically a release its plan did not make): a run there is
counted apart, neither required nor false.

    python tools/bench_releases.py                       # 200 records per rate, 600 s idle
    python tools/bench_releases.py --records 20 --idle-s 60 --rates 100
    python tools/bench_releases.py --generator testkit --records 40 --idle-s 120 --seed 6000
"""

from __future__ import annotations

import argparse
import sys

import numpy as np
import numpy.typing as npt

from testkit.release_tally import Stream, Tally, detect, record, samples
from testkit.student_records import handling_records, student_records

RATES = (50, 100, 200, 1000)


def run_rate(rate: int, records: int, idle_s: float, match_s: float, seed0: int,
             generator: str = "sim") -> tuple[Tally, int]:
    if generator == "testkit":
        return _testkit_rate(rate, records, idle_s, match_s, seed0)
    tally = Tally()
    for k in range(records):
        seed = seed0 + 1000 * rate + k
        rec = record(f"sim://?realtime=0&rate_hz={rate}&student=releases&seed={seed}")
        tally.add(rec.releases, detect(rec.stream), match_s, f"seed={seed}", rec.in_data(rate))
    idle_url = f"sim://?realtime=0&rate_hz={rate}&student=handling&duration_s={idle_s}&seed={seed0 + rate}"
    stream, truth = samples(idle_url)
    assert truth == []
    return tally, len(detect(stream))


def _testkit_rate(rate: int, records: int, idle_s: float, match_s: float, seed0: int) -> tuple[Tally, int]:
    """As `run_rate` on `testkit.student_records`' students (the offline finder's benchmark
    generator, independent of daq: softer rigs, both carts free in some records), streamed as
    (t, metres) samples."""
    tally = Tally()
    for seed in range(seed0, seed0 + records):
        rec = student_records(seed, (float(rate),))[float(rate)]
        tally.add([r.time_s for r in rec.releases], detect(_stream(rec.t, rec.y)), match_s,
                  f"seed={seed}{' both free' if rec.both_free else ''}", rec.in_data(),
                  [f"{r.kind}, {'free pair' if rec.both_free else 'other cart held'}" for r in rec.releases],
                  rec.catches_s)
    # in minutes, seeds as `tools/bench_ident_releases.py` draws them (both tools score the same)
    chunks = max(1, round(idle_s / 60.0)) if idle_s > 0 else 0
    idle = [handling_records(10_000 + k, (float(rate),), idle_s / chunks)[float(rate)] for k in range(chunks)]
    return tally, sum(len(detect(_stream(rec.t, rec.y))) for rec in idle)


def _stream(t: npt.NDArray[np.float64], y: npt.NDArray[np.float64]) -> Stream:
    return ((float(a), (float(b), float(c))) for a, (b, c) in zip(t, y, strict=True))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--records", type=int, default=200, help="student records per rate (default 200)")
    parser.add_argument("--idle-s", type=float, default=600.0, help="seconds of idle handling per rate (600)")
    parser.add_argument("--rates", type=int, nargs="+", default=list(RATES))
    parser.add_argument("--match-s", type=float, default=0.25, help="a detection this close counts (0.25 s)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--show-misses", action="store_true")
    parser.add_argument("--generator", choices=("sim", "testkit"), default="sim",
                        help="the simulated rig's students (sim://?student=releases) or testkit.student_records'")
    args = parser.parse_args(argv)
    print(f"{'rate Hz':>8} {'releases':>9} {'recorded %':>11} {'within 1 sample %':>18} {'|err| p50 ms':>13} "
          f"{'p95 ms':>8} {'max ms':>8} {'false runs':>11} {'idle runs':>10} {'in the data':>12} "
          f"{'of them within 1 sample %':>26}")
    for rate in args.rates:
        tally, idle_runs = run_rate(rate, args.records, args.idle_s, args.match_s, args.seed, args.generator)
        err = np.abs(np.array(tally.errors_s or [np.nan])) * 1e3
        within = 100.0 * float(np.mean(err <= 1e3 / rate)) if tally.errors_s else float("nan")
        seen = np.abs(np.array(tally.errors_in_data_s)) * 1e3
        within_seen = 100.0 * float(np.sum(seen <= 1e3 / rate)) / tally.in_data if tally.in_data else float("nan")
        print(f"{rate:>8} {tally.releases:>9} {100.0 * tally.recorded / max(tally.releases, 1):>11.2f} "
              f"{within:>18.1f} {np.median(err):>13.2f} {np.percentile(err, 95):>8.2f} {np.max(err):>8.1f} "
              f"{tally.false_runs:>11} {idle_runs:>10} {tally.in_data:>12} {within_seen:>26.1f}", flush=True)
        for kind, errors in sorted(tally.by_kind.items()):
            found = [abs(e) for e in errors if e is not None]
            print(f"   {kind}: {len(errors)} releases, recorded {len(found)}, within one sample "
                  f"{sum(e <= 1.0 / rate for e in found)}")
        if tally.catches:
            print(f"   catches (a nudge let a ringing cart go away from its rest; neither required nor "
                  f"false): {tally.catches}, a run at {len(tally.at_catches)}")
        if args.show_misses:
            for miss in tally.misses:
                print("   missed:", miss)
            for false in tally.false:
                print("   false run:", false)
            for caught in tally.at_catches:
                print("   run at a catch:", caught)
    return 0


if __name__ == "__main__":
    sys.exit(main())
