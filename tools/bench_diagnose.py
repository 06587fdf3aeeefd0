"""Benchmark of `ident diagnose`: confusion matrix over generated runs with a hidden effect.

    .venv/bin/python tools/bench_diagnose.py [--cases 120] [--seed 7] [--flick-every K] [--json out.json]

Runs are made by the independent generator `tests/ident/hidden_effects.py` (effects in a
seeded shuffle of a balanced list; everything else drawn by the seed), then `diagnose`
sees only t and y. Printed: the confusion matrix (hidden effect x named cause), accuracy,
false positives on `none`, parameter errors per effect, per-case diagnosis time (median,
90th percentile, max; the generator's time excluded), and the results on the real ECP
hand-release runs in ../shared/realdata when present. Targets (issue 4): >= 95 % right
cause, 0 false positives on `none`, <= 5 s per case.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "ident"))

from hidden_effects import EFFECTS, make_case  # noqa: E402

from ident.data import make_uniform  # noqa: E402
from ident.diagnose import diagnose  # noqa: E402
from ident.io import load  # noqa: E402

REL_TOL = 0.15
REALDATA = ROOT.parent / "shared" / "realdata" / "ECP210_UCSD_2023_Parker-Knopf" / "Open_Loop"
M_PER_COUNT = 1.0 / 560 / 100


def run_generated(n: int, seed: int, flick_every: int = 0) -> list[dict[str, Any]]:
    rng = np.random.default_rng(seed)
    effects = [EFFECTS[i % len(EFFECTS)] for i in range(n)]
    rows = []
    for k, i in enumerate(rng.permutation(n)):
        case_seed = int(rng.integers(0, 2**31))
        flick = flick_every > 0 and k % flick_every == 0
        case = make_case(case_seed, effects[i], flick=flick)
        started = time.perf_counter()
        report = diagnose(case.t, case.y, carts=case.carts).report
        elapsed = time.perf_counter() - started
        chosen = next((c for c in report.candidates if c.effect == case.effect), None)
        errors = {}
        for name, truth in case.truth.items():
            got = chosen.parameters.get(name) if chosen is not None else None
            errors[name] = abs(got - truth) / abs(truth) if got is not None else float("inf")
        right = report.cause == case.effect
        param_ok = all(e <= REL_TOL for e in errors.values())
        gain_ok = report.gain_points == 0.0 if case.effect == "none" else report.gain_points > 0.0
        rows.append({"seed": case_seed, "effect": case.effect, "carts": case.carts, "flick": flick,
                     "rate_hz": case.rate_hz, "noise_m": case.noise_m, "cause": report.cause,
                     "right": right, "param_ok": param_ok, "gain_ok": gain_ok, "errors": errors,
                     "gain_points": report.gain_points, "time_s": elapsed})
        mark = "ok " if right and param_ok and gain_ok else "BAD"
        print(f"{k + 1:4d} {mark} {case.effect:17s} -> {report.cause:17s} carts={case.carts} "
              f"{'flick ' if flick else ''}"
              f"{case.rate_hz:6.0f} Hz gain {report.gain_points:7.3f} "
              + " ".join(f"{n}={100 * e:.1f}%" for n, e in errors.items()) + f"  {elapsed:.2f} s",
              flush=True)
    return rows


def print_summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    names = list(EFFECTS)
    matrix = {t: {p: 0 for p in names} for t in names}
    for r in rows:
        matrix[r["effect"]][r["cause"]] += 1
    width = max(len(n) for n in names)
    print("\nconfusion matrix (rows: hidden effect, columns: named cause)")
    print(" " * (width + 1) + " ".join(f"{n[:8]:>8s}" for n in names))
    for t in names:
        print(f"{t:{width}s} " + " ".join(f"{matrix[t][p]:8d}" for p in names))
    right = sum(r["right"] for r in rows)
    full = sum(r["right"] and r["param_ok"] and r["gain_ok"] for r in rows)
    nones = [r for r in rows if r["effect"] == "none"]
    false_pos = sum(r["cause"] != "none" for r in nones)
    missed = sum(r["effect"] != "none" and r["cause"] == "none" for r in rows)
    times = [r["time_s"] for r in rows]
    print(f"\ncases {len(rows)}; right cause {right}/{len(rows)} = {100 * right / len(rows):.1f} %; "
          f"right cause + parameter within 15 % + positive gain {full}/{len(rows)} "
          f"= {100 * full / len(rows):.1f} %")
    print(f"false positives on none: {false_pos}/{len(nones)}; effects missed (named none): {missed}")
    print("parameter relative error (median / max) where the cause was right:")
    for effect in names:
        errs: dict[str, list[float]] = {}
        for r in rows:
            if r["effect"] == effect and r["right"]:
                for n, e in r["errors"].items():
                    errs.setdefault(n, []).append(e)
        for n, e in errs.items():
            print(f"  {effect:17s} {n:26s} {100 * statistics.median(e):6.2f} % / {100 * max(e):6.2f} %")
    for carts in (1, 2):
        sub = sorted(r["time_s"] for r in rows if r["carts"] == carts)
        if sub:
            print(f"time per case, {carts} cart(s): median {statistics.median(sub):.2f} s, "
                  f"p90 {sub[int(0.9 * (len(sub) - 1))]:.2f} s, max {sub[-1]:.2f} s ({len(sub)} cases)")
    print(f"time per case, all: median {statistics.median(times):.2f} s, max {max(times):.2f} s")
    return {"matrix": matrix, "right": right, "full": full, "cases": len(rows), "false_positives": false_pos,
            "missed": missed, "median_time_s": statistics.median(times), "max_time_s": max(times)}


def run_realdata() -> list[dict[str, Any]]:
    out: list[dict[str, Any]] = []
    if not REALDATA.is_dir():
        print("\nreal data: ../shared/realdata not present, skipped")
        return out
    print("\nreal ECP-210 hand-release runs (encoder 2, 1 count = 1/560 cm):")
    for path in sorted(REALDATA.glob("DOF1_en2_manual2_test*.csv")):
        data = make_uniform(load(path, time_col="Time", pos_cols=["Encoder 2 Pos"], scale=M_PER_COUNT))
        started = time.perf_counter()
        rep = diagnose(data.t, data.y, carts=1, source=path.name).report
        elapsed = time.perf_counter() - started
        extra = {k: v for c in rep.candidates if c.effect == rep.cause for k, v in c.parameters.items()}
        print(f"  {path.name}: {rep.cause}, fit {rep.baseline.fit_percent:.2f} -> {rep.extended.fit_percent:.2f} % "
              f"(+{rep.gain_points:.2f}), zeta {rep.baseline.parameters['zeta']:.4f} -> "
              f"{rep.corrected_linear['zeta']:.4f}, wn {rep.corrected_linear['wn_rad_s']:.3f} rad/s, "
              + ", ".join(f"{k}={v:.4g}" for k, v in extra.items()) + f", {elapsed:.2f} s")
        out.append({"file": path.name, "cause": rep.cause, "baseline_fit": rep.baseline.fit_percent,
                    "extended_fit": rep.extended.fit_percent, "gain_points": rep.gain_points,
                    "parameters": extra, "time_s": elapsed})
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cases", type=int, default=120)
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--flick-every", type=int, default=0,
                        help="every k-th run is released while moving (a flick); 0: none")
    parser.add_argument("--json", type=Path, default=None, help="also write the results here")
    args = parser.parse_args(argv)
    rows = run_generated(args.cases, args.seed, args.flick_every)
    summary = print_summary(rows)
    real = run_realdata()
    if args.json is not None:
        args.json.write_text(json.dumps({"summary": summary, "cases": rows, "realdata": real}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
