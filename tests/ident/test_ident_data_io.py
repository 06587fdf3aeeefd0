"""`IdData` validation, uniform sampling, step input and the loaders (text exports, MCAP)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ident.data import IdData, check_arrays, from_release, make_uniform, step_input
from ident.errors import DataFileError, IdentDimensionError, IdentValueError
from ident.io import load, read_table
from ident.releases import with_found_release
from testkit.ident_synth import cart1_run, cart2_run
from testkit.mcap_runs import write_mcap_run

T = np.arange(0.0, 2.0, 0.02)
Y = np.sin(T)


@pytest.mark.parametrize(("t", "u", "y", "match"), [
    (T, None, np.where(T > 1, np.nan, Y), r"y: expected finite values, got \[nan\] at sample 51"),
    (T, np.full(T.size, np.inf), Y, "u: expected finite values"),
    (T[:5], None, Y[:5], "number of samples: expected at least 20, got 5"),
    (T, None, np.vstack([Y, Y]), r"y: expected time-major shape \(100,\) or \(100, n_outputs\), got shape \(2, 100\)"),
    (T, np.zeros(99), Y, r"u: expected one input of shape \(100,\)"),
    (T.reshape(10, 10), None, Y, "t: expected a 1-D array"),
    (np.concatenate([T[:50], T[49:99]]), None, Y, "duplicate time at index 50"),
    (T[::-1].copy(), None, Y, "decreasing time at index 1"),
])
def test_bad_arrays_get_errors_naming_the_problem(t: np.ndarray, u: np.ndarray | None,
                                                  y: np.ndarray, match: str) -> None:
    with pytest.raises(IdentValueError, match=match):
        IdData(t, u, y)


def test_shapes_are_normalised_and_frozen() -> None:
    data = IdData(T, np.zeros((T.size, 1)), Y)
    assert data.u.shape == (100,) and data.y.shape == (100, 1) and data.n_outputs == 1
    with pytest.raises(ValueError):
        data.y[0, 0] = 1.0
    assert isinstance(IdentDimensionError("a", "b", "c"), ValueError)
    _t, u, y = check_arrays(T, None, np.column_stack([Y, Y]))
    assert y.shape == (100, 2) and not np.any(u)


def test_step_input_keeps_the_release_between_samples() -> None:
    u = step_input(T, 0.513, 0.15)
    assert u[25] == 0.0 and u[26] == 0.15  # 0.50 < 0.513 ≤ 0.52
    data = IdData(T, u, Y, release_time_s=0.513)
    assert data.release_time_s == 0.513 and data.step_time() == pytest.approx(0.52)


def test_rounded_time_stamps_become_the_grid_and_gaps_are_interpolated() -> None:
    ts = 0.0088541
    t = np.round(np.arange(677) * ts, 3)  # an ECP export: 3 printed decimals
    data = IdData(t, None, np.sin(3 * t))
    assert data.is_uniform()
    grid = make_uniform(data)
    assert np.allclose(np.diff(grid.t), ts, rtol=1e-4) and "least-squares grid" in grid.notes[-1]
    keep = np.ones(T.size, bool)
    keep[40:45] = False  # five lost samples
    gappy = IdData(T[keep], None, np.sin(T[keep]))
    assert not gappy.is_uniform()
    fixed = make_uniform(gappy)
    assert fixed.n_samples == T.size and "linear interpolation" in fixed.notes[-1]
    assert np.max(np.abs(fixed.y[:, 0] - np.sin(fixed.t))) < 2e-3


def test_release_time_found_in_the_data_is_close_enough_to_start_a_fit() -> None:
    # a run that starts while the hand holds the cart still: the release finder places the step
    for run in (cart1_run(50.0), cart2_run(200.0)):
        data = with_found_release(run.t, run.y)
        assert data.release_time_s is not None and abs(data.release_time_s - run.release_time_s) < 0.01
        assert data.pulled_cart == 1 and "release time found in the data" in data.notes[-1]


def test_a_release_step_needs_a_release_time() -> None:
    run = cart1_run(50.0)
    with pytest.raises(IdentValueError, match="with_found_release"):
        from_release(run.t, run.y, None)


def test_a_record_without_a_release_is_refused_when_no_release_time_is_known() -> None:
    t = np.arange(0.0, 5.0, 0.01)
    with pytest.raises(IdentValueError, match="release"):
        with_found_release(t, np.zeros((t.size, 2)))


def test_our_csv_needs_no_options(tmp_path: Path) -> None:
    run = cart2_run(50.0)
    path = tmp_path / "run.csv"
    rows = "\n".join(f"{a:.6f},{b:.7f},{c:.7f}" for a, b, c in zip(run.t, run.y[:, 0], run.y[:, 1], strict=True))
    path.write_text("time_s,pos1_m,pos2_m\n" + rows + "\n")
    data = load(path)
    assert data.n_outputs == 2 and data.y[:, 1] == pytest.approx(run.y[:, 1], abs=1e-6)
    # no release time in the file: the release finder places the step
    assert data.release_time_s == pytest.approx(run.release_time_s, abs=0.01)
    assert "found in the data" in data.notes[0]
    assert abs(data.step_time() - run.release_time_s) < 0.03  # type: ignore[operator]


def test_logger_pro_csv_with_quotes_and_centimetres(tmp_path: Path) -> None:
    path = tmp_path / "lp.csv"
    body = "\n".join(f"{t:.3f},{100 * y:.4f}" for t, y in zip(T, 0.1 * (T > 0.5) * np.sin(9 * T), strict=True))
    path.write_text('"Latest: Time (s)","Latest: Position (cm)"\n' + body + "\n")
    data = load(path)
    assert data.y[:, 0] == pytest.approx(0.1 * (T > 0.5) * np.sin(9 * T), abs=1e-6)


ECP = """ Sample   Time     Commanded Pos   Encoder 1 Pos   Encoder 2 Pos   Control Effort

