"""Faults survived, bad input refused, and a soak: the figures of issues 6 and 14.

    .venv/bin/python tools/bench_faults.py [--kill-trials 20] [--soak-s 3600] [--skip-soak] [--json FILE]
    .venv/bin/python tools/bench_faults.py --issue14 [--csv-mb 224] [--load-repeat 3] [--load-tests all|FILE...]
                                          [--json FILE]

`--issue14` runs only the rows of issue 14 (`testkit/fault_rows.py`: every row tried for
real, loopback only) and prints their table: fault, what was tried, outcome, data lost,
crashes, double fits, runs left unfitted (the targets are all zero). Rows 1b, 5b and 11 are
its leftovers: the simple fit's start on carts stuck between two encoder counts, a full disk
for longer than the backlog holds, a worker handed a run the moment it is declared alive.
Row 8 measures each load's peak memory in a fresh child (`testkit/peak_memory.py`); row 10 runs
`--load-tests` `--load-repeat` times beside two CPU burners (`tools/suite_under_load.py`).

Sections (each prints its figures; `--json` writes them all):
1. serial corruption — a 1 kHz two-encoder `sim://` capture with 1 % of its lines corrupted
   (bit flip, truncation, random bytes, NUL, 10 kB without newline), replayed through the
   `daq` service: injected vs counted, intact lines recorded vs expected, runs found; once
   sparing the hold before the release, once corrupting everywhere.
2. unplug/replug — `sim://` disconnects every second during one long run: cycles, gaps marked,
   samples delivered but not recorded.
3. clock and sequence wrap mid-run — steps in the recorded time, samples lost.
4. kill -9 — `--kill-trials` trials at seeded random moments (`testkit/faultkit.py`): recovered,
   max seconds and samples lost before the kill, holes.
5. bad input — every damaged file and payload tried against `ident.io.load` and the
   `schemas` records: refused with a clear error, loaded, or leaked another exception.
6. soak — `--soak-s` simulated seconds at 1 kHz, two encoders (the three lab cases and idle
   stretches, repeated) through `daq run` in a child process publishing on Zenoh to a
   subscriber here, as fast as it goes: wall time, RSS of the child at start and end, runs,
   samples recorded, samples lost (holes in runs, sequence gaps), live batches received.
"""

from __future__ import annotations

import argparse
import json
import logging
import queue
import random
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np

from testkit import faultkit, ports
from testkit import serialfaults as sf

SIM_1KHZ = ("sim://?realtime=0&rate_hz=1000&cases=both&seed=11&rest_s=1&pull_s=0.8&hold_s=1.2&c1=2&c2=2"
            "&tail_s=0.5")
SOAK_SIM = ("sim://?realtime=0&rate_hz=1000&carts=2&cases=cart1,idle,cart2,idle,both,idle&idle_s=20"
            "&repeat=10000&duration_s={duration}&seed=5&c1=1.5&c2=1.5&substep_hz=2000")


def section(title: str) -> None:
    print(f"\n== {title}", flush=True)


def corruption(work: Path) -> dict[str, Any]:
    clean = sf.read_port(SIM_1KHZ)
    clean_runs, _ = sf.run_service_on_bytes(clean, work / "clean")
    meta = clean_runs[0].metadata if clean_runs else None
    release_us = (meta.release_t_ns or 0) // 1000 if meta is not None else 0
    out: dict[str, Any] = {"lines": len(sf.intact_lines(clean))}
    variants = {"spare_hold": lambda t: release_us - 1_500_000 <= t <= release_us, "everywhere": lambda t: False}
    for name, spare in variants.items():
        corrupted = sf.corrupt_capture(clean, 0.01, seed=3, spare=spare)
        runs, counters = sf.run_service_on_bytes(corrupted.stream, work / name)
        t_ns = sf.unwrap_us(corrupted.intact[:, 1]) * 1000
        missing = sum(len(sf.expected(corrupted.intact, t_ns, r) - sf.recorded(r)) for r in runs)
        out[name] = {"injected": sum(corrupted.injected.values()), "by_kind": corrupted.injected,
                     "counted_bad_lines": counters.bad_lines, "runs": len(runs), "expected_runs": 1,
                     "intact_lines_in_runs_not_recorded": missing}
        print(f"  1 % corrupted ({name}): injected {out[name]['injected']} {corrupted.injected}, "
              f"counted {counters.bad_lines}, runs {len(runs)}/1, intact in-run lines not recorded {missing}")
    return out


