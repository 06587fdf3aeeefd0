"""Cost of the cart simulator's compiled kernel (`ident.physics.kernel.simulate_rows`) per
sub-step, for each kind of model the diagnosis fits (one and two carts), in one or more source
trees (`--tree DIR`, default this checkout) measured in alternation so that load hits them
alike; each tree runs in its own process (its own compiled kernel) and prints a checksum of
the positions, which must agree between trees whose physics is the same.

    python tools/bench_kernel.py
    python tools/bench_kernel.py --tree . --tree ../other-checkout --rounds 3
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: Run in the measured tree: best time of `reps` runs of P = 10 parameter rows over N = 500
#: samples, per sub-step (ns), and the positions' sum, for each model kind.
PROBE = r'''
import json, sys, time
import numpy as np
from ident.physics.free import NonlinearTerms, run_maps, step_maps

P, N, DT = 10, 500, 0.02
KINDS = {
    "linear": {},
    "coulomb, sliding": {"friction_m_s2": 0.002},
    "coulomb, sticks": {"friction_m_s2": 0.05},
    "coulomb + input": {"friction_m_s2": 0.002, "input": 0.3},
    "coulomb + cubic": {"friction_m_s2": 0.002, "cubic_per_m2": 20.0},
    "quadratic drag": {"drag_per_m": 2.0},
    "presliding": {"friction_m_s2": 0.05, "presliding_per_s2": 500.0},
}
result = {}
for carts in (1, 2):
    lin = np.tile([[11.0, 0.03]] if carts == 1 else [[130.0, 60.0, 60.0, 130.0, 0.5, 0.5]], (P, 1))
    for name, kind in KINDS.items():
        terms, m, u = {}, 0, None
        for key, value in kind.items():
            if key == "input":
                m = 1
                terms["input_gain"] = np.full((P, carts, 1), value)
                u = np.sin(0.05 * np.arange(N))[:, None] * 0.01
            elif key == "cubic_per_m2":
                terms[key] = np.full(P, value)
            else:
                terms[key] = np.full((P, carts), value)
        maps = step_maps(lin, DT, carts, NonlinearTerms(**terms), n_inputs=m)
        z0 = np.zeros((P, 2 * carts))
        z0[:, 0] = 0.03
        out, _ = run_maps(maps, z0, N, u)          # compiles or loads the kernel
        best = float("inf")
        for _ in range(int(sys.argv[1])):
            t0 = time.perf_counter()
            for _ in range(20):
                run_maps(maps, z0, N, u)
            best = min(best, (time.perf_counter() - t0) / 20)
        result[f"{carts} cart{'s' if carts == 2 else ''}, {name}"] = (
            best / (P * N * maps.substeps) * 1e9, float(np.sum(out)))
print(json.dumps(result))
'''


def once(tree: Path, reps: int) -> dict[str, tuple[float, float]]:
    env = {**os.environ, "PYTHONPATH": str(tree), "OPENBLAS_NUM_THREADS": "1"}
    out = subprocess.run([sys.executable, "-c", PROBE, str(reps)], capture_output=True, text=True, env=env,
                         cwd=tree, check=True, timeout=600).stdout
    parsed: dict[str, tuple[float, float]] = json.loads(out.strip().splitlines()[-1])
    return parsed


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tree", action="append", type=Path, help="a source tree (repeatable)")
    parser.add_argument("--rounds", type=int, default=2, help="alternations of the trees")
    parser.add_argument("--reps", type=int, default=5, help="timed batches per kind (the best is kept)")
    args = parser.parse_args(argv)
    trees = [t.resolve() for t in (args.tree or [ROOT])]
    best: dict[Path, dict[str, tuple[float, float]]] = {}
    for _ in range(args.rounds):
        for tree in trees:
            for kind, (ns, checksum) in once(tree, args.reps).items():
                old = best.setdefault(tree, {}).get(kind)
                best[tree][kind] = (min(ns, old[0]) if old else ns, checksum)
    kinds = list(best[trees[0]])
    print(f"ns per sub-step (best of {args.rounds} x {args.reps}; load average {os.getloadavg()[0]:.1f})")
    print(f"{'model':28s}" + "".join(f" {str(t)[-24:]:>24s}" for t in trees) + "  positions agree")
    for kind in kinds:
        cells = [best[t][kind] for t in trees]
        agree = "yes" if len({c[1] for c in cells}) == 1 else "NO"
        print(f"{kind:28s}" + "".join(f" {c[0]:24.1f}" for c in cells) + f"  {agree}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
