"""PEM flags an unstable estimate (a mode with zeta <= 0) instead of calling it converged.

A spring cart cannot have a pole on or right of the imaginary axis; when the fit lands there
(real motor-pulse records: a slow spurious mode soaks up what the linear model cannot
explain), the model says so: `stable` False, `success` False, a message naming the mode, and
a warning in `ident fit`'s text. Order selection keeps a stable order when there is one.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ident.cli import main
from ident.data import IdData
from ident.io import load
from ident.prediction_error import pem

ECP_MOTOR_PULSE = Path("ECP210_UCSD_2025_team1") / "07-Feb-2025_11_21_31.txt"
COUNTS_PER_M = 56000.0


def _second_order_step(zeta: float, seed: int) -> IdData:
    """x'' + 2ζwn x' + wn² (x - U H(t - 1)) = 0 at 100 Hz, exact, with 0.1 mm noise (ζ < 0 grows)."""
    wn, amp = 8.0, 0.1
    t = np.arange(0.0, 6.0, 0.01)
    tau = np.maximum(t - 1.0, 0.0)
    sigma, wd = zeta * wn, wn * np.sqrt(1.0 - zeta ** 2)
    x = amp * (1.0 - np.exp(-sigma * tau) * (np.cos(wd * tau) + sigma / wd * np.sin(wd * tau)))
    y = x + np.random.default_rng(seed).normal(0.0, 1e-4, t.size)
    return IdData(t, np.where(t >= 1.0, 1.0, 0.0), y[:, None])


def test_a_growing_oscillation_is_flagged_unstable_not_converged() -> None:
    model = pem(_second_order_step(-0.02, 1), 2)
    assert model.modes[0].zeta == pytest.approx(-0.02, abs=2e-3)
    assert not model.stable and model.unstable_modes == (0,)
    assert not model.success
    assert "unstable estimate" in model.message and "mode 1" in model.message


def test_a_damped_cart_stays_stable_and_converged() -> None:
    model = pem(_second_order_step(0.02, 2), 2)
    assert model.modes[0].zeta == pytest.approx(0.02, abs=2e-3)
    assert model.stable and model.success and model.unstable_modes == ()


def test_ident_fit_prints_a_warning_for_an_unstable_estimate(tmp_path: Path,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    data = _second_order_step(-0.02, 3)
    path = tmp_path / "growing.csv"
    rows = "\n".join(f"{float(t)!r},{float(y)!r}" for t, y in zip(data.t, data.y[:, 0], strict=True))
    path.write_text("time_s,pos1_m\n" + rows + "\n")
    assert main(["fit", str(path), "--method", "pem"]) == 0
    out = capsys.readouterr().out
    assert "NOT CONVERGED" in out and "WARNING: unstable estimate" in out


@pytest.mark.slow
def test_real_motor_pulse_order_6_is_flagged_and_order_selection_keeps_a_stable_order(realdata_dir: Path) -> None:
    path = realdata_dir / ECP_MOTOR_PULSE
    if not path.is_file():
        pytest.skip(f"{ECP_MOTOR_PULSE} not present")
    data = load(path, time_col="Time", pos_cols=["Encoder 1 Pos"], scale=1.0 / COUNTS_PER_M,
                input_col="Control Effort")
    six = pem(data, 6)
    assert not six.stable and not six.success
    assert all(six.modes[i].zeta <= 0.0 for i in six.unstable_modes)
    chosen = pem(data, None)
    assert chosen.stable and chosen.success
