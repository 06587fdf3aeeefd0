"""Bad input to `ident` (issue 6, part 3): damaged run files and exports, runs that cannot
be fitted, fuzzed files. The answer is always a clear `IdentError` (naming the problem) or a
result, never another exception and never a hang (every test has a timeout).

The MCAP run file is a real one: a `sim://` rig recorded by the `daq` service in this
process (module fixture), then truncated and corrupted here.
"""

from __future__ import annotations

import random
import shutil
import struct
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ident.cli import main as ident_main
from ident.data import IdData
from ident.errors import DataFileError, IdentError, IdentValueError
from ident.io import load

pytestmark = pytest.mark.timeout(120)


@pytest.fixture(scope="module")
def run_file(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    from daq.service import Service, ServiceConfig

    root = tmp_path_factory.mktemp("badinput")
    url = "sim://?realtime=0&rate_hz=100&cases=cart1&seed=21&rest_s=0.5&pull_s=0.5&hold_s=0.8&c1=2&tail_s=0.3"
    Service(ServiceConfig(port=url, runs_dir=root / "runs", bench="bad", bus=None, until_eof=True)).run()
    files = sorted((root / "runs").glob("*.mcap"))
    assert len(files) == 1
    yield files[0]


def _load_or_ident_error(path: Path) -> IdData | IdentError:
    """Load, or return the `IdentError` it raised; any other exception fails the test."""
    try:
        return load(path)
    except IdentError as exc:
        assert str(exc), "an error must say what is wrong"
        return exc


# --- text exports ------------------------------------------------------------------------------

def _export(path: Path, rows: list[str], header: str = "time_s,pos1_m") -> Path:
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    return path


def _good_rows(n: int = 400, rate_hz: float = 100.0, amplitude_m: float = 0.15) -> list[str]:
    t = np.arange(n) / rate_hz
    y = np.where(t > 1.0, amplitude_m * (1 - np.exp(-0.4 * (t - 1)) * np.cos(8 * (t - 1))), 0.0)
    y += np.random.default_rng(0).normal(0, 1e-5, n)
    return [f"{a:.4f},{b:.7f}" for a, b in zip(t, y, strict=True)]


def test_a_good_export_loads(tmp_path: Path) -> None:
    data = load(_export(tmp_path / "good.csv", _good_rows()))
    assert data.n_samples == 400 and data.t[1] == pytest.approx(0.01)


@pytest.mark.parametrize(("change", "message"), [
    (lambda rows: [*rows[:100], rows[100], *rows[100:]], "duplicate time"),
    (lambda rows: [*rows[:100], rows[50], *rows[101:]], "decreasing time"),
    (lambda rows: rows[:1], "at least"),
    (lambda rows: rows[:5], "at least"),
    (lambda rows: [], "numeric rows"),
], ids=["duplicate", "decreasing", "one-sample", "five-samples", "header-only"])
def test_bad_time_stamps_and_too_few_samples_are_named(tmp_path: Path, change, message: str) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(IdentError, match=message):
        load(_export(tmp_path / "bad.csv", change(_good_rows())))


@pytest.mark.parametrize("bad_value", ["nan", "NaN", "inf", "-Infinity", "abc", "0.1.2"])
def test_a_row_with_nan_inf_or_text_is_an_error_naming_it(tmp_path: Path, bad_value: str) -> None:
    rows = _good_rows()
    rows[200] = f"2.0000,{bad_value}"
    with pytest.raises(IdentError, match=r"row|finite|number"):
        load(_export(tmp_path / "bad.csv", rows))


def test_a_row_with_a_missing_value_is_an_error_naming_it(tmp_path: Path) -> None:
    rows = _good_rows()
    rows[200] = "2.0000,"
    with pytest.raises(IdentError, match="row"):
        load(_export(tmp_path / "bad.csv", rows))


def test_non_finite_values_that_reach_the_arrays_are_named(tmp_path: Path) -> None:
    # Values the row parser accepts but that overflow a float64 (1e999 -> inf).
    rows = _good_rows()
    rows[200] = "2.0000,1e999"
    with pytest.raises(IdentValueError, match="finite"):
        load(_export(tmp_path / "bad.csv", rows))


def test_a_run_without_a_release_is_named(tmp_path: Path) -> None:
    flat = [f"{i / 100:.4f},{0.0:.7f}" for i in range(400)]
    with pytest.raises(IdentError, match="motion"):
        load(_export(tmp_path / "flat.csv", flat))


def test_a_run_without_a_release_fails_the_fit_command_cleanly(tmp_path: Path,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    noise = np.random.default_rng(1).normal(0, 2e-5, 400)
    path = _export(tmp_path / "noise.csv", [f"{i / 100:.4f},{v:.7f}" for i, v in enumerate(noise)])
    assert ident_main(["fit", str(path), "--method", "pem"]) == 2
    assert "ident fit: error:" in capsys.readouterr().err


def test_absurd_amplitudes_are_refused(tmp_path: Path) -> None:
    with pytest.raises(IdentValueError, match=r"amplitude|metres| m"):
        load(_export(tmp_path / "huge.csv", _good_rows(amplitude_m=1.5e11)))


def test_absurd_amplitudes_never_crash_or_hang_the_fit(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for amplitude in (1.5e11, 1e-9):
        path = _export(tmp_path / f"amp{amplitude:g}.csv", _good_rows(amplitude_m=amplitude))
        code = ident_main(["fit", str(path), "--method", "pem"])
        out = capsys.readouterr()
        assert code in (0, 2)
        assert code == 0 or "ident fit: error:" in out.err


# --- MCAP run files ----------------------------------------------------------------------------


def test_the_genuine_run_file_loads(run_file: Path) -> None:
    data = load(run_file)
    assert data.n_samples > 100 and data.release_time_s is not None


@pytest.mark.parametrize("fraction", [0.0, 0.01, 0.05, 0.2, 0.5, 0.8, 0.95, 0.999])
def test_a_truncated_run_file_loads_what_is_complete_or_is_a_data_file_error(run_file: Path, tmp_path: Path,
                                                                            fraction: float) -> None:
    data = run_file.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: int(len(data) * fraction)])
    result = _load_or_ident_error(cut)
    if isinstance(result, IdData):
        assert 0 < result.n_samples <= load(run_file).n_samples
    elif result is not None:
        assert isinstance(result, (DataFileError, IdentValueError)), repr(result)


def test_truncated_mcap_header_is_a_data_file_error(run_file: Path, tmp_path: Path) -> None:
    for size in (1, 5, 9, 20):
        cut = tmp_path / f"cut{size}.mcap"
        cut.write_bytes(run_file.read_bytes()[:size])
        with pytest.raises(DataFileError):
            load(cut)


def test_a_corrupted_compressed_chunk_is_a_data_file_error(run_file: Path, tmp_path: Path) -> None:
    data = bytearray(run_file.read_bytes())
    records = _first_chunk_records_length_offset(bytes(data)) + 8
    size = struct.unpack_from("<Q", data, records - 8)[0]
    data[records + size // 2: records + size // 2 + 16] = bytes(16)   # zero 16 bytes of zstd data
    path = tmp_path / "flipped.mcap"
    path.write_bytes(bytes(data))
    with pytest.raises(DataFileError):
        load(path)


def _first_chunk_records_length_offset(data: bytes) -> int:
    """Byte offset of the u64 `records` length of the first CHUNK record (MCAP spec)."""
    pos = 8                                    # after the magic
    while pos + 9 <= len(data):
        opcode, length = data[pos], struct.unpack_from("<Q", data, pos + 1)[0]
        if opcode == 0x06:                     # CHUNK: 3 x u64, u32 crc, string compression, records
            body = pos + 9
            compression_len = struct.unpack_from("<I", data, body + 28)[0]
            return body + 32 + compression_len
        pos += 9 + length
    raise AssertionError("no chunk in the run file")


def test_a_corrupted_length_inside_a_chunk_is_a_data_file_error(run_file: Path, tmp_path: Path) -> None:
    data = bytearray(run_file.read_bytes())
    struct.pack_into("<Q", data, _first_chunk_records_length_offset(bytes(data)), 2**56)
    path = tmp_path / "bad_length.mcap"
    path.write_bytes(bytes(data))
    with pytest.raises(DataFileError):
        load(path)


def test_empty_and_random_files_named_mcap_are_data_file_errors(tmp_path: Path) -> None:
    rng = random.Random(4)
    for name, content in (("empty.mcap", b""), ("random.mcap", bytes(rng.randrange(256) for _ in range(5000))),
                          ("text.mcap", b"time_s,pos1_m\n"), ("magic.mcap", b"\x89MCAP0\r\n" + b"\x00" * 64)):
        path = tmp_path / name
        path.write_bytes(content)
        with pytest.raises(DataFileError):
            load(path)


def test_a_directory_or_missing_path_is_a_data_file_error(tmp_path: Path) -> None:
    with pytest.raises(DataFileError):
        load(tmp_path / "absent.mcap")
    folder = tmp_path / "folder.mcap"
    folder.mkdir()
    with pytest.raises(DataFileError):
        load(folder)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(flips=st.lists(st.tuples(st.floats(0, 1, exclude_max=True), st.integers(0, 255)), min_size=1, max_size=8))
def test_corrupted_bytes_in_a_run_file_give_data_or_an_ident_error(run_file: Path, tmp_path: Path,
                                                                   flips: list[tuple[float, int]]) -> None:
    data = bytearray(run_file.read_bytes())
    for where, value in flips:
        data[int(where * len(data))] = value
    path = tmp_path / "flipped.mcap"
    path.write_bytes(bytes(data))
    result = _load_or_ident_error(path)
    if isinstance(result, IdData):
        assert np.all(np.isfinite(result.y)) and np.all(np.diff(result.t) > 0)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(text=st.text(alphabet=st.sampled_from(list("0123456789.,;\t -eE+[]#\"\nabnfiNI")), max_size=2000))
def test_fuzzed_text_exports_give_data_or_an_ident_error(tmp_path: Path, text: str) -> None:
    path = tmp_path / "fuzz.csv"
    path.write_text("time_s,pos1_m\n" + text)
    result = _load_or_ident_error(path)
    if isinstance(result, IdData):
        assert np.all(np.isfinite(result.y)) and np.all(np.diff(result.t) > 0)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(blob=st.binary(max_size=3000), suffix=st.sampled_from([".csv", ".tsv", ".txt", ".mcap", ""]))
def test_fuzzed_binary_files_give_data_or_an_ident_error(tmp_path: Path, blob: bytes, suffix: str) -> None:
    path = tmp_path / f"fuzz{suffix}"
    path.write_bytes(blob)
    _load_or_ident_error(path)


@pytest.mark.parametrize("kept", [0.3, 0.5, 2 / 3, 0.9])
def test_a_run_file_copied_mid_write_is_loaded_up_to_the_last_chunk(run_file: Path, tmp_path: Path,
                                                                    kept: float) -> None:
    """A `.part` (the writer killed) is read as MCAP, by its magic, up to its last complete
    record: data with a note of the damage, or a data-file error when no chunk is whole; never
    parsed as a text export (it was, by its `.part` suffix, when the cut left no NUL byte)."""
    part = tmp_path / "r.mcap.part"
    shutil.copy(run_file, part)
    with part.open("r+b") as handle:
        handle.truncate(int(part.stat().st_size * kept))
    result = _load_or_ident_error(part)
    assert isinstance(result, (IdData, DataFileError)), repr(result)
    if isinstance(result, IdData):
        assert any("damaged" in note for note in result.notes), result.notes
    else:
        assert "run file" in str(result), result
