"""`ident.releases.find_releases` on the red team's issue-11 cases, in process (issue 10/11).

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=. .venv/bin/python tools/bench_releases_redteam.py
        [--family F ...] [--first-seed 0] [--seeds 8]

The cases are `tools/redteam/cases11.py`'s (written from the physics, independent of the
package): one cart released from a hold or flicked, every issue-11 effect at its full range,
50-1000 Hz, lattices 1e-5-2e-3 m. Printed per family: cases with no release within 0.3 s of
the simulator's let-go (missed), with exactly that one release, with more than one listed,
and with exactly one within one sample period (the red team's `run11.py` `ident releases`
column, without its `ident diagnose` runs), and with that one ended early: listed as ended by a
touch while the simulator's carts still move (two carts with dry friction: the one that stops
first creeps as the other pulls it; a measure for carts that come to rest: a viscous cart's
decay and a held cart's wander count as moving); the missed, extra and early-ended seeds.
A generated record with a NaN (the generator's simulation diverged: `two_cart_coulomb_y1` 264,
1109, 1122) is named and not counted; `find_releases` refuses it.
`--family` also takes the widened families of `cases11b.py` (e.g. `two_cart_coulomb_y12`).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from ident.releases import find_releases
from testkit.chain_friction import last_motion

REDTEAM = Path(__file__).resolve().parent / "redteam"
NEAR_S = 0.3


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--family", action="append", help="only these families (repeatable)")
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--seeds", type=int, default=8)
    args = ap.parse_args(argv)
    sys.path.insert(0, str(REDTEAM))
    from cases11 import FAMILIES  # the red team's generator, not the package's
    from run11 import case_of
    totals = np.zeros(5, dtype=np.int64)
    for family in args.family or FAMILIES:
        counts = np.zeros(5, dtype=np.int64)   # missed, exactly one, extra, on time, ended early
        bad, early, unusable = [], [], []
        for seed in range(args.first_seed, args.first_seed + args.seeds):
            case = case_of(family, seed)
            if not np.all(np.isfinite(case.y)):   # the generator's simulation diverged: not a record
                unusable.append(seed)
                continue
            releases = find_releases(np.asarray(case.t, dtype=np.float64), np.asarray(case.y, dtype=np.float64))
            truth = float(case.truth["release_time_s"])
            dt = float(np.median(np.diff(case.t)))
            near = [r for r in releases if abs(r.release_time_s - truth) < NEAR_S]
            one = len(releases) == 1 and len(near) == 1
            stops = last_motion(np.asarray(case.t, dtype=np.float64), np.asarray(case.x, dtype=np.float64), truth)
            cut = one and releases[0].ended_by == "touch" and releases[0].end_time_s < stops - dt
            counts += [not near, one, len(releases) > 1, one and abs(releases[0].release_time_s - truth) <= dt, cut]
            if not one:
                bad.append(seed)
            if cut:
                early.append(seed)
        totals += counts
        print(f"{family:22s} {args.seeds - len(unusable)} cases: missed {counts[0]}, exactly one {counts[1]}, "
              f"extra {counts[2]}, one within a sample {counts[3]}, ended early {counts[4]}; "
              f"not exactly one: {bad}; ended early: {early}"
              + (f"; not counted (NaN in the generated record): {unusable}" if unusable else ""), flush=True)
    print(f"{'all':22s} missed {totals[0]}, exactly one {totals[1]}, extra {totals[2]}, "
          f"one within a sample {totals[3]}, ended early {totals[4]}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
