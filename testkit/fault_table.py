"""The table of `tools/bench_faults.py --issue14`: one `Row` per fault, its scores, and the
helpers every row uses (a Python child of this repository, a run recorded from `sim://`).

The rows themselves live by concept: `testkit.fault_rows_worker` (rows 2-4: a worker and its
peers), `testkit.fault_rows_files` (rows 1, 5-7: run files, a full disk, recovery),
`testkit.fault_rows_resources` (rows 8 and 10: memory per input, the suite under load);
`testkit.fault_rows.all_rows` runs them all.
"""

from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
BENCH = "bench1"


@dataclass
class Row:
    """One fault and its scores (the targets are all zero).

    `data_lost`: "0" or what was lost; `over_bound`: "0" or which bound (memory per input,
    bytes written, time per request) was exceeded and by how much; `crashes`: processes that
    ended badly, tests that failed, or the row itself raising; `double_fits`: final reports
    beyond one per run; `unfitted`: runs left without an `ok` final report.
    """

    fault: str
    tried: str
    outcome: str
    data_lost: str = "0"
    crashes: int = 0
    double_fits: int = 0
    unfitted: int = 0
    over_bound: str = "0"

    @property
    def ok(self) -> bool:
        return self.data_lost == "0" and self.over_bound == "0" and not (
            self.crashes or self.double_fits or self.unfitted)


def print_table(rows: list[Row]) -> None:
    head = ("fault", "what was tried", "outcome", "data lost", "over a bound", "crashes", "double fits",
            "unfitted")
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for r in rows:
        print(f"| {r.fault} | {r.tried} | {r.outcome} | {r.data_lost} | {r.over_bound} | {r.crashes} | "
              f"{r.double_fits} | {r.unfitted} |", flush=True)


def failed_row(fault: str, exc: BaseException) -> Row:
    """The row of a fault whose trial itself raised (a wait that timed out, a process that died):
    scored as a crash, with the error, so the table still comes out whole."""
    return Row(fault, "(the trial raised)", f"{type(exc).__name__}: {str(exc)[:300]}", crashes=1)



def run_python(args: list[str], cwd: Path = REPO, timeout_s: float = 600) -> subprocess.CompletedProcess[str]:
    """`python ARGS` in `cwd` (one BLAS thread), its output captured as text."""
    return subprocess.run([sys.executable, *args], cwd=cwd, capture_output=True, text=True, timeout=timeout_s,
                          env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})


def record_sim(directory: Path, url: str) -> Path:
    """The first run file `daq run` records from `url` (no Zenoh) into `directory`."""
    run_python(["-m", "daq.cli", "run", "--port", url, "--bench", BENCH, "--runs-dir", str(directory),
                "--no-zenoh", "--until-eof"]).check_returncode()
    return next(directory.glob("*.mcap"))


__all__ = ["BENCH", "REPO", "Row", "failed_row", "print_table", "record_sim", "run_python"]