[    0    0.000               0               0               0          0.0000;
{rows}
]
"""


def test_ecp_tsv_with_brackets_column_names_and_scale(tmp_path: Path) -> None:
    run = cart2_run(113.0, duration=4.0)
    counts = np.round(run.y / 1e-5)
    rows = "\n".join(f"   {i}    {t:.3f}   0   {int(a)}   {int(b)}   0.0000;"
                     for i, (t, a, b) in enumerate(zip(run.t[1:], counts[1:, 0], counts[1:, 1], strict=True), 1))
    path = tmp_path / "DOF2.csv"
    path.write_text(ECP.format(rows=rows))
    table = read_table(path.read_text())
    assert table.names[:4] == ["Sample", "Time", "Commanded Pos", "Encoder 1 Pos"]
    with pytest.raises(IdentValueError, match="scale of column 'Encoder 2 Pos'"):
        load(path, pos_cols=["Encoder 2"])
    data = load(path, time_col="Time", pos_cols=["Encoder 2", "Encoder 1"], scale=1e-5)
    assert data.y[1:, 0] == pytest.approx(counts[1:, 1] * 1e-5) and data.y[0, 0] == 0.0
    with pytest.raises(IdentValueError, match="exactly one column matching 'Encoder'"):
        load(path, pos_cols=["Encoder"], scale=1e-5)


def test_unreadable_files_are_data_file_errors(tmp_path: Path) -> None:
    with pytest.raises(DataFileError, match="existing file"):
        load(tmp_path / "nope.csv")
    empty = tmp_path / "empty.csv"
    empty.write_text("time_s,pos1_m\n\n")
    with pytest.raises(DataFileError, match="numeric rows"):
        load(empty)




def test_mcap_run_gives_release_time_and_pulled_cart_from_metadata(tmp_path: Path) -> None:
    run = cart1_run(200.0)
    first = 5_000_000_000
    t_ns = [first + round(x * 1e9) for x in run.t]
    path = tmp_path / "r1.mcap"
    write_mcap_run(path, t_ns, [float(v) for v in run.y[:, 0]], run.release_time_s)
    data = load(path)
    assert data.release_time_s == run.release_time_s and data.pulled_cart == 1
    assert data.t[0] == 0.0 and data.t[-1] == pytest.approx(run.t[-1])
    assert data.y[:, 0] == pytest.approx(run.y[:, 0])
    assert data.step_amplitude == 0.15
    truncated = tmp_path / "cut.mcap"
    truncated.write_bytes(path.read_bytes()[: len(path.read_bytes()) // 2])
    partial = load(truncated, release_time_s=run.release_time_s)
    assert 0 < partial.n_samples < data.n_samples


@pytest.mark.parametrize("bad", ["nan", "inf", "abc", "0.1.2"])
def test_a_non_numeric_data_row_is_named_not_skipped(tmp_path: Path, bad: str) -> None:
    rows = [f"{t:.2f},{np.sin(t):.5f}" for t in T]
    rows[30] = f"0.60,{bad}"
    path = tmp_path / "bad.csv"
    path.write_text("time_s,pos1_m\n" + "\n".join(rows) + "\n")
    with pytest.raises(DataFileError, match=f"expected numbers in every data row, got '0.60,{bad}' in line 32"):
        load(path, raw=True)


def test_positions_beyond_a_lab_track_are_a_scale_error(tmp_path: Path) -> None:
    run = cart1_run(50.0)
    path = tmp_path / "counts.csv"
    rows = "\n".join(f"{t:.3f},{y * 1e6:.1f}" for t, y in zip(run.t, run.y[:, 0], strict=True))
    path.write_text("time_s,pos1_m\n" + rows + "\n")  # counts written as if they were metres
    with pytest.raises(IdentValueError, match=r"position amplitude: expected \|position\| ≤ 10 m .*got \d.\d+e\+05 m"):
        load(path, raw=True)


def test_a_damaged_run_file_loads_up_to_the_damage_and_says_so(tmp_path: Path) -> None:
    run = cart1_run(200.0)
    t_ns = [round(x * 1e9) for x in run.t]
    path = tmp_path / "r1.mcap"
    write_mcap_run(path, t_ns, [float(v) for v in run.y[:, 0]], run.release_time_s)
    blob = bytearray(path.read_bytes())
    blob[len(blob) // 2: len(blob) // 2 + 64] = bytes(64)  # zero a stretch inside a chunk
    damaged = tmp_path / "damaged.mcap"
    damaged.write_bytes(bytes(blob))
    data = load(damaged, release_time_s=run.release_time_s)
    assert 0 < data.n_samples < run.t.size
    assert "damaged after" in data.notes[-1]
    for size in (1, 9, 20):
        cut = tmp_path / f"cut{size}.mcap"
        cut.write_bytes(bytes(blob[:size]))
        with pytest.raises(DataFileError, match="expected /samples samples"):
            load(cut)


def test_an_export_without_header_or_time_column_takes_a_sample_rate(tmp_path: Path) -> None:
    path = tmp_path / "data0000.txt"  # PoliScope-like: tab-separated numbers only
    path.write_text("\n".join(f"{0.1 * k:.3f}\t{np.sin(k / 10):.6f}" for k in range(100)) + "\n")
    with pytest.raises(IdentValueError, match="time column"):
        load(path, pos_cols=["col1"], scale=0.01)
    data = load(path, pos_cols=["col1"], scale=0.01, input_col="col0", rate_hz=200.0)
    assert data.sample_time() == pytest.approx(0.005) and data.t[0] == 0.0
    assert data.u[10] == pytest.approx(1.0) and data.y[5, 0] == pytest.approx(0.01 * np.sin(0.5), abs=1e-8)


def _cart_columns() -> tuple[np.ndarray, np.ndarray]:
    run = cart1_run(13.0, duration=2.0)
    return run.t, run.y[:, 0]


@pytest.mark.parametrize(("header", "sep", "unit", "comma"), [
    ("Time [s],Position 1 [mm]", ",", 1e-3, False),         # a unit in brackets (spreadsheets, LabVIEW)
    ("# time_s,pos1_m", ",", 1.0, False),                    # numpy's savetxt header
    ("% time_s pos1_cm", " ", 1e-2, False),                   # MATLAB/Octave's commented header
    ("time_s pos1_mm", " ", 1e-3, False),                     # a whitespace file's names split by one space
    ("Zeit [s];Position [mm]", ";", 1e-3, True),              # a decimal-comma locale, units in brackets
])
def test_headers_as_lab_tools_write_them_name_the_columns_and_units(tmp_path: Path, header: str, sep: str,
                                                                     unit: float, comma: bool) -> None:
    t, y = _cart_columns()
    rows = [f"{a:.4f}{sep}{b / unit:.6f}" for a, b in zip(t, y, strict=True)]
    path = tmp_path / "export.txt"
    path.write_text(header + "\n" + "\n".join(r.replace(".", ",") if comma else r for r in rows) + "\n")
    # names no default finds (German, two position-like words) are named by the user
    data = load(path, time_col="Zeit" if "Zeit" in header else None,
                pos_cols=["pos"] if "Position" in header else None, raw=True)
    assert data.y[:, 0] == pytest.approx(y, abs=2e-6 * (1 + unit * 1e3))
    assert data.t == pytest.approx(t, abs=1e-4)


def test_unnamed_columns_are_refused_with_how_to_name_them(tmp_path: Path) -> None:
    t, y = _cart_columns()
    path = tmp_path / "bare.csv"
    path.write_text("\n".join(f"{a:.4f},{b:.6f}" for a, b in zip(t, y, strict=True)) + "\n")
    with pytest.raises(IdentValueError, match=r"in \['col0', 'col1'\] \(name them with --pos COLUMN"):
        load(path, raw=True)
    with pytest.raises(IdentValueError, match=r"name it with --time COLUMN; a file without one: --rate HZ"):
        load(path, pos_cols=["col1"], scale=1.0, raw=True)
    assert load(path, time_col="col0", pos_cols=["col1"], scale=1.0, raw=True).y[:, 0] == pytest.approx(y, abs=1e-6)


def test_a_logger_pro_export_of_two_runs_of_unequal_length_loads_either_run(tmp_path: Path) -> None:
    """Logger Pro stores each run as a data set (a time and a position column); a shorter
    run's cells are empty after its end. Chosen by name, each run loads up to its own end; by
    default the loader refuses to read the two runs' positions as two carts."""
    first, second = cart1_run(13.0, duration=3.0), cart1_run(14.0, duration=2.0)
    rows = []
    for k in range(first.t.size):
        later = f"{second.t[k]:.4f},{second.y[k, 0]:.6f}" if k < second.t.size else ","
        rows.append(f"{first.t[k]:.4f},{first.y[k, 0]:.6f},{later}")
    path = tmp_path / "two_runs.csv"
    path.write_text('"Run 1: Time (s)","Run 1: Position (m)","Run 2: Time (s)","Run 2: Position (m)"\n'
                    + "\n".join(rows) + "\n")
    with pytest.raises(IdentValueError, match=r"choose one, e\.g\. --time 'Run 1: Time \(s\)' --pos 'Run 1: "
                                              r"Position \(m\)', got 2 data sets"):
        load(path, raw=True)
    one = load(path, time_col="Run 1: Time", pos_cols=["Run 1: Pos"], raw=True)
    two = load(path, time_col="Run 2: Time", pos_cols=["Run 2: Pos"], raw=True)
    assert one.y[:, 0] == pytest.approx(first.y[:, 0], abs=1e-6) and one.t.size == first.t.size
    assert two.y[:, 0] == pytest.approx(second.y[:, 0], abs=1e-6) and two.t.size == second.t.size
    # a data set that goes on after a gap is no shorter run: an error, not data dropped
    path.write_text("time_s,pos1_m\n0.0,0.1\n0.1,\n0.2,0.3\n")
    with pytest.raises(DataFileError, match=r"got one missing in line 3 and values again in line 4"):
        load(path, raw=True)


