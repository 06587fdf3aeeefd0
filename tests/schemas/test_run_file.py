"""`schemas.run_file`: the one reader of run files, its limits, and recovery that never destroys.

Bombs and lies are built here from the MCAP spec (records by hand, zstd by `zstandard`), not
with the reader under test.
"""

from __future__ import annotations

import json
import os
import struct
from pathlib import Path

import numpy as np
import pytest
import zstandard

from daq.cli import main as daq_main
from daq.recorder import RunWriter, recover_dir, utc_now_iso
from daq.run_file import load_run
from schemas import run_file, topics
from schemas.daq import RunFinished, RunMetadata, SampleBatch
from testkit.peak_memory import peak_growth, reset_peak, status_bytes

REPO = Path(__file__).resolve().parents[2]
MAGIC = b"\x89MCAP0\r\n"


def _meta(run_id: str) -> RunMetadata:
    return RunMetadata(bench="b1", run_id=run_id, dialect="cartlab", port="sim://", counts_per_m=20000.0,
                       signs=[1], zero_offsets_raw=[0.0], n_channels=1, detector_settings={},
                       detector_method="test", release_time_s=0.1, release_t_ns=1_100_000_000,
                       first_t_ns=1_000_000_000, pre_trigger_s=0.1, software_version="0",
                       started_utc=utc_now_iso())


def _write_part(runs: Path, run_id: str, n_batches: int, seed: int) -> list[float]:
    rng = np.random.default_rng(seed)
    writer = RunWriter(runs, _meta(run_id), now_s=0.0)
    values = []
    for b in range(n_batches):
        raw = rng.integers(-2000, 2000, 20).astype(float).tolist()
        values += raw
        writer.write_samples(SampleBatch(bench="b1", run_id=run_id, batch_seq=b,
                                         t_ns=[1_000_000_000 + (20 * b + i) * 1_000_000 for i in range(20)],
                                         pos1_m=[r / 20000 for r in raw], raw1=raw), now_s=1.0 + b)
    writer.abandon()
    return values


def _finish(runs: Path, run_id: str, n_batches: int, seed: int) -> Path:
    _write_part(runs, run_id, n_batches, seed)
    (finished,) = [r.finished for r in recover_dir(runs) if r.finished is not None]
    return runs / finished.file


# --- records by hand (MCAP spec) ---------------------------------------------------------------

def _record(opcode: int, body: bytes) -> bytes:
    return struct.pack("<BQ", opcode, len(body)) + body


def _string(text: str) -> bytes:
    raw = text.encode()
    return struct.pack("<I", len(raw)) + raw


def _header() -> bytes:
    return _record(0x01, _string("") + _string("test"))


def _channel(channel_id: int, topic: str) -> bytes:
    return _record(0x04, struct.pack("<HH", channel_id, 0) + _string(topic) + _string("json")
                   + struct.pack("<I", 0))


def _message(channel_id: int, seq: int, data: bytes) -> bytes:
    return _record(0x05, struct.pack("<HIQQ", channel_id, seq, 0, 0) + data)


def _chunk(inner: bytes, declared: int | None = None) -> bytes:
    packed = zstandard.ZstdCompressor(level=19).compress(inner)
    size = len(inner) if declared is None else declared
    body = (struct.pack("<QQQI", 0, 0, size, 0) + _string("zstd") + struct.pack("<Q", len(packed)) + packed)
    return _record(0x06, body)


def _batch(seq: int, n: int) -> bytes:
    return SampleBatch(bench="b1", batch_seq=seq, t_ns=list(range(seq * n, seq * n + n)),
                       pos1_m=[0.0] * n, raw1=[0.0] * n).to_json_bytes()


def _bomb(path: Path, n_chunks: int, batches_per_chunk: int) -> None:
    """Chunks of identical sample batches: tiny compressed, huge decompressed."""
    out = [MAGIC, _header(), _channel(1, topics.SAMPLES)]
    for c in range(n_chunks):
        out.append(_chunk(b"".join(_message(1, c * batches_per_chunk + i, _batch(0, 2000))
                                   for i in range(batches_per_chunk))))
    path.write_bytes(b"".join(out))


# --- the reader -------------------------------------------------------------------------------

