"""Run issue-10 red-team records through `daq run` (ECP replay) and `ident releases` and score them.

    .venv/bin/python tools/redteam/run10.py --records 20 [--first-seed 0] [--seed S] [--handling N] [--out DIR] [-v]

Each record is written twice: the Teensy's ECP stream (`cart1pos:cart2pos:target:duty:time_ms`)
streamed by `daq run --port 'replay://FILE?speed=max' --dialect ecp --until-eof --no-zenoh`,
and a CSV (`time_s,pos1_m,pos2_m`) given to `ident releases FILE --json`. A simulated release
is found when a run's (or a listed) release lies within 0.3 s of it; anything else is a false
run. Handling-only records (`--handling N`, 60 s each) must give no run at all.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from cases10 import RATES, Record, csv_text, ecp_lines, make_record, tsv_text
from output import publish

REPO = Path(__file__).resolve().parents[2]
MATCH_S = 0.3
FORMATS = ("csv", "tsv", "mcap")  # what `ident releases` is given: our CSV, the ECP lab export, daq's runs
TSV_ARGS = ["--time", "Time", "--pos", "Encoder 1 Pos", "Encoder 2 Pos", "--scale", repr(1 / 56000.0)]
# per-release tags the summary breaks the figures down by
TAGS = ("flick", "pull-hold", "back_to_back", "after_motion_start", "cut", "nudge_before", "touch_after")


def _py(code: str, args: list[str]) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", PYTHONPATH=str(REPO))
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, env=env,
                          timeout=900)


DAQ = "import sys; from daq.cli import main; sys.argv[0] = 'daq'; sys.exit(main())"
IDENT = "import sys; from ident.cli import main; sys.argv[0] = 'ident'; sys.exit(main())"


def daq_releases(ecp: Path, runs: Path) -> tuple[list[dict[str, Any]], str]:
    proc = _py(DAQ, ["run", "--port", f"replay://{ecp}?speed=max", "--dialect", "ecp", "--until-eof",
                     "--no-zenoh", "--runs-dir", str(runs)])
    if proc.returncode != 0:
        return [], (proc.stderr.strip().splitlines() or [f"exit {proc.returncode}"])[-1]
    out = []
    for f in sorted(runs.glob("*.mcap")):
        info = _py(DAQ, ["info", str(f), "--json"])
        meta = json.loads(info.stdout)["metadata"]
        out.append({"t": meta["release_t_ns"] / 1e9, "pulled_cart": meta.get("pulled_cart"),
                    "moving_carts": meta.get("moving_carts"), "lab_case": meta.get("lab_case"),
                    "file": f, "first_s": meta["first_t_ns"] / 1e9})
    return out, ""


def ident_releases(path: Path, extra: list[str] | None = None, t0: float = 0.0) -> tuple[list[dict[str, Any]], str]:
    """`ident releases PATH --json [extra]`; times shifted by `t0` (a run file's first sample)."""
    proc = _py(IDENT, ["releases", str(path), "--json", *(extra or [])])
    if proc.returncode != 0:
        return [], (proc.stderr.strip().splitlines() or [f"exit {proc.returncode}"])[-1]
    return [{"t": r["release_time_s"] + t0, "pulled_cart": r["pulled_cart"], "moving_carts": r["moving_carts"],
             "complete": r["complete"]} for r in json.loads(proc.stdout)], ""


def mcap_releases(runs: list[dict[str, Any]]) -> tuple[list[dict[str, Any]], str]:
    """`ident releases` on every run file daq wrote, on the device's time base."""
    found, errs = [], []
    for run in runs:
        rel, err = ident_releases(run["file"], t0=run["first_s"])
        found += rel
        if err:
            errs.append(f"{run['file'].name}: {err}")
    return found, "; ".join(errs)


def diagnose_all(csv: Path) -> tuple[list[dict[str, Any]], str]:
    """`ident diagnose FILE --all --json`: per release, dry friction named and the gain."""
    proc = _py(IDENT, ["diagnose", str(csv), "--all", "--json", "-q"])
    if proc.returncode != 0:
        return [], (proc.stderr.strip().splitlines() or [f"exit {proc.returncode}"])[-1]
    reps = json.loads(proc.stdout)
    return [{"t": r["release_time_s"], "effects": [e["effect"] for e in r["effects"]], "cause": r["cause"],
             "gain": r["gain_points"], "fit": r["extended"]["fit_percent"], "carts": r["carts"]} for r in reps], ""


def score_diagnose(rec: Record, reps: list[dict[str, Any]], err: str) -> dict[str, Any]:
    res: dict[str, Any] = {"complete": 0, "friction": 0, "problems": [f"ident diagnose failed: {err}"] if err else []}
    for i, r in enumerate(rec.releases):
        if r.get("cut"):
            continue
        res["complete"] += 1
        near = [d for d in reps if abs(d["t"] - r["t_r"]) <= MATCH_S]
        if near and "coulomb_friction" in near[0]["effects"] and near[0]["gain"] > 0:
            res["friction"] += 1
        else:
            res["problems"].append(f"ident diagnose --all: release {i + 1} (t={r['t_r']:.3f} s) "
                                   + (f"effects {near[0]['effects']}, gain {near[0]['gain']:.2f}" if near
                                      else "no report near it"))
    return res


def sample_period(rec: Record, t: float) -> float:
    """The sample step at t (the ECP clock is irregular: the step around the instant)."""
    i = int(np.clip(np.searchsorted(rec.t, t), 1, len(rec.t) - 1))
    return float(rec.t[i] - rec.t[i - 1])


def _tags(rec: Record, i: int) -> list[str]:
    r = rec.releases[i]
    tags = [r["kind"]] + [k for k in ("back_to_back", "after_motion_start", "nudge_before", "touch_after") if r.get(k)]
    return tags + (["cut"] if r.get("cut_truth") else [])


def match(rec: Record, found: list[dict[str, Any]], who: str) -> dict[str, Any]:
    res: dict[str, Any] = {"found": 0, "one_sample": 0, "ms20": 0, "false": 0, "carts_ok": 0,
                           "errors_ms": [], "problems": [], "per_release": []}
    used = set()
    pulled = rec.info["pulled_cart"]
    for i, r in enumerate(rec.releases):
        cands = [(abs(f["t"] - r["t_r"]), j) for j, f in enumerate(found) if j not in used]
        best = min(cands) if cands else (np.inf, -1)
        outcome = {"tags": _tags(rec, i), "found": False, "one_sample": False}
        res["per_release"].append(outcome)
        if best[0] > MATCH_S:
            res["problems"].append(f"{who}: release {i + 1} ({r['kind']}, t={r['t_r']:.3f} s, jump "
                                   f"{r['accel_jump_m_s2']:.1f} m/s²) not found")
            continue
        used.add(best[1])
        f = found[best[1]]
        err = f["t"] - r["t_r"]
        ts = sample_period(rec, r["t_r"])
        outcome.update(found=True, one_sample=bool(abs(err) <= ts))
        res["found"] += 1
        res["errors_ms"].append(err * 1e3)
        res["one_sample"] += abs(err) <= ts
        res["ms20"] += abs(err) <= 0.020
        carts_ok = f["pulled_cart"] == pulled and list(f["moving_carts"] or []) == [pulled]
        if "lab_case" in f:  # daq: lab_case names the pulled cart, the other held (docs/daq.md)
            carts_ok = carts_ok and f["lab_case"] == f"cart{pulled}"
        res["carts_ok"] += carts_ok
        if abs(err) > ts:
            res["problems"].append(f"{who}: release {i + 1} ({r['kind']}, jump {r['accel_jump_m_s2']:.1f} m/s²) "
                                   f"at {f['t']:.4f} s, truth {r['t_r']:.4f} s ({err * 1e3:+.1f} ms, "
                                   f"sample {ts * 1e3:.1f} ms)")
        if not carts_ok:
            res["problems"].append(f"{who}: release {i + 1}: pulled {f['pulled_cart']}, moving "
                                   f"{f['moving_carts']}, lab_case {f.get('lab_case', '-')}; truth cart {pulled} "
                                   f"pulled, the other held")
        _complete_check(rec, i, f, who, res)
    for j, f in enumerate(found):
        if j not in used:
            res["false"] += 1
            res["problems"].append(f"{who}: false release at {f['t']:.3f} s")
    return res


def _complete_check(rec: Record, i: int, f: dict[str, Any], who: str, res: dict[str, Any]) -> None:
    """`ident releases`' `complete` against the truth: only the last release may be cut."""
    if "complete" not in f or "(mcap)" in who:  # a run file ends where daq ended the run
        return
    last = i == len(rec.releases) - 1
    cut = rec.releases[i].get("cut_truth") if last else False
    if cut is None:
        return
    res.setdefault("complete_judged", 0)
    res["complete_judged"] = res["complete_judged"] + 1
    if bool(f["complete"]) == (not cut):
        res["complete_ok"] = res.get("complete_ok", 0) + 1
    else:
        res["problems"].append(f"{who}: release {i + 1} complete={f['complete']}, truth "
                               f"{'cut by the end of the record' if cut else 'complete'}")


def run_record(seed: int, handling: bool, tmp: Path, diagnose: bool = False, rate: str | None = None,
               formats: tuple[str, ...] = ("csv",)) -> dict[str, Any]:
    """One record: daq on its ECP stream, `ident releases` on each of `formats` (csv, tsv, mcap)."""
    rec = make_record(seed, handling=handling, rate=rate)
    stem = tmp / f"rec{'h' if handling else ''}{seed}{'_' + rate if rate else ''}"
    ecp, csv, tsv = stem.with_suffix(".ecp"), stem.with_suffix(".csv"), stem.with_suffix(".tsv")
    ecp.write_text(ecp_lines(rec))
    csv.write_text(csv_text(rec))
    runs = tmp / f"runs_{stem.name}"
    d, derr = daq_releases(ecp, runs)
    flag = " --handling-only" if handling else (" --diagnose" if diagnose else "")
    flag += f" --rate {rate}" if rate else ""
    flag += "".join(f" --format {f}" for f in formats if f != "csv")
    out = {"seed": seed, "handling": handling, "rate": rec.info["rate"], "n": len(rec.releases),
           "events": rec.info["events"], "kinds": [r["kind"] for r in rec.releases],
           "daq": match(rec, d, "daq"), "repro": f".venv/bin/python tools/redteam/run10.py --seed {seed}{flag} -v"}
    if derr:
        out["daq"]["problems"].insert(0, f"daq failed: {derr}")
    for fmt in formats:
        if fmt == "csv":
            found, err = ident_releases(csv)
        elif fmt == "tsv":
            tsv.write_text(tsv_text(rec))
            found, err = ident_releases(tsv, TSV_ARGS)
        else:
            found, err = mcap_releases(d)
        key = "ident" if fmt == "csv" else f"ident_{fmt}"
        out[key] = match(rec, found, f"ident releases ({fmt})")
        if err:
            out[key]["problems"].insert(0, f"ident releases ({fmt}) failed: {err}")
    if diagnose and not handling:
        out["diagnose"] = score_diagnose(rec, *diagnose_all(csv))
        out["ident"]["problems"] += out["diagnose"]["problems"]
    return out


def _tools(results: list[dict[str, Any]]) -> list[str]:
    return [k for k in ("daq", "ident", "ident_tsv", "ident_mcap") if any(k in r for r in results)]


def _rate_table(results: list[dict[str, Any]]) -> list[str]:
    lines = ["| tool | rate | records | releases | found | ≤ 1 sample | ≤ 20 ms | pulled+held right | false runs |",
             "|---|---|---|---|---|---|---|---|---|"]
    for who in _tools(results):
        for rate in ("50", "100", "200", "1000", "ecp", "all"):
            rs = [r for r in results if not r["handling"] and who in r and (rate == "all" or r["rate"] == rate)]
            if not rs:
                continue
            n = sum(r["n"] for r in rs)
            s = {k: sum(r[who][k] for r in rs) for k in ("found", "one_sample", "ms20", "carts_ok", "false")}
            lines.append(f"| {who} | {rate} | {len(rs)} | {n} | {s['found']} | {s['one_sample']} | {s['ms20']} | "
                         f"{s['carts_ok']} | {s['false']} |")
    return lines


def _tag_table(results: list[dict[str, Any]]) -> list[str]:
    """Found / within one sample per kind of release (a release may carry several tags)."""
    tools = _tools(results)
    lines = ["", "| release | n | " + " | ".join(f"{w} found, ≤1 sample" for w in tools) + " |",
             "|---|---|" + "---|" * len(tools)]
    for tag in TAGS:
        cells, n = [], 0
        for who in tools:
            outs = [o for r in results if who in r for o in r[who]["per_release"] if tag in o["tags"]]
            n = max(n, len(outs))
            cells.append(f"{sum(o['found'] for o in outs)}, {sum(o['one_sample'] for o in outs)}")
        if n:
            lines.append(f"| {tag} | {n} | " + " | ".join(cells) + " |")
    judged = sum(r["ident"].get("complete_judged", 0) for r in results if "ident" in r)
    if judged:
        ok = sum(r["ident"].get("complete_ok", 0) for r in results if "ident" in r)
        lines.append(f"\n`ident releases` (csv) `complete` right on {ok}/{judged} judged releases")
    return lines


def summarize(results: list[dict[str, Any]]) -> str:
    lines = _rate_table(results) + _tag_table(results)
    hs = [r for r in results if r["handling"]]
    if hs:
        lines.append("")
        lines.append(f"Handling only ({len(hs)} records of 60 s): daq false runs "
                     f"{sum(r['daq']['false'] for r in hs)}, ident releases false "
                     f"{sum(r['ident']['false'] for r in hs)}")
    ds = [r["diagnose"] for r in results if "diagnose" in r]
    if ds:
        lines.append(f"ident diagnose --all (no --carts): complete releases with coulomb_friction and a positive "
                     f"gain {sum(d['friction'] for d in ds)}/{sum(d['complete'] for d in ds)}")
    for who in _tools(results):
        errs = [e for r in results if who in r for e in r[who]["errors_ms"]]
        if errs:
            lines.append(f"{who} instant error (found releases): median {np.median(errs):+.1f} ms, "
                         f"95th pct |err| {np.percentile(np.abs(errs), 95):.1f} ms")
    lines.append("")
    lines.append("Failures (reproduction, then what went wrong):")
    for r in results:
        probs = [p for who in _tools(results) if who in r for p in r[who]["problems"]]
        if probs:
            lines.append(f"- `{r['repro']}` [{r['rate']}, {r['n']} releases {r['kinds']}; {r['events']}]: "
                         + "; ".join(probs))
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--records", type=int, default=10)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--seed", type=int, help="only this record")
    ap.add_argument("--handling-only", action="store_true", help="with --seed: the handling record")
    ap.add_argument("--handling", type=int, default=0, help="handling-only records (60 s each)")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--out", type=Path)
    ap.add_argument("--keep", type=Path, help="keep the written records here")
    ap.add_argument("--diagnose", action="store_true", help="also `ident diagnose --all` every record")
    ap.add_argument("--rate", choices=RATES, help="every record at this rate (the other draws unchanged)")
    ap.add_argument("--format", action="append", choices=FORMATS[1:], default=[],
                    help="also give `ident releases` the record as this (tsv: the ECP export; mcap: daq's runs)")
    ap.add_argument("-v", "--verbose", action="store_true")
    args = ap.parse_args(argv)
    if args.seed is not None:
        jobs = [(args.seed, args.handling_only)]
    else:
        jobs = [(s, False) for s in range(args.first_seed, args.first_seed + args.records)]
        jobs += [(s, True) for s in range(args.first_seed, args.first_seed + args.handling)]
    with tempfile.TemporaryDirectory() as tmpd, ThreadPoolExecutor(args.jobs) as pool:
        tmp = args.keep or Path(tmpd)
        tmp.mkdir(parents=True, exist_ok=True)
        results = []
        for res in pool.map(lambda j: run_record(j[0], j[1], tmp, args.diagnose, args.rate,
                                                 ("csv", *args.format)), jobs):
            results.append(res)
            bad = [p for who in _tools([res]) for p in res[who]["problems"]]
            print(f"record {res['seed']}{' (handling)' if res['handling'] else ''}: "
                  f"{'ok' if not bad else 'FAIL'}", file=sys.stderr)
            if args.verbose:
                print(json.dumps(res, indent=1, default=float))
    publish(results, summarize(results), args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
