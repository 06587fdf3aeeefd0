"""Release detection on simulated students: % recorded, release-instant error, false runs.

For each rate, `--records` seeded `sim://?student=releases` records (1-4 releases each:
flicks from rest, pull-hold-releases, nudges, touches of the held cart, starts in motion,
see `daq/sim/student.py`) and `--idle-s` of `student=handling` (nudges, other-cart moves,
slow pulls brought back: no release) are streamed as bytes, decoded and fed to
`daq.detector.ReleaseDetector`. A true release (the instant the simulated hand lets go) is
recorded when a detected release lies within `--match-s` of it; the error is their
difference. Every other detected release is a false run.

    python tools/bench_releases.py                       # 200 records per rate, 600 s idle
    python tools/bench_releases.py --records 20 --idle-s 60 --rates 100
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

from daq.decode import make_decoder
from daq.detector import Released, ReleaseDetector
from daq.frames import DataFrame
from daq.sim.options import parse_sim_url
from daq.sim.rig import Rig

RATES = (50, 100, 200, 1000)


def samples(url: str) -> tuple[Iterator[tuple[float, tuple[float, float]]], list[float]]:
    """(device s, metres) of a finished in-process `sim://` rig, and its true release times."""
    rig = Rig(parse_sim_url(url))
    data = bytearray()
    while not rig.finished:
        rig.produce_bytes(1 << 16)
        data += rig.take(1 << 16)
    scale = rig.options.counts_per_m
    frames = [f for f in make_decoder("cartlab").feed(bytes(data)) if isinstance(f, DataFrame)]
    stream = ((f.t_us * 1e-6, (f.raw[0] / scale, f.raw[1] / scale)) for f in frames)
    return stream, [e.t_s for e in rig.events if e.kind == "release"]


def detect(stream: Iterator[tuple[float, tuple[float, float]]]) -> list[float]:
    detector = ReleaseDetector()
    return [e.t_release_s for t, pos in stream for e in detector.feed(t, pos) if isinstance(e, Released)]


@dataclass
class Tally:
    releases: int = 0
    recorded: int = 0
    false_runs: int = 0
    errors_s: list[float] = field(default_factory=list)
    misses: list[str] = field(default_factory=list)

    def add(self, truth: list[float], found: list[float], match_s: float, label: str) -> None:
        left = list(found)
        for t_true in truth:
            self.releases += 1
            near = [f for f in left if abs(f - t_true) <= match_s]
            if not near:
                self.misses.append(f"{label} at {t_true:.3f} s")
                continue
            best = min(near, key=lambda f: abs(f - t_true))
            left.remove(best)
            self.recorded += 1
            self.errors_s.append(best - t_true)
        self.false_runs += len(left)


def run_rate(rate: int, records: int, idle_s: float, match_s: float, seed0: int) -> tuple[Tally, int]:
    tally = Tally()
    for k in range(records):
        seed = seed0 + 1000 * rate + k
        url = f"sim://?realtime=0&rate_hz={rate}&student=releases&seed={seed}"
        stream, truth = samples(url)
        tally.add(truth, detect(stream), match_s, f"seed={seed}")
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
          f"{'p95 ms':>8} {'max ms':>8} {'false runs':>11} {'idle runs':>10}")
    for rate in args.rates:
        tally, idle_runs = run_rate(rate, args.records, args.idle_s, args.match_s, args.seed)
        err = np.abs(np.array(tally.errors_s or [np.nan])) * 1e3
        within = 100.0 * float(np.mean(err <= 1e3 / rate)) if tally.errors_s else float("nan")
        print(f"{rate:>8} {tally.releases:>9} {100.0 * tally.recorded / max(tally.releases, 1):>11.2f} "
              f"{within:>18.1f} {np.median(err):>13.2f} {np.percentile(err, 95):>8.2f} {np.max(err):>8.1f} "
              f"{tally.false_runs:>11} {idle_runs:>10}", flush=True)
        if args.show_misses:
            for miss in tally.misses:
                print("   missed:", miss)
    return 0


if __name__ == "__main__":
    sys.exit(main())
