"""`make demo` runs `tools/demo_bench.py`: the whole chain from a simulated rig to the report."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[3]


def _demo(out: Path, friction_n: float, *options: str) -> tuple[list[str], list[str]]:
    """Run the demo; its printed summary rows (case first) and the run ids it recorded."""
    proc = subprocess.run([sys.executable, "tools/demo_bench.py", "--out", str(out), "--rate-hz", "100",
                           "--seed", "4", "--friction-n", str(friction_n), *options],
                          cwd=REPO, capture_output=True, text=True, timeout=140)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    lines = proc.stdout.splitlines()
    assert any("runs recorded 3/3" in line and "done 3/3" in line for line in lines)   # progress
    assert "demo: 3/3 lab cases" in proc.stdout
    header = next(i for i, line in enumerate(lines) if line.startswith("case "))
    return lines[header + 2:header + 5], sorted(p.stem for p in (out / "runs").glob("*.mcap"))


@pytest.mark.timeout(300)
def test_demo_bench_records_anew_each_time_and_reports_its_own_runs(tmp_path: Path) -> None:
    out = tmp_path / "demo-report"
    rows, first_ids = _demo(out, friction_n=0.15)
    assert [row.split()[0] for row in rows] == ["cart1", "cart2", "both"]
    assert all("coulomb_friction" in row for row in rows)
    assert all(run_id in (out / "report.md").read_text() for run_id in first_ids)
    assert re.search(r'"execution_count": \d', (out / "report.ipynb").read_text())    # the notebook ran
    # a second demo without friction: new runs, the old report moved aside, nothing republished
    # (its notebook written, not run: `tests/ident/report/test_lab_report.py` runs one)
    rows, second_ids = _demo(out, 0.0, "--no-notebook")
    assert len(second_ids) == 3 and not set(second_ids) & set(first_ids)
    assert not any("coulomb_friction" in row for row in rows)
    report = (out / "report.md").read_text()
    assert all(r in report for r in second_ids) and not any(r in report for r in first_ids)
    (old,) = (tmp_path / "demo-report.old").iterdir()
    assert sorted(p.stem for p in (old / "runs").glob("*.mcap")) == first_ids
    for name in ("index.html", "report.md", "report.ipynb", "both-pem.svg", "cart1-simple.png"):
        assert (out / name).is_file()
    assert not re.search(r'"execution_count": \d', (out / "report.ipynb").read_text())
    assert len(list((out / "runs").glob("*.mcap"))) == 3
    assert not any("Traceback" in (out / "logs" / log).read_text()
                   for log in ("demo-worker.log", "daq.log"))
