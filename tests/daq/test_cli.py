"""`daq run` on a `sim://` rig end to end (subprocess), the file commands, and `daq serve`."""

from __future__ import annotations

import csv
import json
import signal
import subprocess
import sys
import urllib.request
from pathlib import Path

import numpy as np
import pytest

from daq.cli import main
from daq.run_file import load_run
from testkit import ports
from testkit.daq_process import daq_command, parse_capture
from testkit.repo import REPO
from testkit.waiting import wait_until

SIM = "sim://?realtime=0&rate_hz=200&cases=cart1,cart2,both&seed=5&c1=2&c2=2&capture={capture}"


@pytest.fixture(scope="module")
def sim_runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    root = tmp_path_factory.mktemp("sim_runs")
    capture = root / "capture.bin"
    runs = root / "runs"
    proc = subprocess.run(daq_command("run", "--port", SIM.format(capture=capture), "--runs-dir", str(runs),
                                      "--no-zenoh", "--until-eof", "--bench", "b1"),
                          cwd=REPO, capture_output=True, timeout=90)
    assert proc.returncode == 0, proc.stderr.decode()
    return runs, capture


def test_one_file_per_release_with_exactly_the_emitted_samples(sim_runs: tuple[Path, Path]) -> None:
    runs, capture = sim_runs
    files = sorted(runs.glob("*.mcap"))   # run ids sort in start order
    assert len(files) == 3 and not list(runs.glob("*.part"))
    emitted = parse_capture(capture.read_bytes())
    assert np.all(np.diff(emitted["t_us"]) > 0)   # no clock wrap in this capture
    pulled = []
    for path in files:
        run = load_run(path)
        assert run.complete and run.finished is not None and run.finished.status == "complete"
        start = int(np.searchsorted(emitted["t_us"] * 1000, run.t_ns[0]))
        span = slice(start, start + run.t_ns.size)
        assert run.t_ns.tolist() == (emitted["t_us"][span] * 1000).tolist()
        assert run.raw[:, 0].tolist() == emitted["enc1"][span].astype(float).tolist()
        assert run.raw[:, 1].tolist() == emitted["enc2"][span].astype(float).tolist()
        assert run.release_time_s is not None and 0.5 <= run.release_time_s < 0.5 + 1 / 200
        assert run.metadata is not None and run.metadata.counts_per_m == 20000.0   # from the $I line
        pulled.append((run.metadata.pulled_cart, run.metadata.lab_case, run.metadata.moving_carts))
    assert pulled == [(1, "cart1", [1]), (2, "cart2", [2]), (1, "both", [1, 2])]


