"""`tools/suite_under_load.py`: a failed run shows what failed (the assertion and its
traceback), and `--log-dir` keeps every run's whole output. Before, it printed pytest's
one-line FAILED summaries alone, cut short, and the failure of row 10 seen under load never
showed which count fell short. (No burner here: this is about the report, not the load.)"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from testkit.repo import REPO

FAILING = '''
def test_passes():
    assert True


def test_fails_with_a_message():
    counted = 7
    assert counted >= 16, "only 7 of 16 payloads logged"
'''


def test_a_failed_run_prints_its_assertion_and_keeps_its_log(tmp_path: Path) -> None:
    module = tmp_path / "test_sample.py"
    module.write_text(FAILING)
    logs = tmp_path / "logs"
    done = subprocess.run([sys.executable, "tools/suite_under_load.py", "--burners", "0", "--repeat", "2",
                           "--log-dir", str(logs), str(module), "-q", "-p", "no:cacheprovider"],
                          cwd=REPO, capture_output=True, text=True, timeout=300)
    assert done.returncode != 0
    runs = [line for line in done.stdout.splitlines() if line.startswith("run ")]
    assert len(runs) == 2 and all("1 failed, 1 passed" in line for line in runs), done.stdout
    assert done.stdout.count("only 7 of 16 payloads logged") >= 2, done.stdout   # the assertion, each run
    assert "def test_fails_with_a_message" in done.stdout                       # and its traceback
    assert "test_passes" not in done.stdout.replace("1 passed", "")
    for k in (1, 2):
        assert "only 7 of 16 payloads logged" in (logs / f"run-{k}.log").read_text()
