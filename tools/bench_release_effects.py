"""The release instant of `ident.releases.find_releases` on runs with hidden effects and on
noisy fast holds, in one or more source trees (`--tree DIR`, default this checkout).

Cases come from `testkit.effects` (its own event-driven physics, no `ident` import):
1. `--per-family` draws of every family (single effects, `none`, the pairs) over its full
   ranges, and as many two-cart Coulomb runs read through cart 1's encoder only;
2. `--noisy` Coulomb holds at 700-1000 Hz read with the generator's heaviest noise
   (>= 0.1 mm; it draws 5 µm-0.2 mm).
Per set and tree: cases, the closest found release within one sample of the generator's
instant, within three, over three, and the largest error (samples); then every case whose
error differs between the first two trees by more than half a sample. Each tree runs in its
own process on the same cases.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python tools/bench_release_effects.py
    OPENBLAS_NUM_THREADS=1 .venv/bin/python tools/bench_release_effects.py --tree ../old-checkout --tree .
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: Run in the measured tree: (set, label, error in samples) for every case, as JSON.
PROBE = r'''
import json, sys
import numpy as np
from testkit.effects import FAMILIES, make_case
from testkit.effects.draw import CUBIC_R_MAX_FULL
from ident.releases import find_releases

per_family, noisy, seed = (int(a) for a in sys.argv[1:4])

def error(case):
    t, y = case.observed.t, case.observed.y
    found = find_releases(t, y, list(range(1, y.shape[1] + 1)))
    best = min((abs(f.release_time_s - case.truth.release_time_s) for f in found), default=float("inf"))
    return best * case.truth.rate_hz

out = []
for family in FAMILIES:
    rng = np.random.default_rng([seed, FAMILIES.index(family)])
    for s in (int(v) for v in rng.integers(0, 2 ** 31, per_family)):
        case = make_case(s, family, cubic_r_max=CUBIC_R_MAX_FULL)
        out.append(("families", f"{family} {s} {case.truth.release} {case.truth.rate_hz:.0f} Hz", error(case)))
        if family == "coulomb_friction":
            case = make_case(s, family, carts=2, encoders=1)
            out.append(("families", f"{family}/one encoder {s} {case.truth.release} {case.truth.rate_hz:.0f} Hz",
                        error(case)))
rng = np.random.default_rng([seed, 99])
kept = 0
while kept < noisy:
    s = int(rng.integers(2 ** 31))
    case = make_case(s, "coulomb_friction", release="hold", rate_hz=float(rng.uniform(700.0, 1000.0)), record_s=5.0)
    if case.truth.noise_m < 1e-4:
        continue
    kept += 1
    out.append(("noisy holds", f"coulomb hold {s} {case.truth.rate_hz:.0f} Hz {case.truth.noise_m * 1e6:.0f} um",
                error(case)))
print(json.dumps(out))
'''


def run(tree: Path, per_family: int, noisy: int, seed: int) -> list[tuple[str, str, float]]:
    env = {**os.environ, "PYTHONPATH": str(tree), "OPENBLAS_NUM_THREADS": "1"}
    proc = subprocess.run([sys.executable, "-c", PROBE, str(per_family), str(noisy), str(seed)],
                          capture_output=True, text=True, env=env, cwd=tree, timeout=3600, check=False)
    if proc.returncode != 0:
        raise SystemExit(f"{tree}: the probe failed:\n{proc.stderr}")
    return [tuple(row) for row in json.loads(proc.stdout.splitlines()[-1])]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tree", action="append", type=Path, help="a source tree (repeatable)")
    parser.add_argument("--per-family", type=int, default=15, help="draws per family (15)")
    parser.add_argument("--noisy", type=int, default=40, help="noisy fast holds (40)")
    parser.add_argument("--seed", type=int, default=777)
    args = parser.parse_args(argv)
    trees = [t.resolve() for t in (args.tree or [ROOT])]
    results = {tree: run(tree, args.per_family, args.noisy, args.seed) for tree in trees}
    print(f"{'set':12s} {'tree':>24s} {'cases':>6s} {'<= 1 sample':>12s} {'<= 3':>6s} {'> 3':>5s} {'max':>8s}")
    for name in ("families", "noisy holds"):
        for tree in trees:
            errs = [e for s, _, e in results[tree] if s == name]
            if not errs:   # (`--noisy 0`)
                continue
            print(f"{name:12s} {str(tree)[-24:]:>24s} {len(errs):6d} {sum(e <= 1 for e in errs):12d} "
                  f"{sum(e <= 3 for e in errs):6d} {sum(e > 3 for e in errs):5d} {max(errs):8.1f}")
    if len(trees) >= 2:
        print("cases whose error moved by more than half a sample (samples, first tree -> second):")
        for (_, label, a), (_, _, b) in zip(results[trees[0]], results[trees[1]]):
            if abs(a - b) > 0.5:
                print(f"  {label:52s} {a:7.2f} -> {b:7.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
