"""Two worker processes on one bus: every run fitted exactly once, also across a kill -9.

Topology: this test process is a Zenoh router (loopback, ephemeral port) that also plays
the daq (announcing runs) and collects fit messages; workers are separate processes
connected as clients. The fitter is a logging plug-in (tests/.../plugins/fake_fitters.py),
so these tests are about scheduling, not numerics.
"""

from __future__ import annotations

import json
import signal
from pathlib import Path

import pytest
import zenoh

from ident.worker.schedule import RunRef, owner
from schemas.bus import BusConfig
from testkit import ports
from testkit.waiting import wait_until
from testkit.worker_harness import (
    STARTUP_S,
    FakeDaq,
    FitCollector,
    Router,
    alive_workers,
    client_args,
    fit_log_counts,
    record_sim_run,
    start_worker,
    stop,
)

#: each test waits up to STARTUP_S for its workers, then up to about a minute for what it is about
pytestmark = pytest.mark.timeout(STARTUP_S + 90)


def test_two_workers_fit_each_run_exactly_once(router: Router, tmp_path: Path) -> None:
    endpoint, session = router
    runs_dir = tmp_path / "runs"
    runs_dir.mkdir()
    env = {"FAKE_FIT_LOG": str(tmp_path / "fits.log")}
    daq = FakeDaq(session, "bench1", runs_dir)
    collector = FitCollector(session)
    early = [daq.announce(f"r{i:02d}") for i in range(4)]     # before any worker runs
    workers = [start_worker(n, client_args(endpoint), runs_dir, tmp_path, "testkit.fake_fitters:instant_fit", env)
               for n in ("wa", "wb")]
    try:
        wait_until(lambda: alive_workers(session) == {"wa", "wb"}, STARTUP_S, "both workers alive", workers)
        late = [daq.announce(f"r{i:02d}") for i in range(4, 12)]
        finals = collector.wait_finals(early + late, timeout_s=30)
    finally:
        codes = [stop(w) for w in workers]
    assert codes == [0, 0]
    done = fit_log_counts(tmp_path / "fits.log")["done"]
    assert sorted(done) == sorted(str(r) for r in early + late)
    assert all(len(ws) == 1 for ws in done.values()), done
    assert all(len(reports) == 1 and reports[0].status == "ok" for reports in finals.values())
    fitters = {ws[0] for ws in done.values()}
    assert fitters == {"wa", "wb"}                    # the work was shared
    for run, reports in finals.items():               # the report names the worker that fitted
        assert [reports[0].worker] == done[str(run)]
        assert (runs_dir / f"{run.run_id}.fit" / "report.json").is_file()


def test_kill_9_mid_fit_the_other_worker_takes_over(router: Router, tmp_path: Path) -> None:
    endpoint, session = router
    runs_dir = tmp_path / "runs"
    runs_dir.mkdir()
    log, gate = tmp_path / "fits.log", tmp_path / "gate"
    env = {"FAKE_FIT_LOG": str(log), "FAKE_FIT_GATE": str(gate)}
    daq = FakeDaq(session, "bench1", runs_dir)
    collector = FitCollector(session)
    workers = {n: start_worker(n, client_args(endpoint), runs_dir, tmp_path, "testkit.fake_fitters:gated_fit", env)
               for n in ("wa", "wb")}
    try:
        wait_until(lambda: alive_workers(session) == {"wa", "wb"}, STARTUP_S, "both workers alive", workers.values())
        runs = [daq.announce(f"r{i:02d}") for i in range(8)]
        wait_until(lambda: len(fit_log_counts(log)["start"]) == 2, 20, "each worker mid-fit", workers.values())
        started = fit_log_counts(log)["start"]
        victim_run = next(run for run, ws in started.items() if ws == ["wa"])
        workers["wa"].send_signal(signal.SIGKILL)
        workers["wa"].wait(timeout=10)
        wait_until(lambda: alive_workers(session) == {"wb"}, 20, "the killed worker's token gone", workers["wb"])
        gate.touch()
        finals = collector.wait_finals(runs, timeout_s=40)
    finally:
        gate.touch()
        code_b = stop(workers["wb"])
        stop(workers["wa"])
    assert code_b == 0
    counts = fit_log_counts(log)
    assert sorted(counts["done"]) == sorted(str(r) for r in runs)
    assert all(len(ws) == 1 for ws in counts["done"].values()), counts["done"]
    assert counts["done"][victim_run] == ["wb"]       # taken over, fitted once
    assert all(len(reports) == 1 for reports in finals.values())
    assert {r[0].worker for r in finals.values()} == {"wb"}


