"""The bench page's pure core: display decimation, the hub's events, run rows, file paths."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from daq.web.files import RunFileError, fit_file_path, list_fit_files, mcap_path
from daq.web.hub import Hub
from daq.web.live import Decimator
from daq.web.runs_view import safe_file_name
from schemas.daq import DaqCounters, DaqStatus, DetectorStateMsg, RunFinished, SampleBatch
from schemas.errors import SchemaError
from schemas.fit import FitReport, ModeRec, PemFitRec, TransferFunctionRec


def batch(first: int, n: int, rate_hz: float, bench: str = "b1", two: bool = True) -> SampleBatch:
    t_ns = [round((first + i) * 1e9 / rate_hz) for i in range(n)]
    p1 = [float(first + i) for i in range(n)]          # position = sample index: easy to check
    p2 = [-float(first + i) for i in range(n)] if two else None
    return SampleBatch(bench=bench, batch_seq=first // max(n, 1), t_ns=t_ns, pos1_m=p1, pos2_m=p2,
                       raw1=p1, raw2=p2)


def test_decimator_keeps_every_kth_sample_across_batch_boundaries() -> None:
    dec = Decimator(display_hz=250.0)
    for first in range(0, 1000, 7):                     # 1 kHz in batches of 7: 7 is not a multiple of 4
        dec.feed(batch(first, 7, 1000.0))
    out = dec.take()
    assert out is not None and dec.stride == 4
    assert out.pos1_m == [float(i) for i in range(0, 1001, 4) if i < 1001][: len(out.pos1_m)]
    assert len(out.pos1_m) == len(range(0, 1001, 4))   # samples 0..1000 (143 batches of 7 = 1001)
    assert out.pos2_m == [-p for p in out.pos1_m]
    assert out.raw_count == 1001 and dec.total_raw == 1001
    assert out.t_s[1] - out.t_s[0] == pytest.approx(0.004)
    assert dec.take() is None


def test_decimator_keeps_everything_below_the_display_rate() -> None:
    dec = Decimator(display_hz=250.0)
    dec.feed(batch(0, 10, 100.0, two=False))
    out = dec.take()
    assert out is not None and out.pos1_m == [float(i) for i in range(10)] and out.pos2_m is None


def status(bench: str, connected: bool = True, state: str = "idle") -> DaqStatus:
    return DaqStatus(bench=bench, state=state, run_id=None, port="/dev/ttyACM0", dialect="cartlab",  # type: ignore[arg-type]
                     connected=connected, counts_per_m=1000.0, zero_offsets_raw=[1.0, 2.0],
                     last_t_ns=5, last_pos_m=[0.0, 0.0], n_runs=0, counters=DaqCounters(),
                     software_version="t")


def finished(bench: str, run_id: str) -> RunFinished:
    return RunFinished(bench=bench, run_id=run_id, status="complete", file=f"{run_id}.mcap",
                       n_samples=1500, release_time_s=0.52, duration_s=7.5)


def pem_report(bench: str, run_id: str, status: str = "ok", reason: str | None = None) -> FitReport:
    tf = TransferFunctionRec(output=1, num=[30.0], den=[1.0, 0.4, 30.0])
    pem = PemFitRec(order=2, tfs=[tf], modes=[ModeRec(wn_rad_s=5.477, zeta=0.0365)],
                    fit_percent=[97.25], outputs=[1])
    return FitReport(bench=bench, run_id=run_id, worker="w1", status=status,  # type: ignore[arg-type]
                     reason=reason, pem=pem if status == "ok" else None, figures=["../x/pem.png", "sim.svg"])


def test_hub_routes_events_per_bench_and_flushes_one_samples_event_per_bench() -> None:
    hub = Hub(display_hz=1000.0)
    hub.on_alive("b1", True)
    hub.on_alive("b2", True)
    for first in range(0, 60, 20):
        hub.on_samples(batch(first, 20, 1000.0, "b1"))
    hub.on_samples(batch(0, 20, 1000.0, "b2"))
    hub.on_state(DetectorStateMsg(bench="b2", state="released", t_ns=3, run_id="r1"))
    events = hub.flush()
    names = [(e.name, e.bench) for e in events]
    assert names.count(("samples", "b1")) == 1 and names.count(("samples", "b2")) == 1
    b1 = next(e for e in events if e.name == "samples" and e.bench == "b1")
    assert b1.data["n_raw"] == 60 and b1.data["pos1_m"] == [float(i) for i in range(60)]
    assert ("state", "b2") in names and ("benches", None) in names
    assert hub.flush() == []
    assert [b["name"] for b in hub.bench_list()] == ["b1", "b2"]


def test_hub_names_problems_a_person_can_act_on() -> None:
    hub = Hub()
    snap = hub.snapshot("b9")
    assert "not running" in snap["status"]["problems"][0] and "b9" not in hub.benches
    hub.on_alive("b1", True)
    hub.on_status("b1", status("b1", connected=False, state="armed"), None)
    events = hub.flush()
    problems = [e.data["problems"] for e in events if e.name == "status"][-1]
    assert problems and "/dev/ttyACM0 is not connected" in problems[0]
    assert hub.snapshot("b1")["state"]["state"] == "armed"   # state taken from the status
    hub.on_alive("b1", False)
    assert "not running" in hub.snapshot("b1")["status"]["problems"][0]


def test_hub_run_rows_join_finished_records_and_fits() -> None:
    hub = Hub(fit_files=lambda run_id: [f"{run_id}-fig.png"])
    hub.on_finished(finished("b1", "r1"))
    hub.on_fit(pem_report("b1", "r1"))
    hub.on_fit(FitReport(bench="b1", run_id="r1", worker="w2", status="fitting"))  # late claim
    hub.on_finished(finished("b1", "r2"))
    hub.on_fit(pem_report("b1", "r2", status="failed", reason="run too short: expected ≥ 2 s, got 0.4 s"))
    rows = {r["run_id"]: r for r in hub.rows("b1")}
    r1 = rows["r1"]
    assert r1["release_time_s"] == 0.52 and r1["file"] == "r1.mcap" and r1["fit_files"] == ["r1-fig.png"]
    assert r1["fit"]["status"] == "ok" and r1["fit"]["pem"]["wn_rad_s"] == [5.477]
    assert r1["fit"]["pem"]["fit_percent"] == [97.25]
    assert r1["fit"]["figures"] == ["pem.png", "sim.svg"]          # only base names are linked
    assert rows["r2"]["fit"]["status"] == "failed"
    assert rows["r2"]["fit"]["reason"].startswith("run too short")
    run_events = [e for e in hub.flush() if e.name == "run"]
    assert len(run_events) == 4                                     # the late claim changed nothing


def test_safe_file_name_refuses_what_could_leave_a_folder() -> None:
    assert safe_file_name("figs/pem.png") == "pem.png"
    assert safe_file_name("..") is None and safe_file_name("") is None
    assert safe_file_name("a b.png") is None


def test_run_files_stay_inside_the_runs_dir(tmp_path: Path) -> None:
    runs = tmp_path / "runs"
    (runs / "r1.fit").mkdir(parents=True)
    (runs / "r1.mcap").write_bytes(b"mcap")
    (runs / "r1.fit" / "report.json").write_text("{}")
    (runs / "r1.fit" / "pem.png").write_bytes(b"png")
    secret = tmp_path / "secret.txt"
    secret.write_text("no")
    os.symlink(secret, runs / "r1.fit" / "leak.png")
    os.symlink(secret, runs / "r2.mcap")
    assert mcap_path(runs, "r1").read_bytes() == b"mcap"
    assert fit_file_path(runs, "r1", "pem.png").read_bytes() == b"png"
    assert list_fit_files(runs, "r1") == ["pem.png", "report.json"]
    with pytest.raises(RunFileError):
        fit_file_path(runs, "r1", "leak.png")
    with pytest.raises(RunFileError):
        mcap_path(runs, "r2")
    with pytest.raises(RunFileError):
        mcap_path(runs, "missing")
    for bad in ("..", "../secret", "/etc/passwd", ""):
        with pytest.raises(SchemaError):
            fit_file_path(runs, "r1", bad)
        with pytest.raises(SchemaError):
            mcap_path(runs, bad)


def test_a_page_that_lags_is_dropped_and_told_to_reconnect() -> None:
    import asyncio

    from daq.web.broadcast import CLIENT_QUEUE_EVENTS, Broadcaster
    from daq.web.hub import Event

    async def scenario() -> None:
        hub = Broadcaster()
        slow, other = hub.add("b1"), hub.add("b2")
        hub.publish([Event("samples", "b1", {"i": i}) for i in range(CLIENT_QUEUE_EVENTS + 1)])
        assert slow.dropped and slow not in hub.clients and hub.clients_dropped == 1
        assert slow.queue.qsize() == 1 and slow.queue.get_nowait() is None   # its stream ends
        assert other.queue.empty() and not other.dropped                     # other benches untouched
        hub.publish([Event("benches", None, {})])
        assert other.queue.get_nowait() == Event("benches", None, {})

    asyncio.run(scenario())


def test_command_line_defaults_and_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from daq.web.__main__ import build_parser, main, settings_from_args

    settings = settings_from_args(build_parser().parse_args([]))
    assert settings.bus.connect == ["tcp/127.0.0.1:7447"] and settings.bus.listen == []
    assert settings.runs_dir is None and settings.display_hz == 250.0 and settings.allow_hosts == ()
    assert settings_from_args(build_parser().parse_args(
        ["--allow-host", "labpc", "--allow-host", "labpc.local"])).allow_hosts == ("labpc", "labpc.local")
    settings = settings_from_args(build_parser().parse_args(
        ["--listen", "tcp/127.0.0.1:7450", "--runs-dir", str(tmp_path), "--display-hz", "100"]))
    assert settings.bus.connect == [] and settings.bus.listen == ["tcp/127.0.0.1:7450"]
    assert settings.runs_dir == tmp_path and settings.display_hz == 100.0
    for argv, message in ((["--connect", "localhost:7447"], "expected an endpoint like"),
                          (["--runs-dir", str(tmp_path / "absent")], "expected an existing directory"),
                          (["--display-hz", "0"], "expected a rate > 0")):
        with pytest.raises(SystemExit) as exc:
            main(argv)
        assert exc.value.code == 2 and message in capsys.readouterr().err


def test_host_names_and_the_allowed_set() -> None:
    from daq.web.hosts import allowed_hosts, host_name
    assert host_name("LocalHost:8000") == "localhost"
    assert host_name("[::1]:8000") == "::1" and host_name("[::1]") == "::1"
    assert host_name("evil.example.") == "evil.example"
    assert allowed_hosts("0.0.0.0") == frozenset({"localhost", "127.0.0.1", "::1"})
    assert allowed_hosts("::") == frozenset({"localhost", "127.0.0.1", "::1"})
    assert "192.168.1.20" in allowed_hosts("192.168.1.20")
    assert "fe80::1" in allowed_hosts("fe80::1")
    assert "labpc" in allowed_hosts("0.0.0.0", ["LabPC:8000"])


def test_history_keeps_the_last_window_bounded_and_restarts_with_the_clock() -> None:
    from daq.web.live import DecimatedSamples, History
    history = History(display_hz=100.0, seconds=2.0)
    assert history.capacity == 201
    for k in range(50):                                   # 5 s at 100 points/s, in batches of 10
        t = [(k * 10 + i) * 0.01 for i in range(10)]
        history.extend(DecimatedSamples(t_s=t, pos1_m=[x * 2 for x in t], pos2_m=None, raw_count=40))
    event = history.as_event("b")
    t_s = event["t_s"]
    assert isinstance(t_s, list) and len(t_s) <= history.capacity
    assert t_s[-1] == pytest.approx(4.99) and t_s[0] >= 4.99 - 2.0 and t_s[0] < 4.99 - 1.9
    assert event["pos1_m"] == [x * 2 for x in t_s] and event["pos2_m"] is None
    history.extend(DecimatedSamples(t_s=[0.5, 0.51], pos1_m=[1.0, 1.0], pos2_m=[2.0, None], raw_count=2))
    event = history.as_event("b")
    assert event["t_s"] == [0.5, 0.51] and event["pos2_m"] == [2.0, None]   # a restarted daq


def test_a_snapshot_carries_what_was_flushed() -> None:
    hub = Hub(display_hz=250.0)
    assert hub.snapshot("benchX")["history"]["t_s"] == []
    hub.on_samples(batch(0, 40, 1000.0, bench="benchX", two=False))
    assert hub.snapshot("benchX")["history"]["t_s"] == []       # not sent yet: not history yet
    (event,) = [e for e in hub.flush() if e.name == "samples"]
    history = hub.snapshot("benchX")["history"]
    assert history["t_s"] == event.data["t_s"] and history["pos1_m"] == event.data["pos1_m"]
    assert len(history["t_s"]) == 10


def test_a_bench_turns_stale_with_the_time_it_did_and_back() -> None:
    hub = Hub()
    ok, unplugged = status("b1", state="released"), status("b1", connected=False, state="released")
    hub.on_alive("b1", True, 100.0)
    hub.on_status("b1", ok, None, 101.0)
    assert hub.snapshot("b1")["status"]["stale"] is None
    hub.on_status("b1", unplugged, None, 102.0)
    hub.on_status("b1", unplugged, None, 103.0)
    view = hub.snapshot("b1")["status"]
    assert (view["stale"], view["stale_since"]) == ("port gone", 102.0)      # since the first
    hub.on_status("b1", ok, None, 104.0)
    assert hub.snapshot("b1")["status"]["stale_since"] is None
    hub.on_status("b1", None, "daq for bench b1 does not answer: timeout", 105.0)
    hub.on_alive("b1", False, 106.0)
    view = hub.snapshot("b1")["status"]
    assert (view["stale"], view["stale_since"]) == ("daq gone", 105.0)
    events = [e for e in hub.flush() if e.name == "status"]
    assert events[-1].data["stale"] == "daq gone" and events[-1].data["stale_since"] == 105.0


def test_the_cause_is_the_headline_never_an_immaterial_effect_and_aborted_runs_are_not_fitted() -> None:
    from daq.web.runs_view import diagnosis_summary, run_row
    from schemas.diagnosis import EffectFit
    from testkit.web_support import diagnosis_record

    def effect(name: str, gain: float, material: bool, rank: int) -> EffectFit:
        return EffectFit(effect=name, rank=rank, step=rank, parameters={}, gain_points=gain,  # type: ignore[arg-type]
                         cv_ratio=10.0, cv_threshold=6.6, bic_drop=5.0, material=material)

    clean = diagnosis_record("none", 0.01, 99.0).model_copy(
        update={"effects": [effect("quantization", 0.01, False, 1)]})
    summary = diagnosis_summary(clean)
    assert summary is not None and summary["cause"] is None and summary["gain_points"] is None
    assert summary["effects"] == [{"effect": "quantization", "gain_points": 0.01, "material": False}]
    rubbing = diagnosis_record("coulomb_friction", 2.5, 90.0).model_copy(
        update={"effects": [effect("coulomb_friction", 2.1, True, 1), effect("quantization", 0.4, False, 2)]})
    summary = diagnosis_summary(rubbing)
    assert summary is not None and (summary["cause"], summary["gain_points"]) == ("coulomb_friction", 2.1)
    aborted = RunFinished(bench="b1", run_id="r9", status="aborted", file="r9.mcap", n_samples=10,
                          release_time_s=None, duration_s=0.1, reason="stopped by signal")
    assert run_row("b1", "r9", aborted, None)["fit_shown"] is False
    assert run_row("b1", "r1", finished("b1", "r1"), None)["fit_shown"] is True
