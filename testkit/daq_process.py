"""Helpers for tests that run `daq` as a subprocess: command line, start, capture parsing."""

from __future__ import annotations

import re
import subprocess
import sys
from functools import reduce
from pathlib import Path

import numpy as np
import numpy.typing as npt

from testkit.repo import REPO

_DATA_LINE = re.compile(rb"\$(D,(\d+),(\d+),(-?\d+),(-?\d+))\*([0-9A-F]{2})\n")


def daq_command(*args: str) -> list[str]:
    return [sys.executable, "-m", "daq.cli", *args]


def start_daq(*args: str, log_path: Path) -> subprocess.Popen[bytes]:
    log = open(log_path, "wb")  # noqa: SIM115 (closed by the OS when the child exits)
    return subprocess.Popen(daq_command(*args), cwd=REPO, stdout=log, stderr=subprocess.STDOUT)


def parse_capture(data: bytes) -> dict[str, npt.NDArray[np.int64]]:
    """`$D` lines of a capture, decoded here (not with daq.decode), checksums verified."""
    rows = []
    for match in _DATA_LINE.finditer(data):
        body, checksum = match.group(1), int(match.group(6), 16)
        assert reduce(lambda a, b: a ^ b, body, 0) == checksum
        rows.append([int(match.group(i)) for i in range(2, 6)])
    table = np.array(rows, dtype=np.int64).reshape(-1, 4)
    return {"seq": table[:, 0], "t_us": table[:, 1], "enc1": table[:, 2], "enc2": table[:, 3]}
