"""A long record driven by a force input keeps a work grid that resolves its modes
(`ident.diagnose.stretch.modes_resolved_cut`).

The record is drawn from the physics, independently of the code: a two-cart chain (exact
zero-order-hold steps of its state space, scipy's `cont2discrete`) driven on cart 1 by a train
of 4 s current pulses every 10 s for 50 s at 200 Hz, like the PoliMi rig's record. Decimated
to 500 work samples the whole record is a 10 Hz grid, under its ~6 Hz second mode."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from ident.diagnose import diagnose
from ident.diagnose.stretch import MIN_SAMPLES_PER_PERIOD, modes_resolved_cut

RATE = 200.0
M1, M2, K1, K2, K3, C = 0.99, 1.49, 617.0, 450.0, 150.0, 1.2


def _chain(pulses: int = 5) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = np.arange(int(10 * pulses * RATE)) / RATE
    u = np.where((t % 10.0 >= 5.0) & (t % 10.0 < 9.0), 3.0, 0.0)
    k = np.array([[K1 + K2, -K2], [-K2, K2 + K3]])
    m_inv = np.diag([1 / M1, 1 / M2])
    a = np.block([[np.zeros((2, 2)), np.eye(2)], [-m_inv @ k, -C * m_inv]])
    b = np.array([[0.0], [0.0], [-2.0 / M1], [0.0]])   # 2 N/A: 6 N, about 10 mm held
    phi, gamma, *_ = scipy.signal.cont2discrete((a, b, np.eye(4), np.zeros((4, 1))), 1 / RATE)
    x = np.zeros(4)
    y = np.empty((t.size, 2))
    for i in range(t.size):
        y[i] = x[:2]
        x = phi @ x + gamma[:, 0] * u[i]
    y += np.random.default_rng(5).normal(0.0, 1e-5, y.shape)
    return t, y, u


def _modes_rad_s() -> list[float]:
    """The chain's undamped natural frequencies (rad/s), low to high."""
    k = np.array([[K1 + K2, -K2], [-K2, K2 + K3]])
    return sorted(float(w) for w in np.sqrt(np.linalg.eigvals(np.diag([1 / M1, 1 / M2]) @ k).real))


def test_a_long_forced_record_is_cut_where_a_grid_that_resolves_its_modes_runs_out() -> None:
    _, y, _ = _chain()
    fastest_hz = _modes_rad_s()[-1] / 2 / np.pi
    kept, decimation = modes_resolved_cut(y, 1 / RATE, 2)
    assert kept is not None and kept < y.shape[0]
    assert RATE / decimation >= MIN_SAMPLES_PER_PERIOD * fastest_hz * 0.95
    assert decimation < int(np.ceil(y.shape[0] / 500))
    # a record short enough for its grid is kept whole
    assert modes_resolved_cut(y[:1800], 1 / RATE, 2)[0] is None


def test_a_long_forced_record_is_diagnosed_on_a_grid_that_resolves_its_modes() -> None:
    t, y, u = _chain()
    report = diagnose(t, y, 2, None, u=u).report
    assert report.validation.startswith("The record's first")
    assert report.baseline.fit_percent > 99.0   # linear carts: the linear chain fits to the noise
    assert report.cause == "none"
    wn = sorted(v for k, v in report.corrected_linear.items() if k.startswith("wn_mode"))
    assert wn == pytest.approx(_modes_rad_s(), rel=0.02)   # the second mode was aliased: 22 % low


def test_a_stretch_of_a_forced_record_is_chosen_on_the_command_line(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    """`--from-s` / `--to-s` pick the stretch of a forced record to diagnose (the third pulse
    here); without `--input` they are refused, naming `--release` for a hand release."""
    import json

    from ident.cli import main

    t, y, u = _chain()
    path = tmp_path / "pulses.csv"
    np.savetxt(path, np.column_stack([t, y, u]), delimiter=",", header="time_s,pos1_m,pos2_m,effort", comments="")
    assert main(["diagnose", str(path), "--input", "effort", "--from-s", "20", "--to-s", "32", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["validation"].startswith("The record from 20.000 s to 32.000 s, the measured")
    assert report["window_start_s"] == pytest.approx(20.0) and report["window_end_s"] == pytest.approx(32.0)
    assert report["baseline"]["fit_percent"] > 99.0
    assert main(["diagnose", str(path), "--from-s", "20"]) == 2
    assert "--release K" in capsys.readouterr().err
