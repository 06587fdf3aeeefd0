"""Serial fault injection and an independent reading of the bytes, for tests and benchmarks.

- `corrupt_capture`: corrupt a fraction of the `$D` lines of a clean capture, kinds in turn
  (bit flip, truncation, random bytes, NUL, 10 kB without a newline), each one exactly one
  bad line that no decoder may accept.
- `intact_lines`: every well-formed `$D` line with a good checksum, by regular expression
  (never `daq.decode`: this is the truth the decoder is checked against); `unwrap_us`.
- `run_service`: the `daq` service in this process without Zenoh, back-off not waited.
- `recorded` / `expected`: the (t_ns, enc1, enc2) samples of a run file, and those of the
  intact lines inside its time span.

Used by `tests/daq/test_faults_serial.py` and `tools/bench_faults.py`.
"""

from __future__ import annotations

import random
import re
from collections.abc import Callable
from dataclasses import dataclass
from functools import reduce
from pathlib import Path

import numpy as np
import numpy.typing as npt
import serial

import daq  # noqa: F401  (registers sim:// and replay://)
from daq.run_file import RunData, load_run
from daq.serial_handlers import EndOfStream
from daq.serial_link import SerialLink
from daq.service import Service, ServiceConfig
from schemas.daq import DaqCounters

DATA_LINE = re.compile(rb"\$(D,(\d+),(\d+),(-?\d+),(-?\d+))\*([0-9A-F]{2})\n")
CORRUPTIONS = ("bitflip", "truncate", "random", "nul", "long")


def read_port(url: str, max_reads: int = 200_000) -> bytes:
    port = serial.serial_for_url(url, timeout=0.05)
    out = bytearray()
    try:
        for _ in range(max_reads):
            try:
                out += port.read(65536)
            except EndOfStream:
                return bytes(out)
    finally:
        port.close()
    raise RuntimeError(f"{url}: no end of stream after {max_reads} reads")


def intact_lines(stream: bytes) -> npt.NDArray[np.int64]:
    """(N, 4) seq, t_us, enc1, enc2 of every well-formed `$D` line with a good checksum."""
    rows = []
    for match in DATA_LINE.finditer(stream):
        if reduce(lambda a, b: a ^ b, match.group(1), 0) == int(match.group(6), 16):
            rows.append([int(match.group(i)) for i in range(2, 6)])
    return np.array(rows, dtype=np.int64).reshape(-1, 4)


def unwrap_us(t_us: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
    steps = np.diff(t_us) % (1 << 32)
    return np.concatenate([[t_us[0]], t_us[0] + np.cumsum(steps)]) if t_us.size else t_us


def _corrupt(line: bytes, kind: str, rng: random.Random) -> bytes:
    """One corrupted line that no decoder may accept, and that is exactly one bad line."""
    star = line.index(b"*")
    body = bytearray(line)
    printable_junk = bytes(b for b in range(256) if b not in b"\n$")
    if kind == "bitflip":
        for _ in range(100):
            i = rng.randrange(1, star)
            flipped = body[i] ^ (1 << rng.randrange(8))
            if flipped not in b"\n$":
                body[i] = flipped
                return bytes(body)
    if kind == "truncate":
        return line[:rng.randrange(2, len(line) - 2)] + b"\n"
    if kind == "random":
        return b"$" + bytes(rng.choice(printable_junk) for _ in range(star - 1)) + line[star:]
    if kind == "nul":
        body[rng.randrange(1, star)] = 0
        return bytes(body)
    # kind == "long": the line's start, then 10 kB without a newline: the next `$` ends it.
    return line[:star] + bytes(rng.choice(printable_junk) for _ in range(10_000))


@dataclass
class Corrupted:
    stream: bytes
    injected: dict[str, int]
    intact: npt.NDArray[np.int64]


def corrupt_capture(clean: bytes, fraction: float, seed: int,
                    spare: Callable[[int], bool] = lambda _t_us: False) -> Corrupted:
    """Corrupt a `fraction` of the data lines (kinds in turn); lines whose device time
    `spare(t_us)` holds are left alone."""
    rng = random.Random(seed)
    lines = clean.splitlines(keepends=True)
    injected = {kind: 0 for kind in CORRUPTIONS}
    out = []
    for i, line in enumerate(lines):
        # Never the first/last lines (device info, end of stream); only data lines.
        match = DATA_LINE.fullmatch(line)
        if 5 < i < len(lines) - 5 and match and not spare(int(match.group(3))) and rng.random() < fraction:
            kind = CORRUPTIONS[sum(injected.values()) % len(CORRUPTIONS)]
            injected[kind] += 1
            out.append(_corrupt(line, kind, rng))
        else:
            out.append(line)
    stream = b"".join(out)
    return Corrupted(stream, injected, intact_lines(stream))


def run_service(url: str, runs_dir: Path) -> tuple[list[RunData], DaqCounters]:
    link = SerialLink(url, sleep=lambda _s: None)
    service = Service(ServiceConfig(port=url, runs_dir=runs_dir, bench="faults", bus=None, until_eof=True),
                      link=link)
    service.run()
    runs = [load_run(p) for p in sorted(runs_dir.glob("*.mcap"))]
    return runs, service.acq.counters()


def run_service_on_bytes(stream: bytes, workdir: Path) -> tuple[list[RunData], DaqCounters]:
    workdir.mkdir(parents=True, exist_ok=True)
    (workdir / "stream.bin").write_bytes(stream)
    return run_service(f"replay://{workdir / 'stream.bin'}?speed=max", workdir / "runs")


def recorded(run: RunData) -> set[tuple[int, int, int]]:
    raw = run.raw.astype(np.int64)
    return {(int(t), int(a), int(b)) for t, a, b in zip(run.t_ns, raw[:, 0], raw[:, 1], strict=True)}


def expected(lines: npt.NDArray[np.int64], t_ns: npt.NDArray[np.int64], run: RunData) -> set[tuple[int, int, int]]:
    inside = (t_ns >= run.t_ns[0]) & (t_ns <= run.t_ns[-1])
    return {(int(t), int(a), int(b)) for t, a, b in zip(t_ns[inside], lines[inside, 2], lines[inside, 3], strict=True)}
