"""Run files of the three lab cases, recorded by `daq run` from the simulated rig (dry friction)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from testkit.repo import REPO

SIM_URL = ("sim://?cases=cart1,cart2,both&fc1=0.15&fc2=0.15&rate_hz=200&seed=5&realtime=0")


def record_lab_runs(runs_dir: Path, bench: str = "bench1") -> list[Path]:
    """Three `.mcap` runs in start order (cart1, cart2, both)."""
    subprocess.run([sys.executable, "-m", "daq.cli", "run", "--port", SIM_URL, "--bench", bench,
                    "--runs-dir", str(runs_dir), "--no-zenoh", "--until-eof"],
                   cwd=REPO, check=True, capture_output=True, timeout=60)
    runs = sorted(runs_dir.glob("*.mcap"))
    assert len(runs) == 3, runs
    return runs