def test_a_run_whose_file_cannot_be_had_is_retried_when_its_daq_comes_back(router: Router, tmp_path: Path) -> None:
    endpoint, session = router
    runs_dir = tmp_path / "runs"
    runs_dir.mkdir()
    env = {"FAKE_FIT_LOG": str(tmp_path / "fits.log")}
    daq = FakeDaq(session, "bench1", runs_dir)
    collector = FitCollector(session)
    worker = start_worker("wa", client_args(endpoint), runs_dir, tmp_path, "testkit.fake_fitters:instant_fit", env)
    try:
        missing = daq.announce("gone", content=None)   # no file, and no `run` queryable answers
        good = daq.announce("fine")
        wait_until(lambda: "wa" in alive_workers(session), STARTUP_S, "the worker alive", worker)
        finals = collector.wait_finals([good], timeout_s=30)
        def withdrawn() -> bool:
            collector.drain()
            return any(r.run_id == "gone" and r.status == "withdrawn" for r in collector.messages)

        wait_until(withdrawn, 30, "the unavailable run withdrawn", worker)
        assert missing not in collector.finals()        # transient: not failed for good
        daq.come_back({"gone": b"fake-run gone, served by the daq"})
        finals = collector.wait_finals([missing, good], timeout_s=60)
        assert worker.poll() is None
    finally:
        assert stop(worker) == 0
    assert [r.status for r in finals[missing]] == ["ok"] and finals[good][0].status == "ok"
    assert (runs_dir / "bench1" / "gone.mcap").read_bytes().startswith(b"fake-run gone")


def test_real_pipeline_reports_corrupted_and_truncated_runs_and_goes_on(router: Router, tmp_path: Path) -> None:
    endpoint, session = router
    good_bytes = record_sim_run(tmp_path / "recorded")
    runs_dir = tmp_path / "runs"
    runs_dir.mkdir()
    daq = FakeDaq(session, "bench1", runs_dir)
    collector = FitCollector(session)
    worker = start_worker("wa", client_args(endpoint), runs_dir, tmp_path)
    try:
        bad = daq.announce("garbage", content=b"\x89MCAP0\r\n" + bytes(range(256)) * 4)
        cut = daq.announce("truncated", content=good_bytes[:300])
        good = daq.announce("good", content=good_bytes)
        wait_until(lambda: "wa" in alive_workers(session), STARTUP_S, "the worker alive", worker)
        finals = collector.wait_finals([bad, cut], timeout_s=60)
        results = collector.wait_results([good], timeout_s=60)   # not waiting for its diagnosis
        assert worker.poll() is None
    finally:
        assert stop(worker) == 0
    for run in (bad, cut):
        report = finals[run][0]
        assert report.status == "failed" and report.reason, report
        assert "DataFileError" in report.reason and f"{run.run_id}.mcap" in report.reason
        assert (runs_dir / f"{run.run_id}.fit" / "report.json").is_file()
    ok = results[good][0]
    assert ok.status == "ok" and ok.case == "cart1" and ok.pem is not None and ok.pem.order == 2
    assert ok.pending == ["diagnosis", "figures"] and ok.simple


@pytest.mark.timeout(2 * STARTUP_S + 120)   # two workers started one after the other
def test_a_restarted_worker_republishes_stored_fits_without_refitting(router: Router, tmp_path: Path) -> None:
    endpoint, session = router
    runs_dir = tmp_path / "runs"
    runs_dir.mkdir()
    log = tmp_path / "fits.log"
    env = {"FAKE_FIT_LOG": str(log)}
    daq = FakeDaq(session, "bench1", runs_dir)
    runs = [daq.announce(f"r{i}") for i in range(3)]
    first = start_worker("wa", client_args(endpoint), runs_dir, tmp_path, "testkit.fake_fitters:instant_fit", env)
    try:
        wait_until(lambda: "wa" in alive_workers(session), STARTUP_S, "the first worker alive", first)
        FitCollector(session).wait_finals(runs, timeout_s=30)
    finally:
        assert stop(first) == 0
    # The worker's publishers (and their caches) are gone; a new worker and a new listener.
    wait_until(lambda: alive_workers(session) == set(), 20, "the first worker gone")
    late = FitCollector(session)
    second = start_worker("wb", client_args(endpoint), runs_dir, tmp_path, "testkit.fake_fitters:instant_fit", env)
    try:
        wait_until(lambda: "wb" in alive_workers(session), STARTUP_S, "the second worker alive", second)
        finals = late.wait_finals(runs, timeout_s=30)
    finally:
        assert stop(second) == 0
    assert all(len(v) == 1 and v[0].worker == "wa" for v in finals.values())   # stored, not refitted
    assert all(ws == ["wa"] for ws in fit_log_counts(log)["done"].values())


