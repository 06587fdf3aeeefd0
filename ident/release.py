"""Start values from the data: release time, rest level, noise level, motion check.

These are estimates for starting a fit, not results: every fitter refines the release
time as a continuous parameter. Pure numpy; time-major arrays (see `ident.data`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ident.errors import IdentValueError
from ident.physics.measures import noise_std

FloatArray = NDArray[np.float64]

#: The motion after a release must exceed this many noise standard deviations.
MIN_MOTION_SIGMAS = 20.0


def rest_window(n: int) -> slice:
    """The first samples, taken as the rest before the release (5 %, at least 5)."""
    return slice(0, max(5, n // 20))


def motion_amplitude(y: FloatArray) -> FloatArray:
    """Per-output largest deviation from the rest level, shape (n_out,)."""
    y2 = np.asarray(y, dtype=np.float64).reshape(len(y), -1)
    rest = np.median(y2[rest_window(len(y2))], axis=0)
    return np.asarray(np.max(np.abs(y2 - rest), axis=0))


def check_motion(y: FloatArray) -> None:
    """Raise `IdentValueError` when no output moves clearly above its noise."""
    y2 = np.asarray(y, dtype=np.float64).reshape(len(y), -1)
    amplitude = motion_amplitude(y2)
    sigma = noise_std(y2)
    ratio = float(np.max(amplitude / sigma))
    quantum = _quantum(y2)
    if ratio < MIN_MOTION_SIGMAS or float(np.max(amplitude)) <= 3.0 * quantum:
        raise IdentValueError(
            "y", f"motion after a release (largest deviation ≥ {MIN_MOTION_SIGMAS:g} noise std)",
            f"largest deviation {float(np.max(amplitude)):.3g} m with noise std "
            f"{float(np.min(sigma)):.3g} m (no motion)")


def moving_outputs(y: FloatArray) -> list[int]:
    """Indices of the outputs that move clearly (≥ 20 noise std and > 3 quanta): a pinned
    cart's encoder reads a constant and is not one of them."""
    y2 = np.asarray(y, dtype=np.float64).reshape(len(y), -1)
    amplitude = motion_amplitude(y2)
    sigma = noise_std(y2)
    return [j for j in range(y2.shape[1])
            if amplitude[j] >= MIN_MOTION_SIGMAS * sigma[j] and amplitude[j] > 3.0 * _quantum(y2[:, [j]])]


def _quantum(y: FloatArray) -> float:
    """Smallest non-zero step between consecutive samples (0 when there is none)."""
    steps = np.abs(np.diff(y, axis=0)).ravel()
    steps = steps[steps > 0]
    return float(np.min(steps)) if steps.size else 0.0


def estimate_release_time(t: FloatArray, y: FloatArray) -> float:
    """Estimate the release instant (s) from the onset of the motion.

    After a clean release the displacement grows as `c·τ²` (relative degree 2). For each
    output, find the interpolated crossing times t1, t2 of the thresholds L and 4L
    (L = max(6σ, 2 % of the motion)); `τ ∝ √level` gives `t_r = t1 - (t2 - t1)`. The earliest
    estimate over outputs is returned (a cart coupled through a spring starts later).
    """
    t_arr = np.asarray(t, dtype=np.float64)
    y2 = np.asarray(y, dtype=np.float64).reshape(len(t_arr), -1)
    check_motion(y2)
    sigma = noise_std(y2)
    amplitude = motion_amplitude(y2)
    rest = np.median(y2[rest_window(len(y2))], axis=0)
    estimates = []
    for j in range(y2.shape[1]):
        if amplitude[j] < MIN_MOTION_SIGMAS * sigma[j]:
            continue
        level = max(6.0 * sigma[j], 0.02 * amplitude[j])
        deviation = np.abs(y2[:, j] - rest[j])
        t1 = _first_crossing(t_arr, deviation, level)
        t2 = _first_crossing(t_arr, deviation, 4.0 * level)
        estimates.append(t1 - (t2 - t1))
    estimate = min(estimates)
    if estimate <= t_arr[1]:
        raise IdentValueError("y", "rest before the release (the release inside the record)",
                              f"motion from the first samples (onset estimated at {estimate:.4g} s)")
    return float(min(estimate, t_arr[-1]))


def _first_crossing(t: FloatArray, deviation: FloatArray, level: float) -> float:
    above = np.flatnonzero(deviation >= level)
    k = int(above[0])
    if k == 0:
        return float(t[0])
    d0, d1 = deviation[k - 1], deviation[k]
    return float(t[k - 1] + (t[k] - t[k - 1]) * (level - d0) / (d1 - d0))
