"""`testkit.peak_memory`, the measuring code of the issue-14 memory rows: a call of known peak
is measured as that peak, whatever the parent's size and whatever the child did before it.

The first test failed with the former measurement (`ru_maxrss` after minus before, in a child
of the bench): Linux keeps the maximum RSS across `execve`, so a child of a parent larger than
its own peak measured +0 MB.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np

from testkit.peak_memory import peak_growth, reset_peak, status_bytes
from testkit.repo import REPO

MB = 1 << 20
ALLOCATE = "testkit.peak_memory:allocate"
#: what a measured call may show beyond its own buffer (allocator and interpreter noise)
SLACK = 6 * MB


def test_a_child_of_a_large_parent_measures_its_own_peak() -> None:
    n = 48 * MB
    parent = np.ones((n + 96 * MB) // 8, dtype=np.float64)   # resident in this process: larger than the child
    measured = peak_growth(ALLOCATE, [str(n)])
    assert parent.sum() > 0
    assert measured.outcome == "allocated"
    assert n - SLACK <= measured.growth_bytes <= n + SLACK, measured


def test_the_warm_up_is_not_counted() -> None:
    measured = peak_growth(ALLOCATE, [str(32 * MB)], warm=(ALLOCATE, [str(160 * MB)]))
    assert 32 * MB - SLACK <= measured.growth_bytes <= 32 * MB + SLACK, measured


def test_a_call_that_allocates_nothing_measures_near_zero() -> None:
    measured = peak_growth(ALLOCATE, ["0"])
    assert measured.growth_bytes <= SLACK, measured


def test_another_process_s_peak_is_reset_and_read() -> None:
    # a child that allocates what it is told, one line at a time, and answers when done
    script = ("import sys\nfrom testkit.peak_memory import allocate\n"
              "for line in sys.stdin:\n    print(allocate(line.strip()), flush=True)\n")
    child = subprocess.Popen([sys.executable, "-c", script], cwd=REPO, stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, text=True)
    assert child.stdin is not None and child.stdout is not None
    try:
        child.stdin.write(f"{160 * MB}\n")
        child.stdin.flush()
        assert child.stdout.readline().strip() == "allocated"
        assert status_bytes(child.pid, "VmHWM") >= status_bytes(child.pid, "VmRSS") + 150 * MB
        reset_peak(child.pid)
        before = status_bytes(child.pid, "VmRSS")
        child.stdin.write(f"{32 * MB}\n")
        child.stdin.flush()
        assert child.stdout.readline().strip() == "allocated"
        grown = status_bytes(child.pid, "VmHWM") - before
        assert 32 * MB - SLACK <= grown <= 32 * MB + SLACK, grown
    finally:
        child.stdin.close()
        child.wait(timeout=30)
