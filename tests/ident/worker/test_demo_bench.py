"""`make demo` runs `tools/demo_bench.py`: the whole chain from a simulated rig to the report."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[3]


@pytest.mark.timeout(150)
def test_demo_bench_writes_the_report_and_prints_the_summary(tmp_path: Path) -> None:
    out = tmp_path / "demo-report"
    proc = subprocess.run([sys.executable, "tools/demo_bench.py", "--out", str(out), "--rate-hz", "100",
                           "--seed", "4"], cwd=REPO, capture_output=True, text=True, timeout=140)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    lines = proc.stdout.splitlines()
    assert any("runs recorded 3/3" in line and "done 3/3" in line for line in lines)   # progress
    header = next(i for i, line in enumerate(lines) if line.startswith("case "))
    rows = [line.split()[0] for line in lines[header + 2:header + 5]]
    assert rows == ["cart1", "cart2", "both"]
    assert all("coulomb_friction" in line for line in lines[header + 2:header + 5])
    assert "demo: 3/3 lab cases" in proc.stdout
    for name in ("index.html", "report.md", "both-pem.svg", "cart1-simple.png"):
        assert (out / name).is_file()
    assert len(list((out / "runs").glob("*.mcap"))) == 3
    assert not any("Traceback" in (out / "logs" / log).read_text()
                   for log in ("demo-worker.log", "daq.log"))