def test_the_numbers_of_a_headerless_files_columns_are_no_cart_numbers(tmp_path: Path) -> None:
    """A file without a header names its columns col0, col1, ... (the PoliMi logger's chunks):
    x1 and x2 in col3 and col5 are carts 1 and 2, not 3 and 5; a named column keeps its cart."""
    path = tmp_path / "chunk.txt"
    ring = 0.5 * np.sin(np.arange(400) / 200.0 * 2 * np.pi * 1.5)
    np.savetxt(path, np.column_stack([ring * k for k in range(1, 7)]), delimiter="\t")
    data = load(path, rate_hz=200.0, pos_cols=["col3", "col5"], scale=0.01, raw=True)
    assert data.cart_numbers() == (1, 2)
    named = IdData(data.t, data.u, data.y[:, :1], columns=("Encoder 2 Pos",))
    assert named.cart_numbers() == (2,)


def test_an_input_on_at_the_first_sample_is_shown_acting_from_there() -> None:
    # a drive already on as the record starts (the 2023 open-loop test4): the models take it from
    # the first sample (`input_jumps`), and the summary said only "first change at 3 s"
    t = 0.01 * np.arange(600)
    u = np.where(t < 3.0, 0.5, -0.5)
    summary = repr(IdData(t, u, np.sin(t)))
    assert "on at the first sample (0.5: acting from there), first change at 3 s" in summary
    off = repr(IdData(t, np.where(t < 3.0, 0.0, 0.5), np.sin(t)))
    assert "on at the first sample" not in off and "step of 0.5 at 3 s" in off
