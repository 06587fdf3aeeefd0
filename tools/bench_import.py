"""Start-up cost of `ident`: wall time of `import ident` and of `ident --help` in fresh
interpreters, median and minimum over `--repeats` runs, for one or more source trees
(`--tree DIR`, default this checkout) measured in alternation so that load hits them alike.

    python tools/bench_import.py
    python tools/bench_import.py --tree . --tree ../other-checkout --repeats 9
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PROBES = {
    "import ident": "import ident",
    "ident --help": "import contextlib, io\nfrom ident.cli import main\n"
                    "with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):\n"
                    "    main(['--help'])",
}


def once(tree: Path, statement: str) -> float:
    """Seconds from interpreter start-up done to `statement` done, in a fresh process."""
    code = f"import time\n_t0 = time.perf_counter()\n{statement}\nprint(time.perf_counter() - _t0)"
    env = {**os.environ, "PYTHONPATH": str(tree), "OPENBLAS_NUM_THREADS": "1"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                         cwd=tree, check=True, timeout=300).stdout
    return float(out.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tree", action="append", type=Path, help="a source tree (repeatable)")
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args(argv)
    trees = [t.resolve() for t in (args.tree or [ROOT])]
    times: dict[tuple[Path, str], list[float]] = {(t, p): [] for t in trees for p in PROBES}
    for _ in range(args.repeats):
        for probe, statement in PROBES.items():
            for tree in trees:
                times[tree, probe].append(once(tree, statement))
    print(f"{'tree':40s} {'probe':14s} {'median s':>9s} {'min s':>7s}   (load average {os.getloadavg()[0]:.1f})")
    for (tree, probe), values in times.items():
        print(f"{str(tree)[-40:]:40s} {probe:14s} {statistics.median(values):9.3f} {min(values):7.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