def unplug(work: Path) -> dict[str, Any]:
    capture = work / "unplug.bin"
    url = ("sim://?realtime=0&rate_hz=200&cases=cart1&seed=7&rest_s=0.6&pull_s=0.5&hold_s=0.8&c1=0.3&c2=0.3"
           f"&disconnect_every_s=1.0&disconnect_s=0.25&reopen_failures=1&ring_max_s=14&tail_s=0.5&capture={capture}")
    runs, counters = sf.run_service(url, work / "unplug")
    lines = sf.intact_lines(capture.read_bytes())
    t_ns = sf.unwrap_us(lines[:, 1]) * 1000
    gaps = sum(1 for r in runs if r.metadata for g in r.metadata.counters.gap_intervals
               if g.reason == "disconnect" and r.t_ns[0] <= g.start_t_ns <= r.t_ns[-1])
    missing = sum(len(sf.expected(lines, t_ns, r) - sf.recorded(r)) for r in runs)
    print(f"  unplug/replug: {counters.reconnects} reconnects, {gaps} gaps marked inside {len(runs)} run(s), "
          f"delivered samples not recorded {missing}")
    return {"reconnects": counters.reconnects, "gaps_marked_in_run": gaps, "runs": len(runs),
            "delivered_not_recorded": missing}


def wraps(work: Path) -> dict[str, Any]:
    capture = work / "wrap.bin"
    url = ("sim://?realtime=0&rate_hz=200&cases=cart1&seed=8&rest_s=0.5&pull_s=0.5&hold_s=0.8&c1=1"
           f"&clock0_us={2**32 - 3_200_000}&seq0={2**32 - 700}&tail_s=0.5&capture={capture}")
    runs, counters = sf.run_service(url, work / "wrap")
    steps = np.concatenate([np.diff(r.t_ns) for r in runs]) if runs else np.zeros(0)
    lines = sf.intact_lines(capture.read_bytes())
    t_ns = sf.unwrap_us(lines[:, 1]) * 1000
    missing = sum(len(sf.expected(lines, t_ns, r) - sf.recorded(r)) for r in runs)
    result = {"clock_wraps": counters.clock_wraps, "runs": len(runs),
              "min_step_ms": float(steps.min() / 1e6) if steps.size else None,
              "max_step_ms": float(steps.max() / 1e6) if steps.size else None, "samples_lost": missing}
    print(f"  clock+seq wrap mid-run: {counters.clock_wraps} clock wrap, steps {result['min_step_ms']}.."
          f"{result['max_step_ms']} ms (5 ms nominal), samples lost {missing}")
    return result


def kill9(work: Path, trials: int) -> dict[str, Any]:
    results = faultkit.kill9_trials(work / "kill9", trials, seed=2026, parallel=3, max_after_s=4.0)
    lost = [r.lost_s for r in results]
    out = {"trials": trials, "ok": sum(r.ok for r in results), "recovered": sum(r.recovered for r in results),
           "max_lost_s": max(lost), "mean_lost_s": float(np.mean(lost)),
           "max_lost_samples": round(max(lost) * faultkit.RATE_HZ), "holes": sum(r.holes for r in results),
           "moments_s": [r.kill_after_s for r in results]}
    print(f"  kill -9: {out['ok']}/{trials} trials within 0.5 s and recovered ({out['recovered']} recovered); "
          f"lost max {out['max_lost_s']:.3f} s = {out['max_lost_samples']} samples at {faultkit.RATE_HZ} Hz, "
          f"mean {out['mean_lost_s']:.3f} s; holes {out['holes']}")
    return out


