"""MCAP run files: write/read round trip, crash salvage and `.part` recovery, exports."""

from __future__ import annotations

import csv
import io
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from mcap.reader import make_reader

from daq.errors import DaqIOError
from daq.recorder import RunWriter, finished_of, recover_all, recover_part, utc_now_iso
from daq.run_file import export_csv, export_json, export_mat, load_run, run_info
from schemas import topics
from schemas.daq import DaqCounters, DetectorStateMsg, RunFinished
from testkit.daq_records import run_metadata as _meta
from testkit.daq_records import sample_batches as _batches
from testkit.repo import REPO


def test_round_trip_keeps_every_sample_and_the_metadata(tmp_path: Path) -> None:
    batches = _batches(30)
    writer = RunWriter(tmp_path, _meta(), now_s=0.0)
    assert writer.path.name == "r1.mcap.part"
    writer.write_state(DetectorStateMsg(bench="b1", state="released", t_ns=1_500_000_000, run_id="r1"), 0.0)
    for i, batch in enumerate(batches):
        writer.write_samples(batch, now_s=i * 0.02)
    done = RunFinished(bench="b1", run_id="r1", status="complete", file="r1.mcap", n_samples=600,
                       release_time_s=0.5, duration_s=0.599, counters=DaqCounters(lines=600))
    path = writer.finish(_meta().model_copy(update={"ended_utc": utc_now_iso()}), done)
    assert path == tmp_path / "r1.mcap" and not (tmp_path / "r1.mcap.part").exists()
    run = load_run(path)
    assert run.complete
    assert run.t_ns.tolist() == [t for b in batches for t in b.t_ns]
    assert run.raw[:, 1].tolist() == [r for b in batches for r in (b.raw2 or [])]
    assert run.pos_m[:, 0].tolist() == [p for b in batches for p in b.pos1_m]
    assert run.release_time_s == pytest.approx(0.5)
    assert run.metadata is not None and run.metadata.ended_utc is not None
    assert run.finished == done
    assert [s.state for s in run.states] == ["released"]
    with open(path, "rb") as stream:  # a finished file has a summary readable by the seeking reader
        summary = make_reader(stream).get_summary()
    assert summary is not None and summary.statistics is not None
    assert summary.statistics.message_count == 31 + 600   # batches, state, one /position per sample
    schemas = {s.name: s.encoding for s in summary.schemas.values()}
    assert schemas == {"cartlab.SampleBatch": "jsonschema", "cartlab.DetectorStateMsg": "jsonschema",
                       "cartlab.PositionSample": "jsonschema"}
    assert {c.topic for c in summary.channels.values()} == {topics.SAMPLES, topics.STATE, topics.POSITION}
    assert finished_of(path) == done


def test_exports_share_the_time_base_of_release_time(tmp_path: Path) -> None:
    writer = RunWriter(tmp_path, _meta(), now_s=0.0)
    for batch in _batches(5):
        writer.write_samples(batch, 0.0)
    path = writer.finish(_meta(), RunFinished(bench="b1", run_id="r1", status="complete", file="r1.mcap",
                                              n_samples=100, release_time_s=0.5, duration_s=0.099))
    run = load_run(path)
    rows = [r for r in csv.reader(io.StringIO(export_csv(run))) if not r[0].startswith("#")]
    assert rows[0] == ["time_s", "pos1_m", "pos2_m"]
    assert float(rows[1][0]) == 0.0 and float(rows[2][0]) == pytest.approx(0.001)
    assert float(rows[3][2]) == run.pos_m[2, 1]
    body = json.loads(export_json(run, path))
    assert body["release_time_s"] == pytest.approx(0.5)
    assert body["pos2_m"] == run.pos_m[:, 1].tolist()
    assert run_info(run, path)["n_samples"] == 100
    export_mat(run, tmp_path / "r1.mat")
    from scipy.io import loadmat
    mat = loadmat(str(tmp_path / "r1.mat"))
    assert mat["time_s"].shape == (100, 1)
    assert float(mat["release_time_s"][0, 0]) == pytest.approx(0.5)


_KILLED_WRITER = textwrap.dedent("""
    import os
    from pathlib import Path
    from daq.recorder import RunWriter
    from testkit.daq_records import run_metadata, sample_batches
    writer = RunWriter(Path({runs!r}), run_metadata(), now_s=0.0)
    for i, batch in enumerate(sample_batches(50)):
        writer.write_samples(batch, now_s=i * 0.02)   # 20 ms per batch: flushed every 0.25 s
    os._exit(0)   # no finish: like kill -9
""")


def test_a_killed_writer_is_recovered_up_to_the_last_flush(tmp_path: Path) -> None:
    script = _KILLED_WRITER.format(runs=str(tmp_path))
    subprocess.run([sys.executable, "-c", script], check=True, cwd=REPO, timeout=60)
    part = tmp_path / "r1.mcap.part"
    salvaged = load_run(part)
    assert not salvaged.complete
    # 50 batches × 20 ms = 1.0 s written; the last flush was at ≥ 0.75 s
    assert 0.75 <= salvaged.t_ns.size / 1000 < 1.0
    finished = recover_part(part)
    assert not part.exists()
    assert finished.status == "recovered" and finished.n_samples == salvaged.t_ns.size
    run = load_run(tmp_path / "r1.mcap")
    assert run.complete and run.finished == finished
    assert run.t_ns.tolist() == salvaged.t_ns.tolist()
    assert run.metadata is not None and run.metadata.release_t_ns == 1_500_000_000
    assert recover_all(tmp_path) == []


def test_recovering_a_header_only_part_gives_an_empty_recovered_run(tmp_path: Path) -> None:
    writer = RunWriter(tmp_path, _meta(run_id="r2"), now_s=0.0)
    writer.abandon()
    (finished,) = recover_all(tmp_path)
    assert finished.run_id == "r2" and finished.n_samples == 0 and finished.status == "recovered"
    assert os.path.exists(tmp_path / "r2.mcap")


def test_recover_refuses_a_file_that_is_not_a_part(tmp_path: Path) -> None:
    with pytest.raises(DaqIOError, match=r"expected \*\.mcap\.part"):
        recover_part(tmp_path / "x.mcap")
