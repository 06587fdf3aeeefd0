"""Rows 1 and 5-7 of issue 14: run files (the diagnosis of a clean and a truncated run, a full
disk mid-run, `daq recover` beside a finished run, odd entries in the runs directory)."""

from __future__ import annotations

import itertools
import json
import os
from pathlib import Path
from typing import Any

from schemas import run_file
from testkit.fault_table import BENCH, Row, record_sim, run_python
from testkit.full_disk import Disk


def row1_diagnosis(work: Path) -> Row:
    run = record_sim(work / "r1", "sim://?cases=cart1&rate_hz=1000&seed=3&realtime=0")
    half = work / "r1" / "half.mcap"
    data = run.read_bytes()
    half.write_bytes(data[: len(data) // 2])
    outcomes = []
    crashes = 0
    for path in (run, half):
        done = run_python(["-m", "ident.cli", "diagnose", str(path), "--json"])
        ok = done.returncode == 0 and "Traceback" not in done.stderr
        crashes += not ok
        if ok:
            report = json.loads(done.stdout)
            outcomes.append(f"{path.name.split('.')[0][:4]}: cause {report.get('cause')}, "
                            f"fit {report['baseline']['fit_percent']:.2f} %")
        else:
            outcomes.append(f"{path.name}: exit {done.returncode}")
    return Row("1 diagnosis crash", "ident diagnose on a clean 1 kHz one-cart sim:// run and a half-truncated copy",
               "; ".join(outcomes), crashes=crashes)


_SIMPLE_FITS = """
import json, sys, warnings
from pathlib import Path
warnings.filterwarnings("ignore")
from ident.fitrun.analysis import analyse_fits
from ident.io import load
for path in sys.argv[1:]:
    analysis = analyse_fits(load(Path(path)))
    print(json.dumps({"methods": [r.method for r in analysis.simple], "error": analysis.errors.get("simple")}))
"""


def row1b_simple_start(work: Path) -> Row:
    """The worker's simple fits on the runs that made 'Residuals are not finite in the initial
    point': dry friction leaves a cart stuck between two encoder counts (500 and 1 kHz)."""
    paths: list[Path] = []
    for rate in (500, 1000):
        folder = work / f"r1b-{rate}"
        record_sim(folder, f"sim://?cases=cart1,cart2&repeat=2&rate_hz={rate}&seed=2&realtime=0&fc1=0.1&fc2=0.1")
        paths += sorted(folder.glob("*.mcap"))
    done = run_python(["-c", _SIMPLE_FITS, *map(str, paths)])
    results = [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]
    not_finite = sum("not finite" in (r["error"] or "") for r in results)
    both = sum(r["methods"] == ["rk4", "euler"] for r in results)
    return Row("1b simple start", f"the simple fits (RK4, Euler) of {len(paths)} daq-recorded sim:// runs with dry "
               "friction at 500 Hz and 1 kHz (carts stuck between two counts)",
               f"both methods fitted on {both}/{len(results)}; 'not finite in the initial point' {not_finite}x",
               crashes=not_finite + int(done.returncode != 0), unfitted=len(paths) - both)


def _service_run(url: str, runs_dir: Path, disk: Disk, backlog_samples: int | None = None) -> tuple[Any, int]:
    from daq.recording import BACKLOG_SAMPLES
    from daq.serial_link import SerialLink
    from daq.service import Service, ServiceConfig

    ticks = itertools.count()
    service = Service(ServiceConfig(port=url, runs_dir=runs_dir, bench=BENCH, bus=None, until_eof=True,
                                    disk_backlog_samples=backlog_samples or BACKLOG_SAMPLES),
                      clock=lambda: next(ticks) * 1e-2, link=SerialLink(url, sleep=lambda _s: None),
                      opener=disk.opener)
    try:
        service.run()
    except Exception:  # noqa: BLE001 - a crash is what this row counts
        return service, 1
    return service, 0


def row5_full_disk(work: Path) -> Row:
    from daq.run_file import load_run

    url = "sim://?realtime=0&rate_hz=500&cases=cart1&seed=21&rest_s=1&pull_s=0.6&hold_s=1&tail_s=1"
    _, crashed = _service_run(url, work / "r5", Disk(60_000, 3))
    _service_run(url, work / "r5-clean", Disk(1 << 40, 1 << 30))
    recorded = [load_run(p) for p in sorted((work / "r5").glob("*.mcap"))]
    written = set().union(*(set(r.t_ns.tolist()) for r in recorded))
    whole = set().union(*(set(load_run(p).t_ns.tolist()) for p in (work / "r5-clean").glob("*.mcap")))
    missing = len(whole - written)
    gaps = [g for r in recorded if r.metadata for g in r.metadata.counters.gap_intervals if g.reason == "disk_full"]
    statuses = ", ".join(r.finished.status for r in recorded if r.finished)
    return Row("5 full disk", "ENOSPC injected at the file layer mid-run, space back after 3 refused writes",
               f"run kept going (live stream untouched): {len(recorded)} files ({statuses}), the batches kept in "
               f"memory while full written first; {len(gaps)} gaps marked; path and run named in the log",
               data_lost=str(missing), crashes=crashed)


def row5b_backlog_overflow(work: Path) -> Row:
    """The disk full for seconds with a backlog of 100 samples (0.2 s at 500 Hz): every sample
    is in a file or strictly inside the one marked gap, none in two files."""
    from daq.run_file import load_run

    url = "sim://?realtime=0&rate_hz=500&cases=cart1&seed=21&rest_s=1&pull_s=0.6&hold_s=1&tail_s=1"
    _, crashed = _service_run(url, work / "r5b", Disk(60_000, 5), backlog_samples=100)
    _service_run(url, work / "r5b-clean", Disk(1 << 40, None))
    recorded = [load_run(p) for p in sorted((work / "r5b").glob("*.mcap"))]
    times = [t for r in recorded for t in r.t_ns.tolist()]
    whole = set().union(*(set(load_run(p).t_ns.tolist()) for p in (work / "r5b-clean").glob("*.mcap")))
    gaps = [g for r in recorded if r.metadata for g in r.metadata.counters.gap_intervals if g.reason == "disk_full"]
    lost = whole - set(times)
    unmarked = sum(not any(g.start_t_ns < t < g.end_t_ns for g in gaps) for t in lost)
    twice = len(times) - len(set(times))
    return Row("5b full disk past the backlog", "ENOSPC mid-run for ~8 s with a 100-sample backlog (0.2 s at 500 Hz)",
               f"{len(recorded)} files; {len(lost)} samples lost, all inside the {len(gaps)} gap(s) marked "
               f"disk_full ({unmarked} outside); {twice} samples in two files",
               data_lost=str(unmarked + twice), crashes=crashed)


# --- rows 6 and 7: recovery ---------------------------------------------------------------------------

def row6_recover(work: Path) -> Row:
    runs = work / "r6"
    run = record_sim(runs, "sim://?cases=cart1&rate_hz=1000&seed=5&realtime=0")
    before = run.read_bytes()
    stale = runs / f"{run_file.run_id_of(run)}{run_file.PART_SUFFIX}"
    stale.write_bytes(before[: len(before) // 3])          # a stale part beside the finished file
    junk = runs / "junk.mcap.part"
    junk.write_bytes(os.urandom(4096))
    done = run_python(["-m", "daq.cli", "recover", str(runs)])
    intact = run.read_bytes() == before
    quarantined = (runs / run_file.QUARANTINE_DIR / "junk.mcap.part").is_file()
    recovered = list(runs.glob("*-r1.mcap"))
    lost = "0" if intact and quarantined and recovered else "finished run or part lost"
    return Row("6 daq recover", "a finished run with a stale .part beside it, and an unreadable .part",
               f"finished file intact: {intact}; stale part into {recovered[0].name if recovered else '-'}; "
               f"unreadable part quarantined: {quarantined}", data_lost=lost, crashes=int(done.returncode != 0))


def row7_odd_entries(work: Path) -> Row:
    runs = work / "r7"
    runs.mkdir()
    (runs / "dir.mcap.part").mkdir()
    (runs / "loop.mcap.part").symlink_to(runs / "loop.mcap.part")
    done = run_python(["-m", "daq.cli", "recover", str(runs)])
    started = run_python(["-m", "daq.cli", "run", "--port", "sim://?cases=cart1&rate_hz=200&seed=2&realtime=0",
                    "--bench", BENCH, "--runs-dir", str(runs), "--no-zenoh", "--until-eof"])
    recorded = len(list(runs.glob("*.mcap")))
    return Row("7 odd entries", "a directory and a symlink loop named *.mcap.part in the runs directory",
               f"daq recover exit {done.returncode} (skipped, named), daq run exit {started.returncode}, "
               f"{recorded} run recorded", data_lost="0" if recorded else "the run not recorded",
               crashes=int(done.returncode != 0) + int(started.returncode != 0))



__all__ = ["row1_diagnosis", "row1b_simple_start", "row5_full_disk", "row5b_backlog_overflow", "row6_recover",
           "row7_odd_entries"]
