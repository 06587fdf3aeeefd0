"""The shared measures of `ident.physics.measures` (fit %, noise, spectral peaks) against
values known from how the signals were made."""

from __future__ import annotations

import numpy as np
import pytest

from ident.errors import IdentDimensionError
from ident.physics.measures import fit_percent, noise_std, spectral_peaks

DT = 0.005
T = DT * np.arange(4000, dtype=np.float64)


def test_fit_percent_is_100_for_the_truth_0_for_the_mean_and_minus_inf_for_a_still_output() -> None:
    y = np.column_stack([np.sin(3 * T), np.zeros_like(T)])
    assert fit_percent(y, y)[0] == 100.0
    assert fit_percent(y[:, 0], np.full(T.size, y[:, 0].mean()))[0] == pytest.approx(0.0, abs=1e-12)
    assert fit_percent(y, y)[1] == -np.inf
    half = y[:, 0] + 0.5 * (y[:, 0] - y[:, 0].mean())            # error = half the spread
    assert fit_percent(y[:, 0], half)[0] == pytest.approx(50.0)
    with pytest.raises(IdentDimensionError):
        fit_percent(y, y[:, :1])


@pytest.mark.parametrize("sigma", [3e-4, 1e-3])
def test_noise_std_of_white_noise_on_a_smooth_ring(sigma: float) -> None:
    # the ring's own second difference (≤ 0.05·81·DT² = 1e-4 m) is below the noise's σ√6 here:
    # where it is not, the estimate measures the motion (a known limit, not tested)
    rng = np.random.default_rng(4)
    clean = 0.05 * np.exp(-0.2 * T) * np.cos(9.0 * T)
    y = clean + sigma * rng.standard_normal(T.size)
    assert noise_std(y)[0] == pytest.approx(sigma, rel=0.06)


def test_noise_std_from_fourth_differences_sees_through_a_ring_read_slowly() -> None:
    # a hold of 2 s, then a 2.16 Hz ring decaying at 0.54 /s to the record's end, read at 50 Hz
    # (red team coupled_pinned 9800's main mode): its second difference (7 % of the swing)
    # sets the median of the second differences; the fourth (0.5 %) leaves the noise
    rng = np.random.default_rng(9)
    t = np.arange(0.0, 9.6, 0.02)
    sigma = 1e-5
    tau = np.maximum(t - 2.0, 0.0)
    y = -0.12 * np.exp(-0.54 * tau) * np.cos(2 * np.pi * 2.16 * tau) + sigma * rng.standard_normal(t.size)
    assert noise_std(y)[0] > 10 * sigma
    assert sigma < noise_std(y, order=4)[0] < 2.0 * sigma   # 1.3-1.5 sigma: the ring still shows a little
    white = sigma * rng.standard_normal(4000)
    assert noise_std(white, order=4)[0] == pytest.approx(sigma, rel=0.06)


def test_spectral_peaks_finds_two_rings_and_fill_band_and_exclusion_behave() -> None:
    y = 0.03 * np.exp(-0.1 * T) * np.sin(7.0 * T) + 0.01 * np.exp(-0.2 * T) * np.sin(19.0 * T)
    assert spectral_peaks(y, DT, 2) == pytest.approx([7.0, 19.0], rel=5e-3)
    assert spectral_peaks(y, DT, 1) == pytest.approx([7.0], rel=5e-3)          # the stronger
    assert spectral_peaks(y, DT, 1, max_rad_s=15.0) == pytest.approx([7.0], rel=5e-3)
    assert spectral_peaks(y, DT, 1, min_rad_s=10.0) == pytest.approx([19.0], rel=5e-3)
    assert spectral_peaks(y, DT, 1, exclude=np.array([7.0])) == pytest.approx([19.0], rel=5e-3)
    one = 0.03 * np.exp(-0.3 * T) * np.sin(7.0 * T)        # a ring: no window side lobes
    # in a band that holds one maximum (the window's ripple, 1e-7 of the peak's power and
    # below, lies outside it), fill=False says so; the default pads with a guess (twice the
    # highest) for callers that need `count` values
    assert spectral_peaks(one, DT, 2, min_rad_s=5.0, max_rad_s=30.0, fill=False) == pytest.approx([7.0], rel=5e-3)
    assert spectral_peaks(one, DT, 2, min_rad_s=5.0, max_rad_s=30.0) == pytest.approx([7.0, 14.0], rel=5e-3)
