"""Text exports in every dialect a student's tools write load to the same numbers."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import ident
from ident.errors import DataFileError
from testkit.ident_synth import cart2_run

#: (separator, decimal comma, header) as spreadsheets and lab software write them
DIALECTS = {
    "comma": (",", False, "Time (s),Cart 1 position (m),Cart 2 position (m)"),
    "semicolon_decimal_comma": (";", True, "Time (s);Cart 1 position (m);Cart 2 position (m)"),
    "semicolon_point": (";", False, '"Time (s)";"Cart 1 position (m)";"Cart 2 position (m)"'),
    "tab_decimal_comma": ("\t", True, "Time (s)\tCart 1 position (m)\tCart 2 position (m)"),
    "tab_point": ("\t", False, "Time (s)\tCart 1 position (m)\tCart 2 position (m)"),
    "spaces_decimal_comma": ("   ", True, "Time (s)   Cart 1 position (m)   Cart 2 position (m)"),
    "spaces_point": ("   ", False, "Time (s)   Cart 1 position (m)   Cart 2 position (m)"),
}


def _write(path: Path, t: np.ndarray, y: np.ndarray, separator: str, comma: bool, header: str,
           ecp_rows: bool = False) -> None:
    def cell(v: float, digits: int) -> str:
        text = f"{v:.{digits}f}"
        return text.replace(".", ",") if comma else text

    rows = [separator.join([cell(a, 4), cell(b, 6), cell(c, 6)]) for a, b, c in zip(t, y[:, 0], y[:, 1], strict=True)]
    if ecp_rows:
        rows = [f"[ {rows[0]};", *(f"  {r};" for r in rows[1:-1]), f"  {rows[-1]}];"]
    path.write_text("# exported for the lab\n" + header + "\n" + "\n".join(rows) + "\n")


@pytest.mark.parametrize("dialect", sorted(DIALECTS))
@pytest.mark.parametrize("seed", [1, 2])
def test_every_dialect_loads_the_same_run(tmp_path: Path, dialect: str, seed: int) -> None:
    run = cart2_run(100.0 + 50.0 * seed, seed=seed, duration=4.0)
    separator, comma, header = DIALECTS[dialect]
    path = tmp_path / f"{dialect}.csv"
    _write(path, run.t, run.y, separator, comma, header)
    data = ident.load(path, pos_cols=["Cart 1", "Cart 2"])
    assert data.n_samples == run.t.size and data.n_outputs == 2
    assert np.allclose(data.t, run.t, atol=0.5e-4) and np.allclose(data.y, run.y, atol=0.5e-6)


def test_ecp_rows_with_brackets_and_row_ending_semicolons(tmp_path: Path) -> None:
    run = cart2_run(120.0, seed=3, duration=3.0)
    path = tmp_path / "ecp.txt"
    _write(path, run.t, run.y, "   ", False, "Time (s)   Cart 1 position (m)   Cart 2 position (m)", ecp_rows=True)
    data = ident.load(path, pos_cols=["Cart 1", "Cart 2"])
    assert np.allclose(data.y, run.y, atol=0.5e-6)


def test_a_bad_row_names_the_line_and_how_the_file_was_read(tmp_path: Path) -> None:
    path = tmp_path / "bad.csv"
    path.write_text("Time (s);Position (m)\n0,00;0,0\n0,01;0,1\n0,02;oops\n")
    with pytest.raises(DataFileError, match=r"line 4 \(read as semicolon-separated, decimal comma\)"):
        ident.load(path)