def test_a_decompression_bomb_is_refused_by_name_before_memory_grows(tmp_path: Path) -> None:
    bomb = tmp_path / "bomb.mcap"
    _bomb(bomb, n_chunks=40, batches_per_chunk=30)    # 2.4 M samples in well under 1 MB
    assert bomb.stat().st_size < 1_000_000
    with pytest.raises(run_file.RunFileTooLarge, match="decompressed bytes per compressed byte"):
        run_file.read_run(bomb, run_file.Limits(expansion_after_bytes=1 << 16))   # each chunk expands >200x
    limits = run_file.Limits(max_samples=1_000_000, max_expansion=1e9)
    with pytest.raises(run_file.RunFileTooLarge, match="samples ≤ 1000000"):
        run_file.read_run(bomb, limits)
    with pytest.raises(run_file.RunFileTooLarge, match="decompressed bytes"):
        run_file.read_run(bomb, run_file.Limits(max_decompressed_bytes=10_000_000, max_expansion=1e9))


def test_a_chunk_that_declares_a_huge_size_is_refused_and_one_that_lies_is_damage(tmp_path: Path) -> None:
    inner = _message(1, 0, _batch(0, 10))
    big = tmp_path / "big.mcap"
    big.write_bytes(MAGIC + _header() + _channel(1, topics.SAMPLES) + _chunk(inner, declared=2**40))
    with pytest.raises(run_file.RunFileTooLarge, match="decompressed chunk bytes"):
        run_file.read_run(big)
    small = tmp_path / "lie.mcap"    # declares 100 bytes, holds more: stop there, keep nothing of it
    small.write_bytes(MAGIC + _header() + _channel(1, topics.SAMPLES) + _chunk(inner * 50, declared=100))
    read = run_file.read_run(small)
    assert read.t_ns.size == 0 and not read.complete and "decompressed" in (read.stop_reason or "")


@pytest.mark.parametrize("where", ["outer", "inner"])
def test_a_length_field_that_lies_neither_allocates_nor_crosses_records(tmp_path: Path, where: str) -> None:
    good = _message(1, 0, _batch(0, 10))
    lying = bytearray(_message(1, 1, _batch(1, 10)))
    struct.pack_into("<Q", lying, 1, 2**62)
    body = good + bytes(lying) if where == "inner" else good
    data = MAGIC + _header() + _channel(1, topics.SAMPLES) + _chunk(body)
    if where == "outer":
        data += bytes(lying)
    path = tmp_path / f"{where}.mcap"
    path.write_bytes(data)
    before = status_bytes("self", "VmRSS")
    reset_peak("self")   # the high-water mark from here on is this read's
    read = run_file.read_run(path)
    assert status_bytes("self", "VmHWM") - before < 200_000_000   # no 2**62 allocation
    assert not read.complete and "claims" in (read.stop_reason or "")
    assert read.t_ns.tolist() == ([] if where == "inner" else list(range(10)))


def test_the_file_size_limit_refuses_before_reading(tmp_path: Path) -> None:
    sparse = tmp_path / "sparse.mcap"
    with open(sparse, "wb") as handle:
        handle.truncate(1 << 30)     # 1 GiB of holes: no disk used
    with pytest.raises(run_file.RunFileTooLarge, match="file bytes"):
        run_file.read_run(sparse, run_file.Limits(max_file_bytes=512 << 20))
    read = run_file.read_run(sparse)   # within the default limit: the magic is missing, nothing read
    assert read.n_records == 0 and not read.complete


def test_batches_written_out_of_time_order_are_read_in_time_order_with_their_rows(tmp_path: Path) -> None:
    """A recovered file may hold its batches out of order: the rows come back sorted by the
    batches' times, each position beside its own time, in one and in two channels."""
    rng = np.random.default_rng(5)
    for two in (False, True):
        batches = []
        for seq in (2, 0, 3, 1):
            n = int(rng.integers(1, 40))
            t = [10_000 * seq + k for k in range(n)]
            pos1 = [float(v) for v in t]
            batches.append(SampleBatch(bench="b1", batch_seq=seq, t_ns=t, pos1_m=pos1, raw1=pos1,
                                       pos2_m=[-v for v in pos1] if two else None,
                                       raw2=[-v for v in pos1] if two else None))
        path = tmp_path / f"shuffled{int(two)}.mcap"
        inner = b"".join(_message(1, k, b.to_json_bytes()) for k, b in enumerate(batches))
        path.write_bytes(MAGIC + _header() + _channel(1, topics.SAMPLES) + _chunk(inner))
        read = run_file.read_run(path)
        assert read.t_ns.size == sum(len(b.t_ns) for b in batches)
        assert np.all(np.diff(read.t_ns) > 0)
        assert np.array_equal(read.pos_m[:, 0], read.t_ns.astype(float))
        assert read.pos_m.shape[1] == (2 if two else 1) and np.array_equal(read.raw, read.pos_m)
        if two:
            assert np.array_equal(read.pos_m[:, 1], -read.pos_m[:, 0])