def _try_load(path: Path, tally: Counter[str]) -> None:
    from ident.errors import IdentError
    from ident.io import load

    try:
        load(path)
        tally["loaded"] += 1
    except IdentError:
        tally["refused (IdentError)"] += 1
    except Exception as exc:  # noqa: BLE001 - counted: this is what the benchmark measures
        tally[f"leaked {type(exc).__module__}.{type(exc).__name__}"] += 1


def bad_inputs(work: Path) -> dict[str, Any]:
    rng = random.Random(1)
    files: Counter[str] = Counter()
    _runs, _ = sf.run_service(SIM_1KHZ.replace("rate_hz=1000", "rate_hz=100"), work / "bad")
    run_file = sorted((work / "bad").glob("*.mcap"))[0]
    data = run_file.read_bytes()
    target = work / "bad" / "x.mcap"
    for i in range(60):                                   # truncations
        target.write_bytes(data[: int(len(data) * i / 60)])
        _try_load(target, files)
    for _ in range(100):                                  # byte flips
        flipped = bytearray(data)
        for _ in range(rng.randint(1, 8)):
            flipped[rng.randrange(len(flipped))] = rng.randrange(256)
        target.write_bytes(bytes(flipped))
        _try_load(target, files)
    for _ in range(40):                                   # random files, every suffix
        path = work / "bad" / f"r{rng.randrange(10**6)}{rng.choice(['.csv', '.tsv', '.mcap', ''])}"
        path.write_bytes(bytes(rng.randrange(256) for _ in range(rng.randrange(3000))))
        _try_load(path, files)
    t = np.arange(400) / 100
    good = [f"{a:.4f},{0.15 * (1 - np.exp(-0.4 * max(a - 1, 0)) * np.cos(8 * max(a - 1, 0))):.7f}" for a in t]
    csv_cases = {"nan": ("2.0000,nan", 200), "inf": ("2.0000,inf", 200), "text": ("2.0000,abc", 200),
                 "overflow": ("2.0000,1e999", 200), "duplicate": (good[100], 101), "decreasing": (good[50], 101),
                 "missing": ("2.0000,", 200)}
    for name, (row, at) in csv_cases.items():
        rows = list(good)
        rows[at] = row
        path = work / "bad" / f"{name}.csv"
        path.write_text("time_s,pos1_m\n" + "\n".join(rows) + "\n")
        _try_load(path, files)
    for name, rows in {"one_sample": good[:1], "flat": [f"{a:.4f},0" for a in t],
                       "huge": [r.split(",")[0] + ",1e11" for r in good]}.items():
        path = work / "bad" / f"{name}.csv"
        path.write_text("time_s,pos1_m\n" + "\n".join(rows) + "\n")
        _try_load(path, files)
    messages = _bad_messages(rng)
    print(f"  bad files tried {sum(files.values())}: " + ", ".join(f"{k} {v}" for k, v in sorted(files.items())))
    tried = ", ".join(f"{k} {v}" for k, v in sorted(messages.items()))
    print(f"  bad messages tried {sum(messages.values())}: {tried}")
    return {"files": dict(files), "messages": dict(messages)}


def _bad_messages(rng: random.Random) -> Counter[str]:
    import importlib
    import inspect
    import pkgutil

    import schemas
    from schemas import Record, SchemaError

    records = []
    for info in pkgutil.iter_modules(schemas.__path__):
        module = importlib.import_module(f"schemas.{info.name}")
        records += [o for o in vars(module).values()
                    if inspect.isclass(o) and issubclass(o, Record) and o is not Record]
    tally: Counter[str] = Counter()
    payloads = [b"", b"{", b"null", b"[]", b"\xff\xfe", b'{"schema_version": 2}', b"x" * (4 * 1024 * 1024 + 1),
                b'{"bench": "..", "run_id": "/etc/passwd"}']
    payloads += [bytes(rng.randrange(256) for _ in range(rng.randrange(200))) for _ in range(50)]
    for model in set(records):
        for payload in payloads:
            try:
                model.from_json_bytes(payload)
                tally["accepted"] += 1
            except SchemaError:
                tally["refused (SchemaError)"] += 1
            except Exception as exc:  # noqa: BLE001 - counted
                tally[f"leaked {type(exc).__name__}"] += 1
    return tally


