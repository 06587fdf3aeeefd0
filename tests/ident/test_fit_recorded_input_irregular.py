"""`ident fit --input COL` on a record with an irregular clock (the ECP 2025 open-loop motor
pulses: 1 ms and 2 ms steps) fits on one uniform grid, the input resampled with the outputs.

The generated record is a cart on a spring driven by a force pulse (m x'' + c x' + k x = b u,
u a 0/1 pulse held between stamps), integrated exactly on a 1 ms grid and then stamped like
the Teensy: each step 1 ms (≈ 87 %) or 2 ms (≈ 13 %), one row per stamp.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm

from ident.cli import main
from ident.data import IdData
from ident.prediction_error import pem

COUNTS_PER_M = 56000.0


def _pulse_record(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, float]:
    """Stamps (s), encoder counts, control effort, and the true wn (rad/s) and zeta."""
    rng = np.random.default_rng(seed)
    m, k = rng.uniform(0.5, 1.5), rng.uniform(100.0, 600.0)
    zeta = rng.uniform(0.02, 0.1)
    wn = float(np.sqrt(k / m))
    a = np.array([[0.0, 1.0], [-wn ** 2, -2 * zeta * wn]])
    b = np.array([0.0, 0.02 * wn ** 2])        # a 2 cm static deflection per unit of input
    h = 1e-3
    phi = expm(np.block([[a, b[:, None]], [np.zeros((1, 3))]]) * h)  # exact zero-order hold
    n = 11000
    t_fine = h * np.arange(n)
    on, off = rng.uniform(2.0, 4.0), rng.uniform(6.0, 8.0)
    u_fine = ((t_fine >= on) & (t_fine < off)).astype(float)
    z = np.zeros(2)
    x = np.empty(n)
    for i in range(n):
        x[i] = z[0]
        z = phi[:2, :2] @ z + phi[:2, 2] * u_fine[i]
    steps = np.where(rng.random(n) < 0.13, 2, 1)
    keep = np.cumsum(steps)
    keep = np.concatenate([[0], keep[keep < n]])
    counts = np.round(x[keep] * COUNTS_PER_M + rng.normal(0.0, 1.0, keep.size))
    return t_fine[keep], counts, 491.0 * u_fine[keep], wn, zeta


def _write_tsv(path: Path, t: np.ndarray, counts: np.ndarray, effort: np.ndarray) -> Path:
    rows = [f"{i}\t{ti:.3f}\t{c:.0f}\t0\t{e:.0f}" for i, (ti, c, e) in enumerate(zip(t, counts, effort, strict=True))]
    path.write_text("Sample\tTime\tEncoder 1 Pos\tEncoder 2 Pos\tControl Effort\n" + "\n".join(rows) + "\n")
    return path


@pytest.mark.parametrize("seed", [3, 4])
def test_fit_with_a_recorded_input_on_an_irregular_clock(tmp_path: Path, seed: int,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    t, counts, effort, wn, zeta = _pulse_record(seed)
    assert np.ptp(np.diff(t)) > 0.5e-3          # the clock really is irregular
    path = _write_tsv(tmp_path / "pulse.txt", t, counts, effort)
    code = main(["fit", str(path), "--input", "Control Effort", "--scale", str(1 / COUNTS_PER_M),
                 "--json", "-q"])
    report = json.loads(capsys.readouterr().out)
    assert code == 0, report.get("reason")
    mode = report["pem"]["modes"][0]
    assert mode["wn_rad_s"] == pytest.approx(wn, rel=0.01)
    assert mode["zeta"] == pytest.approx(zeta, rel=0.1, abs=0.003)
    assert report["pem"]["fit_percent"][0] > 95.0


def test_fit_and_diagnose_the_real_motor_pulse_record(realdata_dir: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    path = realdata_dir / "ECP210_UCSD_2025_team1" / "07-Feb-2025_11_16_25.txt"
    if not path.exists():
        pytest.skip(f"{path.name} not present")
    options = ["--input", "Control Effort", "--scale", str(1 / COUNTS_PER_M), "--json"]
    assert main(["fit", str(path), *options, "-q"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["status"] != "failed"
    # the step-up and step-down responses differ: linear models stop near 88–93 % here
    assert 80.0 < report["pem"]["fit_percent"][0] < 97.0
    assert main(["diagnose", str(path), *options]) == 0
    diagnosis = json.loads(capsys.readouterr().out)
    assert np.isfinite(diagnosis["baseline"]["fit_percent"])


def test_pem_resamples_an_irregular_record_with_a_recorded_input_itself() -> None:
    # the same record straight into ident.pem: it fits on its own uniform grid (more samples
    # than stamps), and judges the fit on that grid
    t, counts, effort, wn, zeta = _pulse_record(5)
    model = pem(IdData(t, effort, (counts / COUNTS_PER_M)[:, None]), 2)
    assert model.success and model.stable
    assert model.modes[0].wn == pytest.approx(wn, rel=0.01)
    assert model.modes[0].zeta == pytest.approx(zeta, rel=0.1, abs=0.003)
