"""Peak memory and time of loading an ECP-style text export (issue 14, row 8).

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python tools/bench_text_memory.py [--rows 1500000] [--small-repeat 40]

Writes, in a temporary directory, an ECP Executive-style export (a header, then five
tab-separated columns: sample number, time in s at 1 kHz, two encoder counts, control effort;
about 23-27 bytes a row) of a cart released at 1 s, and prints

- the load's peak memory above what was resident before it (`testkit.peak_memory`: a fresh
  child, kernel high-water mark), in MB and as a multiple of the file size (target <= 2x);
- the time of one large load and the mean time of a 3,000-row load (the common case), in
  this process.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from testkit.fault_rows_resources import load_outcome
from testkit.peak_memory import peak_growth

LOAD = "testkit.fault_rows_resources:load_outcome"
SCALE = "2.2e-5"   # metres per encoder count


def write_export(path: Path, n: int, seed: int = 14) -> None:
    """An ECP-style export of `n` rows (counts of a cart released at 1 s, 1 kHz)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 1000.0
    after = np.clip(t - 1.0, 0.0, None)
    counts = np.where(t < 1.0, 0.0, 4000 * (1 - np.exp(-0.2 * after) * np.cos(9 * after)))
    enc1 = np.round(counts + rng.normal(0, 1, n)).astype(np.int64)
    enc2 = np.round(0.4 * counts + rng.normal(0, 1, n)).astype(np.int64)
    with path.open("w") as handle:
        handle.write("Sample\tTime\tEncoder 1 Pos\tEncoder 2 Pos\tControl Effort\n")
        handle.writelines(f"{k + 1}\t{tk:.3f}\t{a}\t{b}\t0\n"
                          for k, tk, a, b in zip(range(n), t.tolist(), enc1.tolist(), enc2.tolist(), strict=True))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=1_500_000, help="rows of the large export")
    parser.add_argument("--small-repeat", type=int, default=40, help="3,000-row loads timed")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as work:
        big, small = Path(work) / "big.txt", Path(work) / "small.txt"
        write_export(big, args.rows)
        write_export(small, 3000)
        measured = peak_growth(LOAD, [str(big), SCALE], warm=(LOAD, [str(small), SCALE]))
        size = big.stat().st_size
        print(f"large export: {args.rows} rows, {size / 1e6:.1f} MB; {measured.outcome}; "
              f"peak +{measured.growth_bytes / 1e6:.1f} MB = {measured.growth_bytes / size:.2f}x the file")
        load_outcome(str(small), SCALE)
        start = time.perf_counter()
        load_outcome(str(big), SCALE)
        print(f"large load: {time.perf_counter() - start:.2f} s")
        start = time.perf_counter()
        for _ in range(args.small_repeat):
            load_outcome(str(small), SCALE)
        print(f"3,000-row load: {(time.perf_counter() - start) / args.small_repeat * 1e3:.1f} ms mean "
              f"of {args.small_repeat}")


if __name__ == "__main__":
    main()
