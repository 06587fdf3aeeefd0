"""Benchmark of the offline release finder (`ident.releases.find_releases`, issue 10).

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=. .venv/bin/python tools/bench_ident_releases.py [--records 50]
        [--seed 1000] [--idle-minutes 10] [--rates 50,100,200,1000] [--list] [--sim-records 0]

Records come from `testkit.student_records` (its own stick/slip physics, no `ident` import):
students' records with 1–4 releases (flicks, pull-hold-releases, nudges, a loosely held cart
that wanders and is touched, records starting in motion, back-to-back releases, the last cut,
both carts free). Each seed is simulated once and sampled at every rate. Printed per sample
rate (50, 100, 200, 1000 Hz): releases found once (%), releases found elsewhere (false), the
release-instant error against the simulator's (median, 95th percentile, share within one
sample period; and of the releases whose instant is in the data, the hand's force as it lets
go moving the cart by at least 10 noise RMS within one sample period, ½ |Δa| T², the share
within one sample: a softer let-go leaves the free response indistinguishable from the hand's
motion for more than a sample), the pulled cart right (%), false releases in `--idle-minutes` of handling
only (nudges of one cart, touches of the other), and the misses by kind of release and by
what else the record holds. `--list` prints every miss and false release (seed, time).

`--sim-records N` also scores N records per rate of another generator, the simulated rig's own
students (`sim://?student=releases`, `daq/sim/student.py`: a gripping hand that trembles while
it holds, streamed as bytes and decoded as `daq` reads them; seeds as `tools/bench_releases.py`
draws them, so both tools are scored on the same records). The rig names no pulled cart, so
that column is left out there.
"""

from __future__ import annotations

import argparse
import time
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from ident.releases import find_releases
from testkit.release_tally import record
from testkit.student_records import RATES_HZ, StudentRecord, TrueRelease, handling_records, student_records

MATCH_S = 0.25


@dataclass
class Tally:
    """What one rate scored over the records."""

    total: int = 0
    found: int = 0
    cart_ok: int = 0
    cart_known: int = 0
    false: int = 0
    idle_false: int = 0
    errors: list[float] = field(default_factory=list)
    #: releases whose instant is in the data (`StudentRecord.in_data`), and of them those dated
    #: within one sample (a missed one counts against)
    in_data: int = 0
    in_data_within: int = 0
    missed_by: Counter[str] = field(default_factory=Counter)
    listing: list[str] = field(default_factory=list)

    def add(self, seed: int, rec: StudentRecord) -> None:
        hits = find_releases(rec.t, rec.y)
        self.total += len(rec.releases)
        for true, seen in zip(rec.releases, rec.in_data(), strict=True):
            near = [r for r in hits if abs(r.release_time_s - true.time_s) < MATCH_S]
            self.in_data += seen
            dated = len(near) == 1 and abs(near[0].release_time_s - true.time_s) <= 1.0 / rec.rate_hz
            self.in_data_within += seen and dated
            if len(near) == 1:
                self.found += 1
                self.cart_ok += near[0].pulled_cart == true.pulled_cart
                self.cart_known += true.pulled_cart > 0
                self.errors.append(near[0].release_time_s - true.time_s)
                continue
            kind = f"{true.kind}{' cut' if true.cut else ''}{' both free' if rec.both_free else ''}"
            self.missed_by[kind] += 1
            self.listing.append(f"  miss  seed {seed} at {true.time_s:.3f} s: {kind}; events {rec.events}")
        for r in hits:
            if all(abs(r.release_time_s - true.time_s) >= MATCH_S for true in rec.releases):
                self.false += 1
                self.listing.append(f"  false seed {seed} at {r.release_time_s:.3f} s; events {rec.events}")

    def line(self, rate_hz: float, records: int, idle_minutes: float, seconds: float) -> str:
        err = np.abs(np.asarray(self.errors))
        within = float(np.mean(err <= 1.0 / rate_hz)) if err.size else 0.0
        med = 1e3 * float(np.median(err)) if err.size else float("nan")
        p95 = 1e3 * float(np.percentile(err, 95)) if err.size else float("nan")
        kinds = ", ".join(f"{k} {n}" for k, n in sorted(self.missed_by.items())) or "none"
        cart = f", pulled cart right {100 * self.cart_ok / self.cart_known:.1f} %" if self.cart_known else ""
        idle = f"{idle_minutes:g} min of handling: {self.idle_false} false releases; " if idle_minutes else ""
        return (f"{rate_hz:6.0f} Hz  {records} records, {self.total} releases: found "
                f"{100 * self.found / max(self.total, 1):.1f} %, false {self.false}{cart}; instant error "
                f"median {med:.1f} ms, 95th {p95:.1f} ms, within one sample {100 * within:.1f} % (in the data "
                f"{self.in_data}, of them within one sample {_share(self.in_data_within, self.in_data)}); {idle}"
                f"missed by kind: {kinds} ({seconds:.0f} s)")


