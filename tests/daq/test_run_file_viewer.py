"""Run files as a viewer sees them: UTC log times, one metadata record per name, every sample
as its own `/position` message, checked with cartlab's reader and with an independent one
(the TypeScript `@mcap/core` through node, installed by `make node`; skipped without it).
"""

from __future__ import annotations

import json
import shutil
import subprocess
import time
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from daq.run_file import load_run
from schemas import topics
from schemas.daq import PositionSample, SampleBatch
from testkit.daq_process import daq_command, parse_capture
from testkit.repo import REPO

SIM = "sim://?realtime=0&rate_hz=200&cases=cart1,both&seed=11&c1=2&c2=2&capture={capture}"
NODE_DIR = REPO / "tests" / "node"
YEAR_2020_NS = 1_577_836_800 * 10**9


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> tuple[list[Path], Path, int, int]:
    """Two runs recorded by `daq run` from a simulated rig; the wall-clock window around it (ns)."""
    root = tmp_path_factory.mktemp("viewer_runs")
    capture = root / "capture.bin"
    before = time.time_ns()
    proc = subprocess.run(daq_command("run", "--port", SIM.format(capture=capture), "--runs-dir",
                                      str(root / "runs"), "--no-zenoh", "--until-eof", "--bench", "b1"),
                          cwd=REPO, capture_output=True, timeout=90, check=False)
    after = time.time_ns()
    assert proc.returncode == 0, proc.stderr.decode()
    files = sorted((root / "runs").glob("*.mcap"))
    assert len(files) == 2
    return files, capture, before, after


def test_log_time_is_utc_from_an_offset_fixed_at_the_stream_start(
        recorded: tuple[list[Path], Path, int, int]) -> None:
    files, capture, before, after = recorded
    first_device_ns = int(parse_capture(capture.read_bytes())["t_us"][0]) * 1000
    offsets = set()
    for path in files:
        run = load_run(path)
        assert run.metadata is not None and run.metadata.utc_offset_ns is not None
        offsets.add(run.metadata.utc_offset_ns)
        with open(path, "rb") as stream:
            reader = make_reader(stream)
            samples = [(m.log_time, m.publish_time, SampleBatch.from_json_bytes(m.data))
                       for _, c, m in reader.iter_messages(topics=[topics.SAMPLES])]
        for log_time, publish_time, batch in samples:   # the device clock stays in the message
            assert log_time == publish_time == batch.t_ns[0] + run.metadata.utc_offset_ns
    assert len(offsets) == 1   # one offset for the whole stream, not one per run
    stream_start_utc = offsets.pop() + first_device_ns
    assert before <= stream_start_utc <= after


def test_one_metadata_record_per_name(recorded: tuple[list[Path], Path, int, int]) -> None:
    for path in recorded[0]:
        with open(path, "rb") as stream:
            names = Counter(record.name for record in make_reader(stream).iter_metadata())
        assert names == {topics.METADATA_RUN_STARTED: 1, topics.METADATA_RUN: 1, topics.METADATA_FINISHED: 1}


def test_every_sample_is_its_own_position_message_at_its_utc_time(
        recorded: tuple[list[Path], Path, int, int]) -> None:
    for path in recorded[0]:
        run = load_run(path)
        assert run.metadata is not None and run.metadata.utc_offset_ns is not None
        with open(path, "rb") as stream:
            points = [(m.log_time, PositionSample.from_json_bytes(m.data))
                      for _, _, m in make_reader(stream).iter_messages(topics=[topics.POSITION])]
        assert [p.t_ns for _, p in points] == run.t_ns.tolist()
        assert [t for t, _ in points] == (run.t_ns + run.metadata.utc_offset_ns).tolist()
        assert np.array_equal([[p.pos1_m, p.pos2_m] for _, p in points], run.pos_m)


def _node_reader(path: Path) -> dict[str, object]:
    node = shutil.which("node")
    if node is None:
        pytest.skip("node is not installed: the independent MCAP reader cannot run (apt-get install nodejs)")
    modules = NODE_DIR / "node_modules"
    if not (modules / "@mcap" / "core").is_dir() or not (modules / "fzstd").is_dir():
        pytest.skip("@mcap/core and fzstd are not installed in tests/node: run `make node`")
    proc = subprocess.run([node, str(NODE_DIR / "check_mcap.mjs"), str(path)], capture_output=True,
                          text=True, timeout=60, check=False)
    assert proc.returncode == 0, proc.stderr
    result: dict[str, object] = json.loads(proc.stdout)
    return result