def _rss_kb(pid: int) -> int | None:
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    except OSError:
        return None
    return None


class LiveCount:
    """Samples and discontinuities (steps other than 1 ms) seen by the live subscriber."""

    def __init__(self) -> None:
        self.samples = 0
        self.gaps = 0
        self.first_t_ns: int | None = None
        self._last: int | None = None

    def drain(self, batches: queue.SimpleQueue[bytes], until: float) -> None:
        from schemas.daq import SampleBatch

        while True:
            try:
                payload = batches.get(timeout=max(0.0, until - time.monotonic()))
            except queue.Empty:
                return
            t_ns = SampleBatch.from_json_bytes(payload).t_ns
            if t_ns:
                if self._last is not None and t_ns[0] - self._last != 1_000_000:
                    self.gaps += 1
                if self.first_t_ns is None:
                    self.first_t_ns = t_ns[0]
                self._last = t_ns[-1]
                self.samples += len(t_ns)


def soak(work: Path, duration_s: float) -> dict[str, Any]:
    import zenoh

    from daq.run_file import load_run
    from schemas import keys
    from schemas.bus import BusConfig

    endpoint = ports.endpoint()
    runs_dir = work / "soak"
    url = SOAK_SIM.format(duration=duration_s)
    proc = faultkit.daq_process(["run", "--port", url, "--bench", "soak", "--runs-dir", str(runs_dir),
                                 "--listen", endpoint, "--until-eof"], work / "soak.log")
    batches: queue.SimpleQueue[bytes] = queue.SimpleQueue()
    live = LiveCount()
    rss: list[tuple[float, int]] = []
    started = time.monotonic()
    session = zenoh.open(zenoh.Config.from_json5(BusConfig.connector(endpoint).zenoh_json5()))
    try:
        sub = session.declare_subscriber(keys.samples("soak"), lambda s: batches.put(s.payload.to_bytes()))
        while proc.poll() is None:
            value = _rss_kb(proc.pid)
            if value is not None:
                rss.append((time.monotonic() - started, value))
            live.drain(batches, time.monotonic() + 1.0)
        sub.undeclare()
        live.drain(batches, time.monotonic())
    finally:
        session.close()
        if proc.poll() is None:
            proc.kill()
    wall = time.monotonic() - started
    files = sorted(runs_dir.glob("*.mcap"))
    samples = holes = missing = 0
    totals: Counter[str] = Counter()
    for path in files:
        run = load_run(path)
        steps = np.diff(run.t_ns)
        samples += run.t_ns.size
        bad = steps != 1_000_000
        holes += int(np.count_nonzero(bad))
        missing += int(np.sum(np.round(steps[bad] / 1_000_000) - 1)) if bad.any() else 0
        if run.metadata is not None:   # counters of a run file are those of its own span
            c = run.metadata.counters
            totals.update(lines=c.lines, seq_gaps=c.seq_gaps, lost_frames=c.lost_frames, bad_lines=c.bad_lines)
    warm = [v for t, v in rss if t >= 5.0] or [v for _, v in rss]
    out = {"simulated_s": duration_s, "wall_s": round(wall, 1), "speedup": round(duration_s / wall, 1),
           "exit_code": proc.returncode, "runs": len(files), "samples_in_runs": samples,
           "samples_missing_in_runs": missing, "holes_in_runs": holes,
           "seq_gaps_in_runs": totals["seq_gaps"], "lost_frames_in_runs": totals["lost_frames"],
           "bad_lines_in_runs": totals["bad_lines"], "lines_in_runs": totals["lines"],
           "lines_emitted": int(duration_s * 1000) + 1,
           "live_samples_received": live.samples, "live_gaps": live.gaps,
           "live_samples_after_join": int(duration_s * 1000) + 1 - (live.first_t_ns or 0) // 1_000_000,
           "rss_start_mb": round(warm[0] / 1024, 1) if warm else None,
           "rss_end_mb": round(warm[-1] / 1024, 1) if warm else None,
           "rss_max_mb": round(max(warm) / 1024, 1) if warm else None}
    print(f"  soak {duration_s:.0f} s simulated at 1 kHz x 2 encoders in {wall:.0f} s wall ({out['speedup']}x), "
          f"exit {proc.returncode}: {len(files)} runs, {samples} samples in runs, missing {missing}, "
          f"seq gaps {totals['seq_gaps']}, lost frames {totals['lost_frames']}, bad lines {totals['bad_lines']}; "
          f"RSS {out['rss_start_mb']} MB (at 5 s) -> {out['rss_end_mb']} MB (end), max {out['rss_max_mb']} MB; "
          f"live: {live.samples} samples received of {out['live_samples_after_join']} emitted after the subscriber "
          f"joined, {live.gaps} gaps "
          "(the live view may drop: CongestionControl.DROP)")
    return out