def test_memory_to_read_a_run_stays_within_twice_its_arrays_and_file(tmp_path: Path) -> None:
    path = tmp_path / "long.mcap"
    _bomb(path, n_chunks=30, batches_per_chunk=20)   # 1.2 M samples, one channel
    small = tmp_path / "small.mcap"
    _bomb(small, n_chunks=1, batches_per_chunk=1)
    # in a fresh child, after a first read there, by the kernel's high-water mark: `ru_maxrss`
    # carries the pytest parent's size across execve and read +0 here, whatever the reader did
    read = "testkit.mcap_runs:read_run_samples"
    measured = peak_growth(read, [str(path)], warm=(read, [str(small)]))
    n, grown = int(measured.outcome), measured.growth_bytes
    arrays = n * (8 + 8 + 8)   # t_ns, pos_m, raw
    assert n == 1_200_000
    assert grown <= 2 * (arrays + path.stat().st_size), f"grew {grown / 1e6:.0f} MB for {arrays / 1e6:.0f} MB"


def test_read_finished_takes_the_summary_or_walks_a_file_without_one(tmp_path: Path) -> None:
    finished_path = _finish(tmp_path, "r1", 5, seed=1)
    done = run_file.read_finished(finished_path)
    assert isinstance(done, RunFinished) and done.run_id == "r1" and done.n_samples == 100
    cut = tmp_path / "cut.mcap"       # the summary gone: the metadata is still found by walking
    data = finished_path.read_bytes()
    footer_at = data.rindex(b"\x02" + struct.pack("<Q", 20))
    summary_start = struct.unpack_from("<Q", data, footer_at + 9)[0]
    cut.write_bytes(data[:summary_start])
    assert run_file.read_finished(cut) == done
    assert run_file.read_finished(tmp_path / "absent.mcap") is None


# --- recovery ---------------------------------------------------------------------------------

def test_recovery_never_overwrites_a_finished_run_and_keeps_the_stale_part_data(tmp_path: Path) -> None:
    final = _finish(tmp_path, "r7", 30, seed=2)
    before = final.read_bytes()
    stale = _write_part(tmp_path, "r7", 4, seed=3)   # a stale part beside the finished file
    assert daq_main(["recover", str(tmp_path)]) == 0
    assert final.read_bytes() == before
    recovered = load_run(tmp_path / "r7-r1.mcap")
    assert recovered.finished is not None and recovered.finished.run_id == "r7-r1"
    assert recovered.finished.status == "recovered" and "r7.mcap was already finished" in (
        recovered.finished.reason or "")
    assert recovered.raw[:, 0].tolist() == stale
    assert not (tmp_path / "r7.mcap.part").exists()


def test_an_unreadable_part_is_quarantined_not_deleted(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    junk = os.urandom(3000)
    (tmp_path / "r9.mcap.part").write_bytes(junk)
    (tmp_path / "r8.mcap.part").write_bytes(b"")
    assert daq_main(["recover", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "r9.mcap.part: quarantined" in out and "r8.mcap.part: quarantined" in out
    assert (tmp_path / run_file.QUARANTINE_DIR / "r9.mcap.part").read_bytes() == junk
    assert (tmp_path / run_file.QUARANTINE_DIR / "r8.mcap.part").exists()
    assert not list(tmp_path.glob("*.mcap"))


def test_odd_entries_named_part_are_skipped_and_the_rest_recovered(tmp_path: Path,
                                                                   caplog: pytest.LogCaptureFixture) -> None:
    (tmp_path / "d.mcap.part").mkdir()
    loop = tmp_path / "loop.mcap.part"
    loop.symlink_to(loop)
    _write_part(tmp_path, "ok", 3, seed=4)
    results = {r.part.name: r.outcome for r in recover_dir(tmp_path)}
    assert results == {"d.mcap.part": "skipped", "loop.mcap.part": "skipped", "ok.mcap.part": "recovered"}
    assert (tmp_path / "d.mcap.part").is_dir() and loop.is_symlink()
    assert load_run(tmp_path / "ok.mcap").t_ns.size == 60
    assert "not a regular file" in caplog.text
    assert json.dumps(sorted(results))  # every entry named