def test_an_independent_reader_sees_every_sample_on_the_utc_axis(
        recorded: tuple[list[Path], Path, int, int]) -> None:
    for path in recorded[0]:
        run = load_run(path)
        assert run.metadata is not None and run.metadata.utc_offset_ns is not None
        seen = _node_reader(path)
        indexed, stream = seen["indexed"], seen["stream"]
        assert isinstance(indexed, dict) and isinstance(stream, dict)
        assert stream["done"] is True   # a complete file, CRCs valid record by record
        position = indexed["topics"][topics.POSITION]
        assert position["schema"] == "cartlab.PositionSample"
        assert (position["schemaEncoding"], position["messageEncoding"]) == ("jsonschema", "json")
        assert position["ordered"] is True and position["count"] == run.t_ns.size
        log_times = np.array([int(t) for t in position["logTimes"]], dtype=np.int64)
        assert np.array_equal(log_times, run.t_ns + run.metadata.utc_offset_ns)
        assert position["publishTimes"] == position["logTimes"]
        assert log_times[0] > YEAR_2020_NS
        values = np.array([[m["pos1_m"], m["pos2_m"]] for m in position["messages"]])
        assert np.array_equal(values, run.pos_m)
        assert [m["t_ns"] for m in position["messages"]] == run.t_ns.tolist()
        batches = indexed["topics"][topics.SAMPLES]
        assert sum(len(m["t_ns"]) for m in batches["messages"]) == run.t_ns.size
        names = [m["name"] for m in indexed["metadata"]]
        assert sorted(names) == sorted(set(names)) == sorted(
            [topics.METADATA_RUN_STARTED, topics.METADATA_RUN, topics.METADATA_FINISHED])
        statistics = indexed["statistics"]
        assert int(statistics["messageStartTime"]) == int(log_times[0])


def test_csv_export_states_the_release_and_metadata_and_ident_reads_them(
        recorded: tuple[list[Path], Path, int, int], tmp_path: Path) -> None:
    import ident
    from daq.cli import main

    path = recorded[0][0]
    run = load_run(path)
    assert run.metadata is not None and run.release_time_s is not None
    out = tmp_path / "run.csv"
    assert main(["export", str(path), "--format", "csv", "-o", str(out)]) == 0
    comments = dict(line[2:].split(": ", 1) for line in out.read_text().splitlines()
                    if line.startswith("# ") and ": " in line)
    assert float(comments["release_time_s"]) == run.release_time_s
    assert comments["run_id"] == run.metadata.run_id and comments["pulled_cart"] == "1"
    assert comments["lab_case"] == run.metadata.lab_case
    assert json.loads(comments["metadata_json"])["utc_offset_ns"] == run.metadata.utc_offset_ns
    first_utc = np.datetime64(comments["first_sample_utc"].removesuffix("+00:00"), "ns").astype(np.int64)
    assert abs(int(first_utc) - (int(run.t_ns[0]) + run.metadata.utc_offset_ns)) < 1000
    data = ident.load(out)   # the comments are skipped as data and read as the run's facts
    assert data.release_time_s == run.release_time_s and data.pulled_cart == 1
    assert np.array_equal(data.y, run.pos_m)


def test_mat_export_carries_a_metadata_struct(recorded: tuple[list[Path], Path, int, int],
                                              tmp_path: Path) -> None:
    from scipy.io import loadmat

    from daq.cli import main

    path = recorded[0][1]
    run = load_run(path)
    assert run.metadata is not None
    out = tmp_path / "run.mat"
    assert main(["export", str(path), "--format", "mat", "-o", str(out)]) == 0
    mat = loadmat(str(out), squeeze_me=True, struct_as_record=False)
    meta = mat["metadata"]
    assert meta.run_id == run.metadata.run_id and meta.bench == "b1"
    assert meta.release_time_s == run.release_time_s == mat["release_time_s"]
    assert meta.pulled_cart == run.metadata.pulled_cart and meta.lab_case == run.metadata.lab_case
    assert json.loads(meta.metadata_json)["first_t_ns"] == run.metadata.first_t_ns
    assert np.isnan(meta.rate_hz) or meta.rate_hz > 0


def test_a_recovered_run_keeps_one_metadata_record_per_name_and_every_position(tmp_path: Path) -> None:
    from daq.recorder import RunWriter, recover_all
    from testkit.daq_records import run_metadata, sample_batches

    writer = RunWriter(tmp_path, run_metadata(), now_s=0.0)
    batches = sample_batches(30)
    for i, batch in enumerate(batches):
        writer.write_samples(batch, now_s=i * 0.02)
    writer.abandon()   # a crash: the .part stays, with only cartlab.run_started
    (finished,) = recover_all(tmp_path)
    path = tmp_path / finished.file
    with open(path, "rb") as stream:
        reader = make_reader(stream)
        names = Counter(record.name for record in reader.iter_metadata())
        points = [PositionSample.from_json_bytes(m.data).t_ns
                  for _, _, m in reader.iter_messages(topics=[topics.POSITION])]
    assert set(names.values()) == {1} and topics.METADATA_RUN in names
    assert points == [t for b in batches for t in b.t_ns]
    assert load_run(path).metadata is not None
