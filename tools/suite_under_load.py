"""Run the test suite with CPU-burning processes beside it (issue 14: the suite passes on a busy machine).

    .venv/bin/python tools/suite_under_load.py [--burners 2] [--repeat 1] [PYTEST ARGS...]

Starts `--burners` processes that spin on the CPU (plain arithmetic, no I/O) at normal
priority, runs `python -m pytest` with the given arguments (default: the whole suite, `-q`)
`--repeat` times, then ends the burners. Prints each run's outcome line, wall time and exit
code, and exits with the first non-zero code. Not part of `make test`: it is the check a
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


def burn(stop: multiprocessing.synchronize.Event) -> None:
    """Spin until `stop` is set (checked every ~10 ms of work)."""
    x = 0
    while not stop.is_set():
        for i in range(200_000):
            x = (x * 31 + i) % 1_000_003


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--burners", type=int, default=2, help="CPU-burning processes (default 2)")
    parser.add_argument("--repeat", type=int, default=1, help="how many times to run pytest (default 1)")
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
            if done.returncode != 0:
                failed = [line for line in lines if line.startswith(("FAILED", "ERROR"))]
                print("\n".join(failed[:20]), flush=True)
                first_failure = first_failure or done.returncode
    finally:
        stop.set()
        for proc in burners:
            proc.join(timeout=5)
    return first_failure


if __name__ == "__main__":
    raise SystemExit(main())
