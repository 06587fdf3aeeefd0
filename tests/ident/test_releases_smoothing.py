"""The release finder's derivative smoothing (`ident.releases.motion.smoothing_window`): a tenth of
a period, longer where the encoder's noise would hide a releasing hand."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import savgol_filter

from ident.releases.motion import ACCEL_NOISE_FRACTION, MAX_SMOOTHING_FRACTION, SMOOTHING_FRACTION, motion

RATE_HZ = 260.0
WN = 17.75          # rad/s
AMPLITUDE_M = 0.03


def _ring(noise_m: float, lattice_m: float | None, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t, readings, the positions before the encoder)."""
    rng = np.random.default_rng(seed)
    t = np.arange(round(6.0 * RATE_HZ)) / RATE_HZ
    clean = AMPLITUDE_M * np.exp(-0.2 * t) * np.cos(WN * t)
    y = clean + rng.normal(0.0, noise_m, t.size)
    if lattice_m is not None:
        y = lattice_m * np.round(y / lattice_m)
    return t, y, clean


def _samples(fraction: float) -> int:
    return max(5, 2 * round(fraction * 2.0 * np.pi / WN * RATE_HZ / 2) + 1)


def test_a_quiet_encoder_keeps_a_tenth_of_a_period() -> None:
    t, y, _ = _ring(10e-6, None, 1)
    assert motion(t, y).window == _samples(SMOOTHING_FRACTION)


@pytest.mark.parametrize("seed", [2, 3, 4])
def test_a_coarse_noisy_lattice_smooths_until_a_hand_would_show(seed: int) -> None:
    """A 2 mm lattice with 0.6 mm of noise before it (the red team's `quantization_edges`): over a
    tenth of a period the acceleration's noise is ~0.6 of the swing's ω²A; the window grows
    until, on the noise alone, it is within `ACCEL_NOISE_FRACTION` of it (or reaches the cap)."""
    t, y, clean = _ring(0.6e-3, 2e-3, seed)
    m = motion(t, y)
    assert _samples(SMOOTHING_FRACTION) < m.window <= _samples(MAX_SMOOTHING_FRACTION)
    swing = (2.0 * np.pi / m.period_s) ** 2 * AMPLITUDE_M

    def accel_noise(window: int) -> float:   # the smoothed acceleration's error, measured
        err = savgol_filter(y - clean, window, 3, deriv=2, delta=1.0 / RATE_HZ)
        return float(np.std(err[window:-window]))

    if m.window < _samples(MAX_SMOOTHING_FRACTION):
        assert accel_noise(m.window) <= 1.25 * ACCEL_NOISE_FRACTION * swing, (accel_noise(m.window), swing)
    assert accel_noise(_samples(SMOOTHING_FRACTION)) > 3.0 * ACCEL_NOISE_FRACTION * swing


def test_a_coarse_rate_keeps_a_tenth_of_a_period() -> None:
    """At 50 Hz an 18 µm encoder's second differences hold the swing's curvature (~0.4 mm of
    "noise"): that is no reason to smooth longer."""
    t = np.arange(round(8.0 * 50.0)) / 50.0
    y = 1.0 / 56000.0 * np.round(0.05 * np.exp(-0.1 * t) * np.cos(6.5 * t) * 56000.0)
    period_samples = 2.0 * np.pi / 6.5 * 50.0
    assert motion(t, y).window == max(5, 2 * round(SMOOTHING_FRACTION * period_samples / 2) + 1)
