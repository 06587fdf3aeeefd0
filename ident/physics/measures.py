"""The measures every part of ident shares: fit %, the noise level, the encoder's count,
spectral peaks.

One definition each, so that `compare`, the simple identification, PEM and the diagnosis
agree on edge cases. Pure numpy, time-major arrays; no fitting and no I/O here.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ident.errors import IdentDimensionError

FloatArray = NDArray[np.float64]


def fit_percent(y: FloatArray, y_hat: FloatArray) -> list[float]:
    """MATLAB `compare` fit % per output column: 100 (1 - |y - ŷ| / |y - mean y|).

    `y`, `y_hat` time-major (N,) or (N, n_out); an output that never moves (|y - mean y| = 0)
    gets -inf (no fit can be judged), never NaN.
    """
    y2 = np.asarray(y, dtype=np.float64).reshape(len(y), -1)
    y_hat2 = np.asarray(y_hat, dtype=np.float64).reshape(len(y_hat), -1)
    if y2.shape != y_hat2.shape:
        raise IdentDimensionError("y_hat", f"shape {y2.shape}", f"shape {y_hat2.shape}")
    spread = np.linalg.norm(y2 - y2.mean(axis=0), axis=0)
    error = np.linalg.norm(y2 - y_hat2, axis=0)
    return [float(100.0 * (1.0 - e / s)) if s > 0 else float("-inf") for e, s in zip(error, spread, strict=True)]


def noise_std(y: FloatArray, order: int = 2) -> FloatArray:
    """Per-column white-noise std (m) of a record or a residual, shape (n_out,).

    From differences of `order` (2 by default), robustly: for white noise of std σ, the
    second difference `y[k+1] - 2y[k] + y[k-1]` has std σ·√6 (the k-th: σ·√C(2k, k)); the
    median absolute value (÷0.6745) ignores the samples where the motion's own curvature
    dominates (a smooth motion sampled fast has tiny second differences). A cart that rings
    through most of a record read at a low rate has no such samples: at 50 Hz a 2.2 Hz ring's
    second difference is 7 % of its swing, the fourth 0.5 % (red team `coupled_pinned` 9800:
    236 µm from second differences, 14 µm from fourth, ~12 µm of reading noise).
    Floored at 1e-12.
    """
    y2 = np.asarray(y, dtype=np.float64).reshape(len(y), -1)
    if y2.shape[0] < order + 1:
        raise IdentDimensionError("y", f"at least {order + 1} samples", y2.shape[0])
    diff = np.diff(y2, n=order, axis=0)
    sigma = np.median(np.abs(diff), axis=0) / 0.6745 / np.sqrt(float(math.comb(2 * order, order)))
    return np.asarray(np.maximum(sigma, 1e-12), dtype=np.float64)


def encoder_quantum(y: FloatArray) -> float:
    """The encoder's count (m): the smallest non-zero step between consecutive samples of `y`
    (N,) or (N, n), over all columns; 0 when nothing moves. Steps below 1e-12 of the largest
    |y| are rounding of the scale, not counts."""
    y2 = np.asarray(y, dtype=np.float64)
    steps = np.abs(np.diff(y2, axis=0)).ravel()
    steps = steps[steps > 1e-12 * max(float(np.max(np.abs(y2))) if y2.size else 0.0, 1e-300)]
    return float(np.min(steps)) if steps.size else 0.0


def spectrum(y: FloatArray, dt: float, pad: int = 8) -> tuple[FloatArray, FloatArray]:
    """One-sided Hann-windowed power spectrum summed over outputs: (ω rad/s, power)."""
    y2 = y.reshape(y.shape[0], -1)
    n = y2.shape[0]
    win = np.hanning(n)[:, None]
    nfft = int(2 ** np.ceil(np.log2(n * pad)))
    spec = np.abs(np.fft.rfft((y2 - y2.mean(axis=0)) * win, n=nfft, axis=0)) ** 2
    freqs = np.asarray(2 * np.pi * np.fft.rfftfreq(nfft, dt), dtype=np.float64)
    return freqs, np.asarray(spec.sum(axis=1), dtype=np.float64)


def spectral_peaks(y: FloatArray, dt: float, count: int, min_rad_s: float = 0.5,
                   exclude: FloatArray | None = None, exclude_rel: float = 0.15,
                   fill: bool = True, max_rad_s: float = np.inf) -> FloatArray:
    """The `count` largest local maxima of the spectrum (rad/s, parabolic interpolation in
    log power) in [`min_rad_s`, `max_rad_s`], sorted; peaks within `exclude_rel`·ω of a
    frequency in `exclude` are skipped, and peaks closer than 15 % to a stronger one are
    merged into it.

    When fewer than `count` peaks exist, `fill` pads with guesses (twice the highest, or
    2π rad/s) so that callers needing exactly `count` values get them; `fill=False` returns
    only the peaks found (PEM then knows it has too few)."""
    w, p = spectrum(y, dt)
    local = np.flatnonzero((p[1:-1] > p[:-2]) & (p[1:-1] >= p[2:])) + 1
    local = local[(w[local] >= min_rad_s) & (w[local] <= max_rad_s)]
    if exclude is not None:
        keep = [i for i in local if np.all(np.abs(w[i] - exclude) > exclude_rel * np.asarray(exclude))]
        local = np.asarray(keep, dtype=int)
    order = local[np.argsort(p[local])[::-1]]
    peaks: list[float] = []
    for i in order:
        if all(abs(w[i] - q) > 0.15 * q for q in peaks):
            a, b, c = np.log(p[i - 1] + 1e-300), np.log(p[i] + 1e-300), np.log(p[i + 1] + 1e-300)
            shift = 0.5 * (a - c) / (a - 2 * b + c) if (a - 2 * b + c) != 0 else 0.0
            peaks.append(float(w[i] + np.clip(shift, -0.5, 0.5) * (w[1] - w[0])))
        if len(peaks) == count:
            break
    while fill and len(peaks) < count:
        peaks.append(peaks[-1] * 2.0 if peaks else 2 * np.pi)
    return np.sort(np.asarray(peaks))
