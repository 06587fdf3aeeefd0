"""Rows 8 and 10 of issue 14: memory per input (a large CSV, a sparse file, a compressed MCAP
bomb, each loaded in a child whose peak RSS is measured) and the suite under load."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from testkit.fault_table import BENCH, Row, run_python

_PEAK = """
import resource, sys
from pathlib import Path
import ident.io
from ident.errors import IdentError
ident.io.load(Path(sys.argv[2]), release_time_s=1.0)
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
try:
    data = ident.io.load(Path(sys.argv[1]), release_time_s=1.0)
    outcome = f"loaded {data.y.shape[0]} samples"
except (IdentError, ValueError) as exc:
    outcome = f"refused: {str(exc)[:70]}"
print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024 - base)
print(outcome)
"""


def _peak(path: Path, small: Path) -> tuple[int, str]:
    out = run_python(["-c", _PEAK, str(path), str(small)], timeout_s=1800).stdout.splitlines()
    return int(out[0]), out[1]


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
        grown, outcome = _peak(path, small)
        data = size if path is not sparse else 0
        within = grown <= 2 * max(data, 1) or outcome.startswith("refused")
        rows.append(Row(f"8 memory: {label}", f"ident.io.load of a {size / 1e6:.1f} MB {label}",
                        f"{outcome}; peak RSS +{grown / 1e6:.0f} MB"
                        + (f" ({grown / size:.2f}x the file)" if data else ""),
                        data_lost="0" if within else f"over 2x ({grown / 1e6:.0f} MB)"))
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

def row10_load(work: Path, repeat: int) -> Row:
    done = run_python(["tools/suite_under_load.py", "--burners", "2", "--repeat", str(repeat),
                 "tests/ident/test_worker_abuse.py", "-q"], timeout_s=3600)
    lines = [line for line in done.stdout.splitlines() if line.startswith("run ")]
    failed = sum("exit 0" not in line for line in lines)
    outcome = "; ".join(line.split(": ", 1)[-1] for line in lines) or done.stderr[-200:]
    return Row("10 suite under load", f"tests/ident/test_worker_abuse.py {repeat}x with two CPU burners "
               "(tools/suite_under_load.py)", outcome, crashes=failed)



__all__ = ["row8_memory", "row10_load", "write_bomb"]
