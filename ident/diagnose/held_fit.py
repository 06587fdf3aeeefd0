"""The held cart's candidate: its measured motion as an input (smoothed), its coupling fitted
from a grid and several starts. No I/O here."""

from __future__ import annotations

import numpy as np

from ident.diagnose.fitting import FitResult, fit
from ident.diagnose.models import ModelSpec
from ident.diagnose.problem import FloatArray, Problem, best_on_grid


def fit_held_cart(spec: ModelSpec, prob: Problem, theta0: FloatArray, lower: FloatArray, upper: FloatArray,
                  typical: FloatArray, at: int, wn2: float, max_nfev: int) -> FitResult:
    """The held cart's coupling β fitted from the best of a grid at the current parameters and
    from 0.05, 0.2 and 0.5 wn², the best fit kept. The
    current model has absorbed the held cart's slow pull into its rest and frequency, so at
    those values any β > 0 costs more (a grid at fixed parameters picks β = 0) and a short
    fit from β = 0 does not find the joint move; from a start near the coupling it does."""
    grid = best_on_grid(spec, prob, theta0, at, tuple(wn2 * g for g in (0.0, 0.05, 0.2, 0.5)))
    best: FitResult | None = None
    for beta in (float(grid[at]), 0.05 * wn2, 0.2 * wn2, 0.5 * wn2):
        start = grid.copy()
        start[at] = beta
        result = fit(spec, start, lower, upper, typical, prob.dt, prob.y, prob.train, max_nfev=max_nfev)
        if best is None or result.sse_train < best.sse_train:
            best = result
    assert best is not None
    return best


#: Bins of the held reading's power spectrum averaged for the Wiener gain (odd).
HELD_SMOOTH_BINS = 9
#: The noise's power is subtracted this many times over: a margin for the averaged spectrum's
#: scatter (9 bins: a noise-only average exceeds 1.5 × its mean with p ≈ 0.05). 1, 1.5, 2, 3
#: tried on drawn held motions: 1.5 came nearest the ideal gain P_clean / (P_clean + σ²).
HELD_OVERSUBTRACT = 1.5


def held_input(reading: FloatArray, decimation: int) -> FloatArray:
    """The held cart's motion as the free cart's input (m, from its first work sample), on the
    work grid (every `decimation`-th sample of `reading` (N,) m).

    The input enters the fit multiplied by the coupling β = k2/m: a reading error e adds β e to
    the free cart's force, and least squares shrinks β by the share of the input's variance
    that is reading noise (errors in variables; generated flicks at 0.15 mm noise: β 7 % low,
    2.6 % with the noiseless held cart). What the held cart really does is a hand's slow
    wander, its pull by the free cart (the free cart's modes) and its own ring on the hand
    (a hand is a stiff spring: several times the free cart's frequency, excited by the
    release); no fixed cutoff keeps the ring and drops the noise at every rate (a low-pass at
    3 × the free cart's mode removed a held cart's 10 Hz ring at 57 Hz: β 6.3 % off, 0.2 %
    unfiltered). So a zero-phase Wiener gain per frequency bin,

        G_k = max(0, 1 - c σ_k² / P̄_k),

    P̄_k the reading's power |X_k|² averaged over `HELD_SMOOTH_BINS` bins, σ_k² = N σ² the
    white noise's power per bin, estimated as the median of |X_k|² over the upper half of the
    band divided by ln 2 (|X_k|² of white noise is exponential: median = mean ln 2; a ring's
    few bins do not move a median), c = `HELD_OVERSUBTRACT`. The straight line between the
    reading's ends is taken out first (the DFT is periodic: no jump at the wrap) and put back.
    """
    x = np.asarray(reading, dtype=np.float64)
    n = x.size
    if n >= 8 * HELD_SMOOTH_BINS:
        from scipy.ndimage import uniform_filter1d  # deferred: keeps `import ident` fast
        line = x[0] + (x[-1] - x[0]) * np.arange(n, dtype=np.float64) / (n - 1)
        spec = np.fft.rfft(x - line)
        power = np.abs(spec) ** 2
        noise_power = float(np.median(power[power.size // 2:])) / np.log(2.0)
        smooth = uniform_filter1d(power, HELD_SMOOTH_BINS, mode="nearest")
        gain = np.clip(1.0 - HELD_OVERSUBTRACT * noise_power / np.maximum(smooth, 1e-300), 0.0, 1.0)
        x = np.fft.irfft(spec * gain, n) + line
    work = x[::decimation]
    out: FloatArray = work - work[0]
    return out


__all__ = ["fit_held_cart", "held_input"]