def issue14(csv_mb: float, load_repeat: int, load_tests: tuple[str, ...], json_path: Path | None) -> int:
    from dataclasses import asdict

    from testkit import fault_rows

    logging.basicConfig(level=logging.ERROR)
    with tempfile.TemporaryDirectory(prefix="bench_faults14_") as tmp:
        rows = fault_rows.all_rows(Path(tmp), csv_mb, load_repeat, load_tests)
    section("issue 14: every row")
    fault_rows.print_table(rows)
    bad = [r.fault for r in rows if not r.ok]
    print(f"\n{len(rows) - len(bad)}/{len(rows)} rows at target (0 data lost, 0 crashes, 0 double fits, "
          f"0 unfitted){': not ' + ', '.join(bad) if bad else ''}")
    if json_path is not None:
        json_path.write_text(json.dumps([asdict(r) for r in rows], indent=2))
    return 0 if not bad else 1


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--kill-trials", type=int, default=20)
    parser.add_argument("--soak-s", type=float, default=3600.0, help="simulated seconds of the soak")
    parser.add_argument("--skip-soak", action="store_true")
    parser.add_argument("--json", type=Path, default=None, help="write every figure to this file")
    parser.add_argument("--issue14", action="store_true", help="only the rows of issue 14, as a table")
    parser.add_argument("--csv-mb", type=float, default=224.0, help="size of the CSV of row 8 (MB)")
    parser.add_argument("--load-repeat", type=int, default=3, help="runs of the tests under load (row 10)")
    parser.add_argument("--load-tests", nargs="+", default=None,
                        help="test files row 10 runs under load ('all': the whole suite; default: "
                             "the worker and browser tests, testkit.fault_rows_resources.LOAD_TESTS)")
    args = parser.parse_args(argv)
    if args.issue14:
        from testkit.fault_rows_resources import LOAD_TESTS

        return issue14(args.csv_mb, args.load_repeat, tuple(args.load_tests or LOAD_TESTS), args.json)
    logging.getLogger("daq").setLevel(logging.ERROR)   # the faults below are expected: no warning per fault
    figures: dict[str, Any] = {}
    with tempfile.TemporaryDirectory(prefix="bench_faults_") as tmp:
        work = Path(tmp)
        section("1. serial corruption (1 kHz, two encoders, replay://)")
        figures["corruption"] = corruption(work)
        section("2. unplug/replug during a run")
        figures["unplug"] = unplug(work)
        section("3. device clock and sequence wrap mid-run")
        figures["wraps"] = wraps(work)
        section(f"4. kill -9 of daq mid-run ({args.kill_trials} trials)")
        figures["kill9"] = kill9(work, args.kill_trials)
        section("5. bad input to ident and to the schemas records")
        figures["bad_input"] = bad_inputs(work)
        if not args.skip_soak:
            section(f"6. soak: {args.soak_s:.0f} s simulated through daq run + Zenoh")
            figures["soak"] = soak(work, args.soak_s)
    if args.json is not None:
        args.json.write_text(json.dumps(figures, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
