"""A lab report of a one-cart case whose other cart is held by a hand: the diagnosis takes the
held cart's measured motion as an input (as `ident diagnose` does), and the report's notebook,
run beside its exported data, recomputes the same diagnosis (the held cart's positions are
exported after the fitted cart's, `held1_m`).

The run is drawn by the independent generator `testkit.effects`: cart 2 released with Coulomb
friction, cart 1 held by a hand that wanders; written as a text export."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from ident.commands.report import write_lab_report
from testkit.effects import make_case


@pytest.mark.timeout(300)
def test_a_held_carts_motion_enters_the_reports_diagnosis_and_its_notebook(tmp_path: Path) -> None:
    import nbformat
    from nbclient import NotebookClient

    case = make_case(3, "coulomb+held_cart")
    csv = tmp_path / "held.csv"
    np.savetxt(csv, np.column_stack([case.observed.t, case.observed.y]), delimiter=",",
               header="time_s,x1_m,x2_m", comments="", fmt="%.12g")
    out = tmp_path / "report"
    results = write_lab_report([csv], out, run_notebook=False)
    [result] = results
    diagnosis = result.report.diagnosis
    assert result.case == "cart2" and diagnosis is not None
    assert "held_cart_motion" in {e.effect for e in diagnosis.effects}
    header = (out / "data" / "cart2.csv").read_text().splitlines()[0]
    assert header == "time_s,u_m,x2_m,held1_m"
    notebook = nbformat.read(out / "report.ipynb", as_version=4)
    NotebookClient(notebook, timeout=240, kernel_name="python3",
                   resources={"metadata": {"path": str(out)}}).execute()
    numbers = json.loads(notebook.cells[-1].outputs[0]["text"])
    assert numbers["cart2"]["diagnosis"]["cause"] == diagnosis.cause
    assert numbers["cart2"]["diagnosis"]["gain"] == pytest.approx(diagnosis.gain_points, rel=1e-6)
