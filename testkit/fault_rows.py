"""The rows of issue 14, each tried for real (loopback only) and scored: `tools/bench_faults.py --issue14`.

Each row function makes one fault happen the way the independent fault test did, and returns
a `testkit.fault_table.Row`: the fault, what was tried, the outcome, and the four scores the
issue asks for (data lost, crashes, double fits, runs left unfitted). The rows live by
concept: `fault_rows_files` (1, 1b, 5, 5b, 6, 7), `fault_rows_worker` (2-4, 11),
`fault_rows_resources` (8, 10). Rows 1b, 5b and 11 are the leftovers of the issue: the
simple fit's start on carts stuck between two counts, a full disk past the backlog's bound,
and a worker declared alive only once it can fit.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from pathlib import Path

from testkit.fault_rows_files import (
    row1_diagnosis,
    row1b_simple_start,
    row5_full_disk,
    row5b_backlog_overflow,
    row6_recover,
    row7_odd_entries,
)
from testkit.fault_rows_resources import LOAD_TESTS, row8_memory, row10_load
from testkit.fault_rows_worker import row2_daq_gone, row3_pause, row4_abuse, row11_worker_start
from testkit.fault_table import Row, failed_row, print_table


def all_rows(work: Path, csv_mb: float = 224.0, load_repeat: int = 3,
             load_tests: tuple[str, ...] = LOAD_TESTS) -> list[Row]:
    """Every row, in the issue's order; a trial that raises is scored as a crash (`failed_row`)
    and the others still run. Prints one progress line per trial to stderr."""
    trials: list[tuple[str, Callable[[], Row | list[Row]]]] = [
        ("1 diagnosis crash", lambda: row1_diagnosis(work)),
        ("1b simple start", lambda: row1b_simple_start(work)),
        ("2 stopped daq", lambda: row2_daq_gone(work)),
        ("3 paused worker", lambda: row3_pause(work)),
        ("4 abuse", lambda: row4_abuse(work)),
        ("5 full disk", lambda: row5_full_disk(work)),
        ("5b full disk past the backlog", lambda: row5b_backlog_overflow(work)),
        ("6 daq recover", lambda: row6_recover(work)),
        ("7 odd entries", lambda: row7_odd_entries(work)),
        ("8 memory", lambda: row8_memory(work, csv_mb)),
        ("10 suite under load", lambda: row10_load(work, load_repeat, load_tests)),
        ("11 worker start", lambda: row11_worker_start(work)),
    ]
    rows: list[Row] = []
    for fault, trial in trials:
        started = time.monotonic()
        try:
            result = trial()
        except Exception as exc:  # noqa: BLE001 - a trial that raises is a crash in its row
            result = failed_row(fault, exc)
        rows += result if isinstance(result, list) else [result]
        print(f"  row {fault}: {time.monotonic() - started:.0f} s", file=sys.stderr, flush=True)
    return rows


__all__ = ["Row", "all_rows", "print_table"]
