"""Benchmark of the offline release finder (`ident.releases.find_releases`, issue 10).

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=. .venv/bin/python tools/bench_ident_releases.py [--records 50]
        [--seed 1000] [--idle-minutes 10]

Records come from `testkit.student_records` (its own stick/slip physics, no `ident` import):
students' records with 1–4 releases (flicks, pull-hold-releases, nudges, a loosely held cart
that wanders and is touched, records starting in motion, back-to-back releases, the last cut).
Printed per sample rate (50, 100, 200, 1000 Hz): releases found once (%), releases found
elsewhere (false), the release-instant error against the simulator's (median, 95th
percentile, share within one sample period), the pulled cart right (%), and false releases in
`--idle-minutes` of handling only (nudges of one cart, touches of the other).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from ident.releases import find_releases
from testkit.student_records import RATES_HZ, handling_record, student_record

MATCH_S = 0.25


def rate_figures(rate_hz: float, seeds: range, idle_minutes: float) -> str:
    started = time.perf_counter()
    total = found = cart_ok = false = 0
    errors: list[float] = []
    for seed in seeds:
        rec = student_record(seed, rate_hz)
        hits = find_releases(rec.t, rec.y)
        total += len(rec.releases)
        for true in rec.releases:
            near = [r for r in hits if abs(r.release_time_s - true.time_s) < MATCH_S]
            if len(near) == 1:
                found += 1
                cart_ok += near[0].pulled_cart == true.pulled_cart
                errors.append(near[0].release_time_s - true.time_s)
        false += sum(all(abs(r.release_time_s - true.time_s) >= MATCH_S for true in rec.releases) for r in hits)
    idle_false = 0
    chunks = max(1, round(idle_minutes))
    for k in range(chunks):
        rec = handling_record(10_000 + k, rate_hz, 60.0 * idle_minutes / chunks)
        idle_false += len(find_releases(rec.t, rec.y))
    err = np.abs(np.asarray(errors))
    within = float(np.mean(err <= 1.0 / rate_hz)) if err.size else 0.0
    return (f"{rate_hz:6.0f} Hz  {len(seeds)} records, {total} releases: found {100 * found / total:.1f} %, "
            f"false {false}, pulled cart right {100 * cart_ok / max(found, 1):.1f} %; instant error median "
            f"{1e3 * float(np.median(err)):.1f} ms, 95th {1e3 * float(np.percentile(err, 95)):.1f} ms, "
            f"within one sample {100 * within:.1f} %; {idle_minutes:g} min of handling: {idle_false} false "
            f"releases ({time.perf_counter() - started:.0f} s)")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--records", type=int, default=50, help="records per rate")
    parser.add_argument("--seed", type=int, default=1000, help="first seed")
    parser.add_argument("--idle-minutes", type=float, default=10.0, help="handling-only minutes per rate")
    args = parser.parse_args(argv)
    for rate in RATES_HZ:
        print(rate_figures(rate, range(args.seed, args.seed + args.records), args.idle_minutes), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