def test_kill_9_during_the_diagnosis_the_other_worker_completes_the_run(router: Router, tmp_path: Path) -> None:
    """The real two-stage pipeline: a worker dies after its early report (transfer functions
    published, diagnosis running); the other one fits the run again and completes it, once."""
    endpoint, session = router
    run_bytes = record_sim_run(tmp_path / "recorded", cases="cart2", seed=11)
    runs_dir = tmp_path / "runs"
    runs_dir.mkdir()
    daq = FakeDaq(session, "bench1", runs_dir)
    collector = FitCollector(session)
    workers = {n: start_worker(n, client_args(endpoint), runs_dir, tmp_path) for n in ("wa", "wb")}
    try:
        wait_until(lambda: alive_workers(session) == {"wa", "wb"}, STARTUP_S, "both workers alive", workers.values())
        runs = [daq.announce("r0", content=run_bytes)]
        early = collector.wait_results(runs, timeout_s=30)[runs[0]][0]
        assert early.pending and not early.final
        victim = early.worker
        workers[victim].send_signal(signal.SIGKILL)
        workers[victim].wait(timeout=10)
        finals = collector.wait_finals(runs, timeout_s=60)
    finally:
        codes = {n: stop(w) for n, w in workers.items()}
    survivor = "wb" if victim == "wa" else "wa"
    assert codes[survivor] == 0
    assert all(len(v) == 1 and v[0].status == "ok" for v in finals.values()), finals
    assert finals[runs[0]][0].worker == survivor                      # taken over
    assert finals[runs[0]][0].diagnosis is not None and finals[runs[0]][0].case == "cart2"
    assert (runs_dir / f"{runs[0].run_id}.fit" / "report.json").is_file()


@pytest.mark.timeout(2 * STARTUP_S + 120)   # two workers started one after the other
def test_a_new_worker_learns_from_a_survivor_what_a_dead_worker_fitted(router: Router, tmp_path: Path) -> None:
    """Separate runs directories (nothing shared on disk): wa and wb fit, wa is killed, then
    wc starts with an empty history of wa's publications and must refit nothing."""
    endpoint, session = router
    dirs = {n: tmp_path / f"runs-{n}" for n in ("wa", "wb", "wc")}
    for d in dirs.values():
        d.mkdir()
    log = tmp_path / "fits.log"
    env = {"FAKE_FIT_LOG": str(log)}
    daqs = [FakeDaq(session, "bench1", d) for d in dirs.values()]   # the same runs, three copies
    # runs wa fits while wa and wb are up, and that wc would own once wa is gone: wc would
    # refit them if it did not learn that they are done
    ids = [f"r{i}" for i in range(400)]
    ids_a = [i for i in ids if owner(RunRef("bench1", i), {"wa", "wb"}) == "wa"
             and owner(RunRef("bench1", i), {"wb", "wc"}) == "wc"][:4]
    ids_b = [i for i in ids if owner(RunRef("bench1", i), {"wa", "wb"}) == "wb"][:4]
    workers = {n: start_worker(n, client_args(endpoint), dirs[n], tmp_path, "testkit.fake_fitters:instant_fit", env)
               for n in ("wa", "wb")}
    try:
        wait_until(lambda: alive_workers(session) == {"wa", "wb"}, STARTUP_S, "wa and wb alive", workers.values())
        runs = []
        for i in ids_a + ids_b:
            copies = [daq.announce(i) for daq in daqs]   # announced to every runs directory
            runs.append(copies[0])
        FitCollector(session).wait_finals(runs, timeout_s=30)
        assert all(fit_log_counts(log)["done"][f"bench1/{i}"] == ["wa"] for i in ids_a)
        workers["wa"].send_signal(signal.SIGKILL)
        workers["wa"].wait(timeout=10)
        wait_until(lambda: alive_workers(session) == {"wb"}, 20, "wa gone", workers["wb"])
        late = FitCollector(session)
        workers["wc"] = start_worker("wc", client_args(endpoint), dirs["wc"], tmp_path,
                                     "testkit.fake_fitters:instant_fit", env)
        wait_until(lambda: alive_workers(session) == {"wb", "wc"}, STARTUP_S, "wc alive",
                   [workers["wb"], workers["wc"]])
        # a new run that wc owns: wc fits pending runs oldest first, so once this one is
        # fitted, wc has had its chance to (wrongly) refit wa's older runs
        new_id = next(f"r-new{i}" for i in range(200)
                      if owner(RunRef("bench1", f"r-new{i}"), {"wb", "wc"}) == "wc")
        for daq in daqs[1:]:
            (daq.runs_dir / f"{new_id}.mcap").write_bytes(b"fake-run")
        extra = daqs[0].announce(new_id)
        assert late.wait_finals([extra], timeout_s=30)[extra][0].worker == "wc"
    finally:
        for proc in workers.values():
            stop(proc)
    done = fit_log_counts(log)["done"]
    assert sorted(done) == sorted([str(r) for r in runs] + [str(extra)])
    assert all(len(ws) == 1 for ws in done.values()), done   # wa's runs were not fitted again


