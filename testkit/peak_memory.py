"""The peak memory one call costs, measured in a fresh child process (issue 14, row 8).

`peak_growth("module:function", args, warm=...)` starts `python -c PROBE` in this repository,
which imports `module` and makes the `warm` call (import and first-call costs are not the
call's), reads its resident set size, resets the kernel's high-water mark, calls
`function(*args)` and reads the mark again:

    growth = VmHWM after the call - VmRSS before it        (bytes)

Why not `resource.getrusage(...).ru_maxrss`: Linux keeps a process's maximum RSS across
`execve`, so a child started by a large parent reports the parent's RSS as its own peak.
A loading call smaller than the parent then measured +0 MB (the bench process, which
had just written a 200 MB CSV, was that parent). `VmHWM` belongs to the child's own address
space, and writing `5` to `/proc/self/clear_refs` resets it to the current RSS, so the figure
is the call's own whatever ran before it. `reset_peak(pid)` and `status_bytes(pid, "VmHWM")`
do the same for another process of this user (a worker flooded by the fault rows).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

from testkit.repo import REPO

PROBE = """
import importlib, json, sys
from testkit.peak_memory import reset_peak, status_bytes

def resolve(target):
    module, name = target.split(":")
    return getattr(importlib.import_module(module), name)

plan = json.loads(sys.argv[1])
function = resolve(plan["call"][0])
if plan["warm"] is not None:
    resolve(plan["warm"][0])(*plan["warm"][1])
before = status_bytes("self", "VmRSS")
reset_peak("self")
outcome = function(*plan["call"][1])
print(json.dumps({"before": before, "peak": status_bytes("self", "VmHWM"), "outcome": str(outcome)}))
"""


def status_bytes(pid: int | str, field: str) -> int:
    """A memory field of `/proc/PID/status` ("VmRSS": resident now, "VmHWM": its peak), in bytes."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1]) * 1024
    raise RuntimeError(f"no {field} in /proc/{pid}/status")


def reset_peak(pid: int | str) -> None:
    """Set the process's high-water mark (VmHWM) to its current RSS (Linux `clear_refs` 5)."""
    Path(f"/proc/{pid}/clear_refs").write_text("5")


@dataclass(frozen=True)
class PeakGrowth:
    """What one call cost: resident bytes before it, its peak, and what it returned (as text)."""

    before_bytes: int
    peak_bytes: int
    outcome: str

    @property
    def growth_bytes(self) -> int:
        """Peak resident bytes above those held before the call (>= 0)."""
        return max(0, self.peak_bytes - self.before_bytes)


def peak_growth(target: str, args: list[str], warm: tuple[str, list[str]] | None = None,
                timeout_s: float = 1800) -> PeakGrowth:
    """Run `target` ("module:function") on string `args` in a fresh child and measure its peak;
    `warm` ("module:function", args) is called first, outside the measurement.

    Raises `RuntimeError` with the child's error output if the probe fails (no `/proc`, a
    `clear_refs` that cannot be written, the function raising): a wrong figure is never
    returned in place of a failure.
    """
    plan = json.dumps({"call": [target, args], "warm": list(warm) if warm else None})
    done = subprocess.run([sys.executable, "-c", PROBE, plan], cwd=REPO, capture_output=True,
                          text=True, timeout=timeout_s, env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})
    if done.returncode != 0:
        raise RuntimeError(f"the memory probe of {target} failed (exit {done.returncode}): {done.stderr[-800:]}")
    figures = json.loads(done.stdout.strip().splitlines()[-1])
    return PeakGrowth(figures["before"], figures["peak"], figures["outcome"])


def allocate(n_bytes: str) -> str:
    """Touch a fresh `n_bytes` buffer and free it: a call of known peak, to test the probe."""
    buffer = bytearray(int(n_bytes))
    buffer[:: 4096] = b"\x01" * len(buffer[:: 4096])   # every page written, so every page resident
    del buffer
    return "allocated"


__all__ = ["PROBE", "PeakGrowth", "allocate", "peak_growth", "reset_peak", "status_bytes"]