def _share(part: int, whole: int) -> str:
    return f"{100 * part / whole:.1f} %" if whole else "-"


def sim_record(seed: int, rate_hz: float) -> StudentRecord:
    """A `sim://?student=releases` record (the rig's own students) as the finder sees it."""
    rec = record(f"sim://?realtime=0&rate_hz={rate_hz:g}&student=releases&seed={seed}")
    t, y = zip(*rec.stream, strict=True)
    return StudentRecord(np.asarray(t), np.asarray(y),
                         tuple(TrueRelease(s, 0, "sim", jump_m_s2=a)
                               for s, a in zip(rec.releases, rec.let_go_m_s2, strict=True)),
                         False, rate_hz, noise_m=rec.noise_m)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--records", type=int, default=50, help="records per rate")
    parser.add_argument("--seed", type=int, default=1000, help="first seed")
    parser.add_argument("--idle-minutes", type=float, default=10.0, help="handling-only minutes per rate")
    parser.add_argument("--rates", default=",".join(f"{r:g}" for r in RATES_HZ), help="sample rates (Hz)")
    parser.add_argument("--list", action="store_true", help="print every miss and false release")
    parser.add_argument("--sim-records", type=int, default=0,
                        help="also this many sim://?student=releases records per rate (seeds from --seed)")
    args = parser.parse_args(argv)
    rates = tuple(float(r) for r in args.rates.split(","))
    tallies = {rate: Tally() for rate in rates}
    seconds = dict.fromkeys(rates, 0.0)
    for seed in range(args.seed, args.seed + args.records):
        for rate, rec in student_records(seed, rates).items():
            started = time.perf_counter()
            tallies[rate].add(seed, rec)
            seconds[rate] += time.perf_counter() - started
    chunks = max(1, round(args.idle_minutes)) if args.idle_minutes > 0 else 0
    for k in range(chunks):
        for rate, rec in handling_records(10_000 + k, rates, 60.0 * args.idle_minutes / chunks).items():
            started = time.perf_counter()
            found = find_releases(rec.t, rec.y)
            tallies[rate].idle_false += len(found)
            tallies[rate].listing += [f"  false idle {10_000 + k} at {r.release_time_s:.3f} s" for r in found]
            seconds[rate] += time.perf_counter() - started
    for rate in rates if args.records else ():
        print(tallies[rate].line(rate, args.records, args.idle_minutes, seconds[rate]), flush=True)
        if args.list and tallies[rate].listing:
            print("\n".join(tallies[rate].listing))
    if args.sim_records:
        print("the simulated rig's students (sim://?student=releases):")
    for rate in rates if args.sim_records else ():
        sim, started = Tally(), time.perf_counter()
        for k in range(args.sim_records):
            seed = args.seed + 1000 * round(rate) + k
            sim.add(seed, sim_record(seed, rate))
        print(sim.line(rate, args.sim_records, 0.0, time.perf_counter() - started), flush=True)
        if args.list and sim.listing:
            print("\n".join(sim.listing))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
