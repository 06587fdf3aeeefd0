"""`ident.releases.find_releases` on the red team's issue-11 cases, in process (issue 10/11).

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=. .venv/bin/python tools/bench_releases_redteam.py
        [--family F ...] [--first-seed 0] [--seeds 8]

The cases are `tools/redteam/cases11.py`'s (written from the physics, independent of the
package): one cart released from a hold or flicked, every issue-11 effect at its full range,
50-1000 Hz, lattices 1e-5-2e-3 m. Printed per family: cases with no release within 0.3 s of
the simulator's let-go (missed), with exactly that one release, with more than one listed,
and with exactly one within one sample period (the red team's `run11.py` `ident releases`
column, without its `ident diagnose` runs); the missed and extra seeds.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from ident.releases import find_releases

REDTEAM = Path(__file__).resolve().parent / "redteam"
NEAR_S = 0.3


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--family", action="append", help="only these families (repeatable)")
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--seeds", type=int, default=8)
    args = ap.parse_args(argv)
    sys.path.insert(0, str(REDTEAM))
    from cases11 import FAMILIES, make_case  # the red team's generator, not the package's
    totals = np.zeros(4, dtype=np.int64)
    for family in args.family or FAMILIES:
        counts = np.zeros(4, dtype=np.int64)   # missed, exactly one, extra, on time
        bad = []
        for seed in range(args.first_seed, args.first_seed + args.seeds):
            case = make_case(family, seed)
            releases = find_releases(np.asarray(case.t, dtype=np.float64), np.asarray(case.y, dtype=np.float64))
            truth = float(case.truth["release_time_s"])
            dt = float(np.median(np.diff(case.t)))
            near = [r for r in releases if abs(r.release_time_s - truth) < NEAR_S]
            one = len(releases) == 1 and len(near) == 1
            counts += [not near, one, len(releases) > 1, one and abs(releases[0].release_time_s - truth) <= dt]
            if not one:
                bad.append(seed)
        totals += counts
        print(f"{family:22s} {args.seeds} cases: missed {counts[0]}, exactly one {counts[1]}, "
              f"extra {counts[2]}, one within a sample {counts[3]}; not exactly one: {bad}", flush=True)
    print(f"{'all':22s} missed {totals[0]}, exactly one {totals[1]}, extra {totals[2]}, "
          f"one within a sample {totals[3]}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
