"""Run the test suite with CPU-burning processes beside it (issue 14: the suite passes on a busy machine).

    .venv/bin/python tools/suite_under_load.py [--burners 2] [--repeat 1] [--log-dir DIR] [PYTEST ARGS...]

Starts `--burners` processes that spin on the CPU (plain arithmetic, no I/O) at normal
priority, runs `python -m pytest` with the given arguments (default: the whole suite, `-q`)
`--repeat` times, then ends the burners. Prints each run's outcome line, wall time and exit
code, and exits with the first non-zero code. A failed run also prints its failure report
(pytest's FAILURES section: the assertion and its traceback, at most `MAX_REPORT_LINES`
lines), because a failure seen only under load is useless without what failed; `--log-dir`
keeps every run's whole output as `run-K.log`. Not part of `make test`: it is the check a
maintainer runs before trusting that the suite is free of timing assumptions.
"""

from __future__ import annotations

import argparse
import multiprocessing
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
#: Most lines of a failed run's report printed (the whole output goes to `--log-dir`).
MAX_REPORT_LINES = 200


def burn(stop: multiprocessing.synchronize.Event) -> None:
    """Spin until `stop` is set (checked every ~10 ms of work)."""
    x = 0
    while not stop.is_set():
        for i in range(200_000):
            x = (x * 31 + i) % 1_000_003


def failure_report(output: str) -> list[str]:
    """The FAILURES/ERRORS sections of pytest's output (up to its short summary), or its
    FAILED/ERROR lines when there is no such section (e.g. `-q --tb=no`)."""
    lines = output.splitlines()
    start = next((i for i, line in enumerate(lines) if line.startswith("=") and
                  ("FAILURES" in line or "ERRORS" in line)), None)
    if start is None:
        return [line for line in lines if line.startswith(("FAILED", "ERROR"))]
    end = next((i for i in range(start + 1, len(lines)) if "short test summary" in lines[i]), len(lines))
    report = lines[start:end]
    if len(report) > MAX_REPORT_LINES:
        report = [*report[:MAX_REPORT_LINES], f"... ({len(report) - MAX_REPORT_LINES} more lines)"]
    return report + [line for line in lines[end:] if line.startswith(("FAILED", "ERROR"))]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--burners", type=int, default=2, help="CPU-burning processes (default 2)")
    parser.add_argument("--repeat", type=int, default=1, help="how many times to run pytest (default 1)")
    parser.add_argument("--log-dir", type=Path, default=None, help="keep each run's whole output as DIR/run-K.log")
    args, pytest_args = parser.parse_known_args(argv)
    pytest_args = pytest_args or ["-q"]
    stop = multiprocessing.Event()
    burners = [multiprocessing.Process(target=burn, args=(stop,), name=f"burner-{i}")
               for i in range(args.burners)]
    for proc in burners:
        proc.start()
    first_failure = 0
    try:
        for run in range(1, args.repeat + 1):
            started = time.monotonic()
            done = subprocess.run([sys.executable, "-m", "pytest", *pytest_args], cwd=REPO,
                                  capture_output=True, text=True)
            lines = [line for line in done.stdout.splitlines() if line.strip()]
            summary = lines[-1] if lines else "(no output)"
            print(f"run {run}/{args.repeat} with {args.burners} burners: exit {done.returncode}, "
                  f"{time.monotonic() - started:.0f} s: {summary}", flush=True)
            if args.log_dir is not None:
                args.log_dir.mkdir(parents=True, exist_ok=True)
                (args.log_dir / f"run-{run}.log").write_text(done.stdout + done.stderr)
            if done.returncode != 0:
                print("\n".join(failure_report(done.stdout)), flush=True)
                first_failure = first_failure or done.returncode
    finally:
        stop.set()
        for proc in burners:
            proc.join(timeout=5)
    return first_failure


if __name__ == "__main__":
    raise SystemExit(main())