def test_a_second_worker_with_a_name_in_use_refuses_to_start(router: Router, tmp_path: Path) -> None:
    endpoint, session = router
    first = start_worker("wa", client_args(endpoint), tmp_path / "runs", tmp_path, "testkit.fake_fitters:instant_fit")
    try:
        wait_until(lambda: alive_workers(session) == {"wa"}, STARTUP_S, "wa alive", first)
        (tmp_path / "dup").mkdir()
        twin = start_worker("wa", client_args(endpoint), tmp_path / "runs2", tmp_path / "dup",
                            "testkit.fake_fitters:instant_fit")
        assert twin.wait(timeout=STARTUP_S) == 2   # it ends once its session sees wa's token
        assert "expected a name no alive worker uses, got 'wa', already alive" in \
            (tmp_path / "dup" / "wa.log").read_text()
        assert first.poll() is None and alive_workers(session) == {"wa"}
    finally:
        assert stop(first) == 0


LEASE_MS = 3000


def _short_lease_config(path: Path, endpoint: str) -> list[str]:
    """A client config whose lease is short, so a SIGSTOP outlasts it in a few seconds."""
    config = BusConfig(mode="client", listen=[], connect=[endpoint]).zenoh_dict()
    config["transport"]["link"] = {"tx": {"lease": LEASE_MS, "keep_alive": 4}}
    path.write_text(json.dumps(config))
    return ["--zenoh-config", str(path)]


@pytest.mark.timeout(STARTUP_S + 150)
def test_a_worker_paused_past_the_lease_is_fenced_and_every_run_is_reported_once(tmp_path: Path) -> None:
    endpoint = f"tcp/127.0.0.1:{ports.free_port()}"
    router_config = BusConfig(mode="router", listen=[endpoint]).zenoh_dict()
    router_config["transport"]["link"] = {"tx": {"lease": LEASE_MS, "keep_alive": 4}}
    session = zenoh.open(zenoh.Config.from_json5(json.dumps(router_config)))
    runs_dir = tmp_path / "runs"
    runs_dir.mkdir()
    log, gate = tmp_path / "fits.log", tmp_path / "gate"
    env = {"FAKE_FIT_LOG": str(log), "FAKE_FIT_GATE": str(gate)}
    daq = FakeDaq(session, "bench1", runs_dir)
    collector = FitCollector(session)
    workers = {n: start_worker(n, _short_lease_config(tmp_path / f"{n}.json5", endpoint), runs_dir, tmp_path,
                               "testkit.fake_fitters:gated_fit", env) for n in ("wa", "wb")}
    try:
        wait_until(lambda: alive_workers(session) == {"wa", "wb"}, STARTUP_S, "both workers alive", workers.values())
        runs = [daq.announce(f"r{i:02d}") for i in range(8)]
        wait_until(lambda: len(fit_log_counts(log)["start"]) == 2, 30, "each worker mid-fit", workers.values())
        victim_run = next(run for run, ws in fit_log_counts(log)["start"].items() if ws == ["wa"])
        workers["wa"].send_signal(signal.SIGSTOP)       # paused mid-fit, past the lease
        wait_until(lambda: alive_workers(session) == {"wb"}, 30, "the paused worker's token gone", workers.values())
        gate.touch()                                    # wb finishes, takes over the victim's run
        wait_until(lambda: "wb" in fit_log_counts(log)["start"].get(victim_run, []), 40,
                   "the take-over of the paused worker's run", workers.values())
        workers["wa"].send_signal(signal.SIGCONT)       # wa finishes its stale fit: fenced
        wait_until(lambda: "(fenced)" in (tmp_path / "wa.log").read_text(), 40, "wa fenced", workers.values())
        finals = collector.wait_finals(runs, timeout_s=60)
    finally:
        gate.touch()
        workers["wa"].send_signal(signal.SIGCONT)
        codes = [stop(w) for w in workers.values()]
        collector.close()
        session.close()
    assert codes == [0, 0]
    assert all(len(reports) == 1 and reports[0].status == "ok" for reports in finals.values()), finals
    assert finals[RunRef("bench1", victim_run.split("/")[1])][0].worker == "wb"
    published = [r for r in collector.messages if r.final]
    assert len(published) == len(runs)                  # no double fit on the bus
