"""Held or free in `daq`: is each recorded run's set of moving carts the truth's?

Streams student records through `daq.detector.ReleaseDetector` and, at the end of each run (its
`Settled`, the next release, or the end of the stream), takes the run's moving carts as the
pipeline writes them into the run's metadata (`daq.held.moving_carts` on
`ReleaseDetector.run_spans_m` and `run_swings_m`). A run is matched to the true release within `--match-s`; the
truth is the pulled cart alone when the other cart is held, both carts for a free pair.

Three generators, each written apart from the detector:
- `testkit`: `testkit.student_records` (free pairs in a fifth of the records); `testkit-free`:
  the same with both carts free in every record;
- `sim`: the rig's own students, `sim://?student=releases` (the other cart held by a hand);
- `redteam`: `tools/redteam/cases10.py` (the other cart held by a hand that wanders and moves
  it 3-12 mm 2-5 s after a release, sometimes just after the next one).

    python tools/bench_held_free.py --records 40 --rates 50 200 --seed 0
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from daq.detector import Released, ReleaseDetector, Settled
from daq.held import moving_carts
from testkit.release_tally import record
from testkit.student_records import student_records

sys.path.insert(0, str(Path(__file__).resolve().parent / "redteam"))
import cases10

Stream = Iterable[tuple[float, tuple[float, ...]]]


@dataclass
class Score:
    runs: int = 0
    right: int = 0
    held_truth: int = 0
    held_right: int = 0
    free_truth: int = 0
    free_right: int = 0
    wrong: list[str] = field(default_factory=list)

    def add(self, label: str, truth: list[int], got: list[int] | None, spans: list[float]) -> None:
        self.runs += 1
        ok = got == truth
        self.right += ok
        if len(truth) == 1:
            self.held_truth += 1
            self.held_right += ok
        else:
            self.free_truth += 1
            self.free_right += ok
        if not ok:
            self.wrong.append(f"{label}: truth {truth}, got {got}, spans {[round(s * 1e3, 1) for s in spans]} mm")


def runs_of(stream: Stream) -> list[tuple[float, list[int] | None, list[float]]]:
    """(release instant, moving carts, spans) of every run the detector records in `stream`."""
    detector = ReleaseDetector()
    out: list[tuple[float, list[int] | None, list[float]]] = []
    current: Released | None = None

    def close() -> None:
        if current is not None:
            spans = detector.run_spans_m() or []
            out.append((current.t_release_s, moving_carts(current.channel + 1, spans, swings_m=detector.run_swings_m()),
                        spans))

    def events(evs: list[object]) -> None:
        nonlocal current
        for e in evs:
            if isinstance(e, Released):
                close()
                current = e
            elif isinstance(e, Settled):
                close()
                current = None

    for t, pos in stream:
        events(list(detector.feed(t, pos)))
    events(list(detector.finish()))
    close()
    return out


def score(score_: Score, label: str, stream: Stream, truth: list[tuple[float, list[int]]], match_s: float) -> None:
    for t_found, got, spans in runs_of(stream):
        near = [moving for t_true, moving in truth if abs(t_true - t_found) <= match_s]
        if near:
            score_.add(f"{label} at {t_found:.3f} s", near[0], got, spans)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--records", type=int, default=40)
    ap.add_argument("--rates", type=int, nargs="+", default=[50, 100, 200, 1000])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--match-s", type=float, default=0.1)
    ap.add_argument("--generators", nargs="+", default=["testkit", "sim", "redteam"])
    args = ap.parse_args(argv)
    print("| generator | rate | runs | right | held right | free right |")
    print("|---|---|---|---|---|---|")
    wrong: list[str] = []
    for gen in args.generators:
        for rate in args.rates:
            s = Score()
            for k in range(args.records):
                seed = args.seed + k
                if gen.startswith("testkit"):
                    both = True if gen == "testkit-free" else None
                    rec = student_records(seed, (float(rate),), both_free=both)[float(rate)]
                    truth = [(r.time_s, [r.pulled_cart, 3 - r.pulled_cart] if rec.both_free else [r.pulled_cart])
                             for r in rec.releases]
                    stream: Stream = ((float(a), (float(b), float(c))) for a, (b, c) in zip(rec.t, rec.y, strict=True))
                elif gen == "sim":
                    seed = args.seed + 1000 * rate + k
                    srec = record(f"sim://?realtime=0&rate_hz={rate}&student=releases&seed={seed}")
                    assert srec.pulled_cart is not None
                    truth = [(t, [srec.pulled_cart]) for t in srec.releases]   # the other cart held
                    stream = srec.stream
                else:
                    rrec = cases10.make_record(seed, rate=str(rate))
                    pulled = int(rrec.info["pulled_cart"])
                    truth = [(float(r["t_r"]), [pulled]) for r in rrec.releases]
                    y = np.asarray(rrec.counts, float) / cases10.COUNTS_PER_M
                    stream = ((float(a), (float(b), float(c))) for a, (b, c) in zip(rrec.t, y, strict=True))
                score(s, f"{gen} seed {seed} at {rate} Hz", stream, truth, args.match_s)
            print(f"| {gen} | {rate} | {s.runs} | {s.right} | {s.held_right}/{s.held_truth} | "
                  f"{s.free_right}/{s.free_truth} |", flush=True)
            wrong += s.wrong
    for line in wrong:
        print("-", line)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
