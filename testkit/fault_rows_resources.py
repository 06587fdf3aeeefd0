"""Rows 8 and 10 of issue 14: memory per input (a large CSV, a sparse file, a compressed MCAP
bomb, each loaded in a child whose peak RSS is measured) and the suite under load."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np

from testkit.fault_table import BENCH, Row, run_python
from testkit.peak_memory import PeakGrowth, peak_growth

#: What reading an input may cost beyond twice its data, e.g. to refuse it (bytes): a 1 GiB
#: sparse file holds no data, and a 2.5 MB bomb must be refused, not inflated.
REFUSAL_BYTES = 32 << 20


def load_outcome(path: str, scale: str = "") -> str:
    """`ident.io.load` of `path` (release at 1 s; `scale` in m per unit, if given, for columns
    without a unit such as an ECP export's encoder counts): what became of it, in a few words."""
    import ident.io
    from ident.errors import IdentError

    try:
        data = ident.io.load(Path(path), release_time_s=1.0, scale=float(scale) if scale else None)
    except (IdentError, ValueError) as exc:
        return f"refused: {str(exc)[:70]}"
    return f"loaded {data.y.shape[0]} samples"


def _peak(path: Path, small: Path) -> PeakGrowth:
    """The load of `path` measured in a fresh child, after a load of `small` there (so the
    loader's own imports and first-call costs are not counted)."""
    target = f"{__name__}:load_outcome"
    return peak_growth(target, [str(path)], warm=(target, [str(small)]))


def row8_memory(work: Path, csv_mb: float) -> list[Row]:
    folder = work / "r8"
    folder.mkdir()
    small = folder / "small.csv"
    t = np.arange(3000) / 1000.0
    x = np.where(t < 1.0, 0.0, 0.1 * (1 - np.cos(11 * np.clip(t - 1.0, 0.0, None))))
    np.savetxt(small, np.column_stack([t, x, 0.3 * x]), delimiter=",", header="time_s,pos1_m,pos2_m", comments="")
    big = folder / "big.csv"
    n = int(csv_mb * 1e6 / 32)
    with big.open("w") as out:
        out.write("time_s,pos1_m,pos2_m\n")
        rng = np.random.default_rng(1)
        for start in range(0, n, 200_000):
            tt = np.arange(start, min(n, start + 200_000)) / 1000.0
            xx = np.where(tt < 1.0, 0.0, 0.15 * (1 - np.exp(-0.01 * (tt - 1.0)) * np.cos(11 * (tt - 1.0))))
            block = np.column_stack([tt, xx, 0.3 * xx + rng.normal(0, 1e-6, tt.size)])
            np.savetxt(out, block, delimiter=",", fmt="%.9g")
    sparse = folder / "sparse.csv"
    with sparse.open("wb") as handle:
        handle.truncate(1 << 30)
    bomb = folder / "bomb.mcap"
    write_bomb(bomb)
    rows = []
    for label, path in (("CSV", big), ("1 GiB sparse file", sparse), ("compressed MCAP bomb", bomb)):
        size = path.stat().st_size
        peak = _peak(path, small)
        grown, outcome = peak.growth_bytes, peak.outcome
        data = size if path is not sparse else 0
        bound = max(2 * data, REFUSAL_BYTES)
        rows.append(Row(f"8 memory: {label}", f"ident.io.load of a {size / 1e6:.1f} MB {label}",
                        f"{outcome}; peak RSS +{grown / 1e6:.1f} MB over {peak.before_bytes / 1e6:.0f} MB"
                        + (f" ({grown / size:.2f}x the file)" if data else ""),
                        over_bound="0" if grown <= bound else f"+{grown / 1e6:.0f} MB > {bound / 1e6:.0f} MB"))
    return rows


def write_bomb(path: Path) -> None:
    """A valid daq-style MCAP whose chunks hold the same sample batch over and over: ~2.5 MB on
    disk, well over a GB decompressed (zstd squeezes the repeats)."""
    import struct

    import zstandard

    from schemas import topics
    from schemas.daq import SampleBatch

    def record(opcode: int, body: bytes) -> bytes:
        return struct.pack("<BQ", opcode, len(body)) + body

    def string(text: str) -> bytes:
        raw = text.encode()
        return struct.pack("<I", len(raw)) + raw

    batch = SampleBatch(bench=BENCH, batch_seq=0, t_ns=list(range(2000)), pos1_m=[0.0] * 2000,
                        raw1=[0.0] * 2000).to_json_bytes()
    message = record(0x05, struct.pack("<HIQQ", 1, 0, 0, 0) + batch)
    inner = message * 1500
    packed = zstandard.ZstdCompressor(level=19).compress(inner)
    chunk = record(0x06, struct.pack("<QQQI", 0, 0, len(inner), 0) + string("zstd")
                   + struct.pack("<Q", len(packed)) + packed)
    channel = record(0x04, struct.pack("<HH", 1, 0) + string(topics.SAMPLES) + string("json") + struct.pack("<I", 0))
    with path.open("wb") as out:
        out.write(b"\x89MCAP0\r\n" + record(0x01, string("") + string("bomb")) + channel)
        while out.tell() < 2_500_000:
            out.write(chunk)


# --- row 10: the suite under load ---------------------------------------------------------------------

#: The tests row 10 runs under load by default: those that wait on other processes (workers, the
#: daq, Chromium), where a timing assumption shows first. `--load-tests all` runs the whole suite.
LOAD_TESTS = ("tests/ident/test_worker_abuse.py", "tests/ident/worker/test_worker_exactly_once.py",
              "tests/ident/worker/test_worker_start.py", "tests/daq/test_web_browser.py",
              "tests/daq/test_web_browser_security.py")
_RUN_LINE = re.compile(r"^run \d+/\d+ with \d+ burners: exit (-?\d+), (.*)$")


def row10_load(work: Path, repeat: int, tests: tuple[str, ...] = LOAD_TESTS) -> Row:
    """`tools/suite_under_load.py` with two burners, `repeat` runs of `tests` (all: the suite)."""
    selected = [] if tests == ("all",) else list(tests)
    done = run_python(["tools/suite_under_load.py", "--burners", "2", "--repeat", str(repeat),
                       "--log-dir", str(work / "r10"), *selected, "-q"], timeout_s=3 * 3600)
    print(done.stdout, file=sys.stderr, flush=True)   # each run's line and a failed run's report
    runs = [m for m in map(_RUN_LINE.match, done.stdout.splitlines()) if m]
    failed = sum(m.group(1) != "0" for m in runs)
    failures = sorted({line.split(" - ")[0] for line in done.stdout.splitlines() if line.startswith("FAILED")})
    outcome = "; ".join(m.group(2) for m in runs) or f"no run reported: {done.stderr[-200:]}"
    if failures:
        outcome += "; failed: " + ", ".join(failures)
    what = "the whole suite" if not selected else ", ".join(selected)
    return Row("10 suite under load", f"{what}, {repeat}x beside two CPU burners (tools/suite_under_load.py)",
               outcome, crashes=failed + int(len(runs) != repeat))


__all__ = ["LOAD_TESTS", "load_outcome", "row8_memory", "row10_load", "write_bomb"]
