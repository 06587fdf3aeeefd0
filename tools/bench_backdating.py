"""How close the release detector's back-dated release is to the truth, on `sim://` rigs.

For each rate and seed, the three lab cases (cart 1, cart 2, both) are simulated as fast as
possible, decoded and fed to `daq.detector.ReleaseDetector`; the error of each back-dated
release against the rig's own `release` event is printed in sample periods (mean, RMS,
largest), with the hand's tremor on (the rig's default, 50 um RMS, 7-11 Hz) and off.

    .venv/bin/python tools/bench_backdating.py [--seeds 6] [--rates 100,1000]

The acceptance criterion (issue 2) is one sample period; the tremor's velocity at the
instant the hand lets go dominates the error at 1 kHz.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from daq.decode import make_decoder
from daq.detector import Released, ReleaseDetector
from daq.frames import DataFrame
from daq.sim.options import parse_sim_url
from daq.sim.rig import Rig

SIM = "sim://?realtime=0&rate_hz={rate}&cases=cart1,cart2,both&seed={seed}&c1=2&c2=2{extra}"


def release_errors(rate_hz: int, seed: int, extra: str) -> list[float]:
    """Back-dating errors (found - true, in sample periods); NaN for a case not found once."""
    rig = Rig(parse_sim_url(SIM.format(rate=rate_hz, seed=seed, extra=extra)))
    data = bytearray()
    for _ in range(1_000_000):
        if rig.finished:
            break
        rig.produce_bytes(1 << 16)
        data += rig.take(1 << 16)
    scale = rig.options.counts_per_m
    frames = [f for f in make_decoder("cartlab").feed(bytes(data)) if isinstance(f, DataFrame)]
    truth = [e.t_s for e in rig.events if e.kind == "release"]
    detector = ReleaseDetector()
    found = [e for f in frames for e in detector.feed(f.t_us * 1e-6, (f.raw[0] / scale, f.raw[1] / scale))
             if isinstance(e, Released)]
    if len(found) != len(truth):
        return [float("nan")] * len(truth)
    return [(r.t_release_s - t) * rate_hz for r, t in zip(found, truth)]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, default=6)
    parser.add_argument("--rates", default="100,1000", help="comma-separated sample rates (Hz)")
    args = parser.parse_args()
    for rate in (int(r) for r in args.rates.split(",")):
        for label, extra in (("tremor 50 um", ""), ("no tremor", "&tremor_m=0")):
            errors = np.array([e for seed in range(args.seeds)
                               for e in release_errors(rate, 13 * seed + rate + 1, extra)])
            missed = int(np.isnan(errors).sum())
            ok = errors[~np.isnan(errors)]
            print(f"{rate:5d} Hz, {label:12s}: {ok.size} releases, {missed} missed; error in sample periods: "
                  f"mean {ok.mean():+.3f}, rms {np.sqrt(np.mean(ok ** 2)):.3f}, largest {np.abs(ok).max():.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
