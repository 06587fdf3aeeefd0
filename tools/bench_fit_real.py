"""Time `ident fit`'s analysis on every complete release of the real hand records, beside a
baseline commit, in the same run.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python tools/bench_fit_real.py [--baseline-commit c6d921b]
        [--realdata ../shared/realdata]

Each window is the one `ident fit --release K` fits (`ident.releases.window_of` on the record
loaded raw); the analysis is `ident.fitrun.analyse_fits` with one cart (the simple RK4 and
Euler fits and PEM), as `ident fit` and `ident report` run it. The current checkout and the
baseline (unpacked by `git archive`) each run in their own process on one core (BLAS and
numba on one thread), after a warm-up fit (imports, numba's compile or cache). Prints per
window: samples, seconds, and each model's fit %; then the total. The real records are not
in the repository (no licence): without them the script says so and exits 0.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
SCALE_2025 = 1.0 / 56000.0
SCALE_2023 = 1.0 / 560 / 100

WORKER = r"""
import json, sys, time
from pathlib import Path
from ident.fitrun import FitSettings, analyse_fits
from ident.io import load
from ident.releases import releases_of, window_of

sources = json.loads(sys.argv[1])
windows = []
for path, pos, scale in sources:
    data = load(path, pos_cols=pos, scale=scale, raw=True)
    for release in releases_of(data):
        if release.complete:
            windows.append((f"{Path(path).name} @{release.release_time_s:.3f} s", window_of(data, release)))
started = time.perf_counter()
analyse_fits(windows[0][1], FitSettings(carts=1))
warm = time.perf_counter() - started
rows = []
for label, window in windows:
    started = time.perf_counter()
    analysis = analyse_fits(window, FitSettings(carts=1))
    elapsed = time.perf_counter() - started
    fits = {s.method: round(s.fit_percent, 2) for s in analysis.simple}
    if analysis.pem is not None:
        fits["pem"] = round(float(analysis.pem.fit_percent[0]), 2)
    rows.append({"window": label, "samples": int(window.t.size), "time_s": elapsed, "fits": fits,
                 "errors": [str(e)[:120] for e in analysis.errors]})
print(json.dumps({"warm_up_s": warm, "rows": rows}))
"""


def sources(realdata: Path) -> list[tuple[str, list[str] | None, float]]:
    """(path, position columns, scale) of every real hand record present."""
    found: list[tuple[str, list[str] | None, float]] = []
    team = realdata / "ECP210_UCSD_2025_team1"
    found += [(str(p), None, SCALE_2025) for p in sorted(team.glob("*.txt"))]
    steps = realdata / "ECP210_UCSD_2023_Parker-Knopf" / "Open_Loop"
    found += [(str(p), ["Encoder 2"], SCALE_2023) for p in sorted(steps.glob("DOF1_en2_manual2_test*.csv"))]
    return found


def run(code_root: Path, files: list[tuple[str, list[str] | None, float]]) -> dict[str, Any]:
    env = dict(os.environ, PYTHONPATH=str(code_root), OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1",
               MKL_NUM_THREADS="1", NUMBA_NUM_THREADS="1")
    proc = subprocess.run([sys.executable, "-c", WORKER, json.dumps(files)], env=env, cwd=code_root,
                          capture_output=True, text=True, timeout=7200, check=False)
    if proc.returncode != 0:
        return {"error": proc.stderr[-800:]}
    result: dict[str, Any] = json.loads(proc.stdout.strip().splitlines()[-1])
    return result


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--baseline-commit", default="c6d921b", help="the commit to compare with")
    parser.add_argument("--realdata", type=Path, default=ROOT.parent / "shared" / "realdata")
    args = parser.parse_args(argv)
    files = sources(args.realdata)
    if not files:
        print(f"no real hand records under {args.realdata}: nothing to time")
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        old_root = Path(tmp) / "baseline"
        old_root.mkdir()
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", args.baseline_commit], capture_output=True,
                                 check=True)
        subprocess.run(["tar", "-x", "-C", str(old_root)], input=archive.stdout, check=True)
        results = {label: run(root, files) for label, root in
                   (("current", ROOT), (f"baseline {args.baseline_commit}", old_root))}
    for label, result in results.items():
        print(f"== {label}")
        if "error" in result:
            print(f"  ERROR {result['error']}")
            continue
        total = 0.0
        for row in result["rows"]:
            total += row["time_s"]
            fits = ", ".join(f"{k} {v:.2f} %" for k, v in row["fits"].items())
            print(f"  {row['window']:38s} {row['samples']:6d} samples {row['time_s']:7.2f} s   {fits}"
                  + (f"   errors: {row['errors']}" if row["errors"] else ""))
        print(f"  total {total:.1f} s over {len(result['rows'])} windows (warm-up {result['warm_up_s']:.1f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