def test_info_json_has_release_time(sim_runs: tuple[Path, Path], capsys: pytest.CaptureFixture[str]) -> None:
    path = sorted(sim_runs[0].glob("*.mcap"))[0]
    assert main(["info", str(path), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["release_time_s"] == pytest.approx(load_run(path).release_time_s)
    assert info["metadata"]["bench"] == "b1"
    assert info["metadata"]["detector_settings"]["pre_trigger_s"] == 0.5


def test_export_csv_and_mat(sim_runs: tuple[Path, Path], tmp_path: Path) -> None:
    path = sorted(sim_runs[0].glob("*.mcap"))[1]
    run = load_run(path)
    assert main(["export", str(path), "--format", "csv", "-o", str(tmp_path / "r.csv")]) == 0
    rows = [r for r in csv.reader((tmp_path / "r.csv").open()) if not r[0].startswith("#")]
    assert rows[0] == ["time_s", "pos1_m", "pos2_m"]
    assert len(rows) == run.t_ns.size + 1
    assert float(rows[-1][0]) == pytest.approx((run.t_ns[-1] - run.t_ns[0]) / 1e9)
    assert main(["export", str(path), "--format", "mat", "-o", str(tmp_path / "r.mat")]) == 0
    assert (tmp_path / "r.mat").stat().st_size > run.t_ns.size * 8


def test_bad_port_says_which_url(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["run", "--port", "/dev/does-not-exist-42", "--runs-dir", str(tmp_path), "--no-zenoh"])
    assert code == 1
    err = capsys.readouterr().err
    assert "/dev/does-not-exist-42" in err and "expected a port that opens" in err


def test_recover_on_an_empty_directory_says_so(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["recover", str(tmp_path)]) == 0
    assert "nothing to recover" in capsys.readouterr().out


def test_a_port_that_goes_away_mid_run_leaves_a_marked_gap(tmp_path: Path) -> None:
    capture = tmp_path / "capture.bin"
    url = ("sim://?realtime=0&cases=cart1&seed=3&c1=2&c2=2&disconnect_every_s=6&disconnect_s=0.5"
           f"&capture={capture}")
    proc = subprocess.run(daq_command("run", "--port", url, "--runs-dir", str(tmp_path / "runs"), "--no-zenoh",
                                      "--until-eof"), cwd=REPO, capture_output=True, timeout=60)
    assert proc.returncode == 0, proc.stderr.decode()
    assert b"disconnected; reopening" in proc.stderr
    (path,) = (tmp_path / "runs").glob("*.mcap")
    run = load_run(path)
    assert run.metadata is not None and run.finished is not None
    counters = run.metadata.counters
    assert counters.reconnects == 1 and len(counters.gap_intervals) == 1
    gap = counters.gap_intervals[0]
    assert gap.reason == "disconnect" and gap.lost_frames == counters.lost_frames > 0
    # the run kept what it had on both sides of the gap, and the gap is where samples are missing
    steps = np.diff(run.t_ns)
    assert int(steps.max()) == gap.end_t_ns - gap.start_t_ns
    assert int(run.t_ns[0]) < gap.start_t_ns < gap.end_t_ns < int(run.t_ns[-1])
    emitted = parse_capture(capture.read_bytes())
    start = int(np.searchsorted(emitted["t_us"] * 1000, run.t_ns[0]))
    assert run.raw[:, 0].tolist() == emitted["enc1"][start:start + run.t_ns.size].astype(float).tolist()


def test_replaying_the_capture_gives_the_same_runs(sim_runs: tuple[Path, Path], tmp_path: Path) -> None:
    runs, capture = sim_runs
    proc = subprocess.run(daq_command("run", "--port", f"replay://{capture}?speed=max", "--runs-dir",
                                      str(tmp_path / "replayed"), "--no-zenoh", "--until-eof", "--bench", "b1"),
                          cwd=REPO, capture_output=True, timeout=60)
    assert proc.returncode == 0, proc.stderr.decode()
    live = [load_run(p) for p in sorted(runs.glob("*.mcap"))]
    replayed = [load_run(p) for p in sorted((tmp_path / "replayed").glob("*.mcap"))]
    assert len(replayed) == len(live) == 3
    for a, b in zip(live, replayed):
        assert a.t_ns.tolist() == b.t_ns.tolist()
        assert a.raw.tolist() == b.raw.tolist()
        assert a.release_time_s == b.release_time_s


def test_serve_help_is_the_bench_page_help(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["serve", "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith("usage: daq serve") and "--display-hz" in out and "--runs-dir" in out
    with pytest.raises(SystemExit) as exc:
        main(["run", "--port", "x", "--display-hz", "5"])   # serve's options are serve's only
    assert exc.value.code == 2
    assert "unrecognized arguments: --display-hz 5" in capsys.readouterr().err


def test_daq_run_does_not_load_the_web_stack(tmp_path: Path) -> None:
    probe = ("import sys; from daq.cli import main; "
             f"code = main(['run', '--port', '/dev/does-not-exist-42', '--runs-dir', {str(tmp_path)!r}]); "
             "print(code, sorted(m for m in sys.modules if m.split('.')[0] in ('starlette', 'uvicorn') "
             "or m.startswith('daq.web')))")
    proc = subprocess.run([sys.executable, "-c", probe], cwd=REPO, capture_output=True, timeout=60)
    assert proc.stdout.decode().split() == ["1", "[]"], proc.stderr.decode()


def test_serve_serves_the_page_and_stops_cleanly_on_sigterm(free_port: int) -> None:
    nobody = ports.endpoint()   # no daq there: the page says so and keeps serving
    proc = subprocess.Popen(daq_command("serve", "--port", str(free_port), "--connect", nobody), cwd=REPO,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    url = f"http://127.0.0.1:{free_port}/api/stats"

    def serving() -> bool:
        try:
            with urllib.request.urlopen(url, timeout=2) as reply:
                return bool(reply.status == 200)
        except OSError:
            assert proc.poll() is None, proc.stderr.read() if proc.stderr else b""
            return False

    try:
        wait_until(serving, 20, "daq serve to answer")
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(10) == 0
        err = proc.stderr.read() if proc.stderr else b""
        assert f"bench page on http://127.0.0.1:{free_port}/".encode() in err and b"Traceback" not in err
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(5)


@pytest.mark.parametrize("port", ["tcp://127.0.0.1:9", "http://bench/", "COM://3"])
def test_unknown_url_scheme_is_one_line_listing_the_schemes(port: str, capsys: pytest.CaptureFixture[str],
                                                             tmp_path: Path) -> None:
    assert main(["run", "--port", port, "--no-zenoh", "--runs-dir", str(tmp_path)]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert port in err and "socket://" in err and "sim://" in err and "replay://" in err
    assert not list(tmp_path.iterdir())   # refused before anything opened or was written
