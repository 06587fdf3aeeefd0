"""The demo bench (`make demo`): a simulated rig through the whole service to the lab report.

    .venv/bin/python tools/demo_bench.py --out demo-report

Starts, on loopback only: an embedded Zenoh peer (this process), an `ident worker`
process, and `daq run` on a `sim://` rig with dry friction performing the three lab cases
(cart 1 with cart 2 pinned, cart 2 with cart 1 pinned, both carts) as fast as it can
compute them. Every run records anew: a previous `<out>/` is first moved aside to
`<out>.old/<UTC time>/` (never republished), and only runs recorded by this `daq` are
reported. It waits for the three fit reports on Zenoh (showing progress), stops the
processes, writes the lab report to `<out>/` (`index.html`, `report.md`, `report.ipynb`,
figures; the run files stay in `<out>/runs/`) and prints a summary table. Exit code 0 when all three
cases were fitted, 1 otherwise, 2 when a process died or a wait timed out.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from datetime import UTC, datetime
from pathlib import Path

from testkit.benchkit import Bench, sim_url
from testkit.waiting import ProcessDied, wait_until

CASES = ("cart1", "cart2", "both")


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("demo-report"), help="report directory")
    parser.add_argument("--rate-hz", type=float, default=200.0, help="sample rate of the rig")
    parser.add_argument("--friction-n", type=float, default=0.15,
                        help="dry (Coulomb) friction force on each cart, N")
    parser.add_argument("--seed", type=int, default=1, help="seed of the rig's noise and hand")
    parser.add_argument("--timeout-s", type=float, default=100.0, help="longest wait for the fits")
    parser.add_argument("--no-notebook", action="store_true",
                        help="write report.ipynb without running it (no Jupyter kernel; ~13 s faster)")
    return parser.parse_args(argv)


class Progress:
    """One status line, rewritten in place on a terminal, printed on change otherwise."""

    def __init__(self, bench: Bench, started: float) -> None:
        self.bench, self.started, self.last = bench, started, ""

    def __call__(self) -> None:
        self.bench.watcher.drain()
        w = self.bench.watcher
        done = set(w.fits)
        fitting = {(c.bench, c.run_id) for c in w.claims} - set(w.partial_at) - done
        diagnosing = set(w.partial_at) - done
        line = (f"[{time.monotonic() - self.started:5.1f} s] runs recorded {len(w.finished)}/3, "
                f"fitting {len(fitting)}, diagnosing {len(diagnosing)}, done {len(done)}/3")
        if line[10:] != self.last[10:] or sys.stdout.isatty():
            end = "\r" if sys.stdout.isatty() else "\n"
            print(line, end=end, flush=True)
        self.last = line


def move_aside(out: Path) -> Path | None:
    """Move a previous report directory to `<out>.old/<UTC time>/`; where it went."""
    if not out.exists():
        return None
    stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%S.%fZ")
    target = out.with_name(out.name + ".old") / stamp
    target.parent.mkdir(parents=True, exist_ok=True)
    out.rename(target)
    return target


def run_bench(out: Path, url: str, timeout_s: float, started: float) -> list[Path]:
    """Run daq + worker until the three fits are published; return the fit directories."""
    runs = out / "runs"
    with Bench(out / "logs") as bench:
        print(f"demo: Zenoh peer on {bench.endpoint} (loopback only, scouting off)")
        print("demo: starting ident worker (loads scipy/control/matplotlib) ...", flush=True)
        bench.start_worker("demo-worker", runs)
        bench.wait_workers({"demo-worker"})
        print(f"demo: starting daq on {url}", flush=True)
        bench.start_daq("daq", url, "demo", runs)
        progress = Progress(bench, started)
        wait_until(lambda: len(bench.watcher.final_reports()) >= len(CASES), timeout_s,
                   "the three fit reports", bench.procs, progress=progress, poll_s=0.1)
        progress()
        print()
        fits = bench.watcher.final_reports()
        recorded = set(bench.watcher.finished)
    # only the runs this daq recorded: a stored fit is never reported as new
    return [runs / f"{run_id}.fit" for (bench_name, run_id) in sorted(fits)
            if (bench_name, run_id) in recorded]


def print_summary(results: list) -> None:  # type: ignore[type-arg]
    from ident.report.content import summary_rows

    rows = summary_rows(results)
    header = ("case", "wn (rad/s)", "zeta", "fit % (PEM; RK4)", "diagnosed cause", "gain (pts)")
    table = [header] + [(r[0], r[2], r[3], r[4], r[5], r[6]) for r in rows]
    widths = [max(len(row[i]) for row in table) for i in range(len(header))]
    for k, row in enumerate(table):
        print("  ".join(cell.ljust(w) for cell, w in zip(row, widths)))
        if k == 0:
            print("  ".join("-" * w for w in widths))
    print("\nidentified transfer functions X_i(s)/R(s) (PEM):")
    for r in rows:
        for i, tf in enumerate(r[1].split(" ; ")):
            print(f"  {r[0]:6s} {'cart ' + str(i + 1) + ': ' if r[0] == 'both' else ''}{tf}")


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    started = time.monotonic()
    url = sim_url(CASES, friction_n=args.friction_n, rate_hz=args.rate_hz, seed=args.seed)
    previous = move_aside(args.out)
    if previous is not None:
        print(f"demo: the previous report moved to {previous}; recording new runs")
    try:
        fit_dirs = run_bench(args.out, url, args.timeout_s, started)
    except (ProcessDied, TimeoutError) as exc:
        print(f"\ndemo: FAILED: {exc}\n(logs in {args.out / 'logs'})", file=sys.stderr)
        return 2
    from ident.commands.report import gather
    from ident.report.writer import write_report_dir

    print("demo: writing the lab report ...", flush=True)
    results = write_report_dir(gather(fit_dirs, args.out / "fits"), args.out, run_notebook=not args.no_notebook)
    print()
    print_summary(results)
    print(f"\ndemo: {len(results)}/3 lab cases in {time.monotonic() - started:.1f} s; report: "
          f"{args.out / 'index.html'} and {args.out / 'report.md'}")
    return 0 if len(results) == len(CASES) else 1


if __name__ == "__main__":
    sys.exit(main())
