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

from pathlib import Path

from testkit.fault_rows_files import (
    row1_diagnosis,
    row1b_simple_start,
    row5_full_disk,
    row5b_backlog_overflow,
    row6_recover,
    row7_odd_entries,
)
from testkit.fault_rows_resources import row8_memory, row10_load
from testkit.fault_rows_worker import row2_daq_gone, row3_pause, row4_abuse, row11_worker_start
from testkit.fault_table import Row, print_table


def all_rows(work: Path, csv_mb: float = 224.0, load_repeat: int = 3) -> list[Row]:
    rows = [row1_diagnosis(work), row1b_simple_start(work), row2_daq_gone(work), row3_pause(work),
            *row4_abuse(work), row5_full_disk(work), row5b_backlog_overflow(work), row6_recover(work),
            row7_odd_entries(work), *row8_memory(work, csv_mb), row10_load(work, load_repeat),
            row11_worker_start(work)]
    return rows


__all__ = ["Row", "all_rows", "print_table"]
