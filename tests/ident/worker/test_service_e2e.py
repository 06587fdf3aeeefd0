"""End to end in separate processes: `sim://` rig -> `daq run` -> Zenoh -> `ident worker` ->
a fit report received here, for the three lab cases; and two benches with two workers
behind a Zenoh router (started here in router mode), every run fitted exactly once.

The simulated rig uses its default carts (m1 0.85 kg, m2 0.75 kg, k1 60, k2 45, k3 50 N/m)
with dry friction; the expected frequencies below are computed from those defaults, the
worker never sees them.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from ident.worker.runs_dir import REPORT_NAME
from schemas.fit import FitReport
from testkit.benchkit import Bench, sim_url
from testkit.waiting import wait_until

pytestmark = pytest.mark.timeout(150)

M1, M2, K1, K2, K3 = 0.85, 0.75, 60.0, 45.0, 50.0
WN_CART1_PINNED2 = math.sqrt((K1 + K2) / M1)   # cart 2 pinned: cart 1 sees k1 + k2
WN_CART2_PINNED1 = math.sqrt((K2 + K3) / M2)


def _by_run(bench: Bench) -> dict[tuple[str, str], list[FitReport]]:
    return bench.watcher.final_reports()


def test_three_lab_cases_end_to_end(tmp_path: Path) -> None:
    runs = tmp_path / "runs"
    with Bench(tmp_path / "bench") as bench:
        bench.start_worker("w1", runs)
        bench.wait_workers({"w1"})
        bench.start_daq("daq", sim_url(["cart1", "cart2", "both"]), "bench1", runs)
        wait_until(lambda: len(_by_run(bench)) >= 3, 90, "three fit reports", bench.procs)
        finals = _by_run(bench)
        results = bench.watcher.first_results()
        finished = dict(bench.watcher.finished)
    assert len(finals) == 3 and all(len(v) == 1 for v in finals.values())
    for key, reports in results.items():       # early results, then the complete report, once
        assert [bool(r.pending) for r in reports] == [True, False], reports
        assert reports[0].pem == finals[key][0].pem
    reports = [finals[key][0] for key in sorted(finals)]     # run ids sort in start order
    assert [r.case for r in reports] == ["cart1", "cart2", "both"]
    assert all(r.status == "ok" and r.worker == "w1" for r in reports)
    assert [r.pem.order if r.pem else None for r in reports] == [2, 2, 4]
    assert [r.pem.outputs if r.pem else None for r in reports] == [[1], [2], [1, 2]]
    for report in reports:
        assert report.pem is not None and min(report.pem.fit_percent) > 80.0
        daq_release = finished[(report.bench, report.run_id)].release_time_s
        assert daq_release is not None and report.release_time_s is not None
        assert abs(report.release_time_s - daq_release) < 0.01
        fit_dir = runs / f"{report.run_id}.fit"
        assert FitReport.from_json_bytes((fit_dir / REPORT_NAME).read_bytes()) == report
        assert report.figures and all((fit_dir / name).stat().st_size > 1000
                                      for name in report.figures)
        assert {n.split(".")[0] for n in report.figures} >= {"pem", "diagnosis"}
        assert report.diagnosis is not None and report.diagnosis.cause == "coulomb_friction"
    cart1, cart2, both = reports
    assert cart1.pem and abs(cart1.pem.modes[0].wn_rad_s / WN_CART1_PINNED2 - 1) < 0.02
    assert cart2.pem and abs(cart2.pem.modes[0].wn_rad_s / WN_CART2_PINNED1 - 1) < 0.02
    assert both.pem and len(both.pem.tfs) == 2 and len(both.pem.tfs[0].den) == 5


def test_two_benches_two_workers_behind_a_router(tmp_path: Path) -> None:
    """Workers have their own (empty) runs directories: they fetch every run over Zenoh.

    Exactly once is judged on the first results of each run (the early report with the
    transfer functions): one report from one worker per run. The diagnosis stage is not
    waited for here (the three-case test above covers it).
    """
    with Bench(tmp_path / "bench", router=True) as bench:
        for name in ("wa", "wb"):
            bench.start_worker(name, tmp_path / f"fits-{name}")
        bench.wait_workers({"wa", "wb"})
        bench.start_daq("daq-a", sim_url(["cart1", "both"], seed=3), "benchA", tmp_path / "runs-a")
        bench.start_daq("daq-b", sim_url(["cart2", "cart1"], seed=4), "benchB", tmp_path / "runs-b")
        wait_until(lambda: len(bench.watcher.first_results()) >= 4, 100, "results of four runs",
                   bench.procs)
        results = bench.watcher.first_results()
        claims = list(bench.watcher.claims)
        finished = dict(bench.watcher.finished)
    assert sorted(results) == sorted(finished) and len(results) == 4
    assert {b for b, _ in results} == {"benchA", "benchB"}
    for key, reports in results.items():
        partial = [r for r in reports if r.pending]
        assert len(partial) == 1 and partial[0].status == "ok", reports     # fitted once
        assert {r.worker for r in reports} == {partial[0].worker}
        mine = [c for c in claims if (c.bench, c.run_id) == key]
        standing = [c.worker for c in mine if c.status == "fitting"]
        for c in mine:                                                  # a lost tie-break
            if c.status == "withdrawn":
                standing.remove(c.worker)
        assert standing == [partial[0].worker], mine                    # one standing claim
    cases = {key: v[0].case for key, v in results.items()}
    assert sorted(c for (b, _), c in cases.items() if b == "benchA") == ["both", "cart1"]
    assert sorted(c for (b, _), c in cases.items() if b == "benchB") == ["cart1", "cart2"]
    assert {v[0].worker for v in results.values()} <= {"wa", "wb"}
    for (b, run_id), reports in results.items():                # fetched by the one that fitted
        worker = reports[0].worker
        other = "wb" if worker == "wa" else "wa"
        assert (tmp_path / f"fits-{worker}" / b / f"{run_id}.mcap").is_file()
        assert not (tmp_path / f"fits-{other}" / b / f"{run_id}.mcap").exists()
