"""Staircase structure of a measurement: are the positions on a lattice offset + q·k?

An encoder reports whole counts, so every sample is `offset + q·k` exactly (up to float
rounding of the count-to-metre scale). The quantum is the smallest gap between distinct
measured values (adjacent levels are visited where the cart is slow), accepted only when
at least 99 % of the samples lie within 1 % of q from the lattice it defines. Continuous
(noisy, unquantised) data has a vanishing smallest gap and fails the test.

A lattice read with noise added after it (y = offset + q·k + n, n ~ N(0, s²)) has no exact
levels; `find_noisy_lattice` finds it from the speed-weighted characteristic function
C(f) = |Σ w_i exp(2πi f y_i)| / Σ w_i, w_i = |ẏ_i|: on a lattice exp(2πi y/q) = exp(2πi (n + offset)/q)
whatever the motion, so |C(1/q)| = exp(-2π² s²/q²) (0.17 at s = 0.3 q), while continuous data
gives only the characteristic function of the swept positions, which the speed weighting
flattens (each half-cycle weighs like a uniform sweep: |C| ~ 1/(2π f A)) and a resting cart
cannot inflate (weight 0). A steady swing sampled evenly is itself nearly a lattice at the
distance moved per sample: the search only proposes a quantum, which the diagnosis keeps only
if modelling it improves the fit beyond noise (`select`). No I/O here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

ON_LATTICE_FRACTION = 0.99
MIN_LEVELS = 5
#: false-alarm probability of the noisy-lattice search over all its frequencies
NOISY_ALPHA = 1e-3
#: quanta searched under noise: at least this many per swing (coarser is no encoder), and at
#: least the finest quantum of a lab encoder we accept (m)
NOISY_MIN_LEVELS = 8
NOISY_MIN_QUANTUM_M = 5e-6
#: |C| must also exceed this (a lattice under noise of more than ~0.45 q is indistinguishable)
NOISY_MIN_COHERENCE = 0.02


@dataclass(frozen=True)
class Lattice:
    """`quantum_m` q, `offset_m` in [0, q), `coherence` mean cos(2π (y - offset)/q) ∈ [-1, 1]."""

    quantum_m: float
    offset_m: float
    coherence: float
    levels: int


def lattice_coherence(y: FloatArray, q: float, offset: float) -> float:
    return float(np.mean(np.cos(2 * np.pi * (y - offset) / q)))


def find_lattice(y: FloatArray) -> tuple[Lattice | None, float]:
    """The lattice every sample of `y` (any shape) sits on exactly, or None; and the coherence."""
    values = np.asarray(y, dtype=np.float64).ravel()
    levels = np.unique(values)
    if levels.size < MIN_LEVELS:
        return None, 0.0
    scale = float(np.max(np.abs(levels))) or 1.0
    gaps = np.diff(levels)
    gaps = gaps[gaps > 1e-9 * scale]
    if gaps.size == 0:
        return None, 0.0
    q = float(np.min(gaps))
    offset = float(np.mod(levels[0], q))
    r = (values - offset) / q
    frac = np.abs(r - np.round(r))
    coherence = lattice_coherence(values, q, offset)
    used = np.unique(np.round(r)).size
    if np.mean(frac < 0.01) < ON_LATTICE_FRACTION or used < MIN_LEVELS or q < 1e-7 * scale:
        return None, coherence
    # the gaps are multiples of q: refine q as the least-squares lattice spacing
    k = np.round((levels - levels[0]) / q)
    if k[-1] > 0:
        q = float(np.dot(k, levels - levels[0]) / np.dot(k, k))
    return Lattice(q, float(np.mod(levels[0], q)), lattice_coherence(values, q, offset), used), coherence


def _weighted(y: FloatArray) -> tuple[FloatArray, FloatArray]:  # values, |motion per sample|
    """Samples of every column of `y` (N, c) and their weights |ẏ| (central differences of a
    5-sample moving mean, so that the weight is not correlated with a sample's own noise)."""
    ys, ws = [], []
    for col in np.atleast_2d(np.asarray(y, dtype=np.float64).T):
        if col.size < 9:
            continue
        smooth = np.convolve(col, np.ones(5) / 5, mode="same")
        w = np.zeros(col.size)
        w[3:-3] = np.abs(smooth[4:-2] - smooth[2:-4])
        ys.append(col)
        ws.append(w)
    if not ys:
        return np.zeros(0), np.zeros(0)
    return np.concatenate(ys), np.concatenate(ws)


def weighted_coherence(values: FloatArray, weights: FloatArray, f: FloatArray) -> FloatArray:
    """Σ w exp(2πi f y) / Σ w at the spatial frequencies `f` (1/m): complex, shape of `f`."""
    phase = np.exp(2j * np.pi * np.outer(f, values - values[0]))
    return np.asarray(phase @ weights / np.sum(weights))


def _spectrum(values: FloatArray, weights: FloatArray, q_min: float) -> tuple[FloatArray, FloatArray]:
    """|C(f)| on a grid up to 1/q_min, 2× finer than the resolution 1/span, by binning the
    weighted samples (bins of q_min/8: < 3 % loss of |C| at 1/q_min) and one FFT."""
    h = q_min / 8
    lo = float(np.min(values))
    idx = np.floor((values - lo) / h).astype(np.int64)
    n_bins = int(idx.max()) + 1
    hist = np.bincount(idx, weights=weights, minlength=n_bins)
    n_fft = 1 << int(np.ceil(np.log2(2 * n_bins)))
    spec = np.abs(np.fft.rfft(hist, n_fft)) / np.sum(weights)
    return np.fft.rfftfreq(n_fft, h).astype(np.float64), spec.astype(np.float64)


def find_noisy_lattice(y: FloatArray) -> Lattice | None:
    """A lattice offset + q·k under additive noise in `y` (N,) or (N, c), or None.

    The speed-weighted |C(f)| is searched for f ≥ NOISY_MIN_LEVELS / swing; a peak counts when
    |C|² exceeds its noise mean Σw²/(Σw)² by ln(n_f/α) (an exponential under no lattice, n_f
    independent frequencies searched). The highest significant peak may be a harmonic k/q: the
    lowest significant sub-multiple of it is the quantum, then refined on |C| directly.
    """
    values, weights = _weighted(y)
    if values.size == 0 or np.sum(weights) <= 0:
        return None
    span = float(np.ptp(values))
    q_max, q_min = span / NOISY_MIN_LEVELS, max(NOISY_MIN_QUANTUM_M, 1e-7 * span)
    if q_max <= 2 * q_min:
        return None
    f, spec = _spectrum(values, weights, q_min)
    band = (f >= 1 / q_max) & (f <= 1 / q_min)
    if not np.any(band):
        return None
    null = float(np.sum(weights ** 2) / np.sum(weights) ** 2)
    n_f = max(1.0, (1 / q_min - 1 / q_max) * span)
    bar = max(float(np.sqrt(null * np.log(n_f / NOISY_ALPHA))), NOISY_MIN_COHERENCE)
    k_top = int(np.flatnonzero(band)[np.argmax(spec[band])])
    if spec[k_top] < bar:
        return None
    # the lowest significant sub-multiple of the top peak is the fundamental (read off the
    # spectrum: the largest of the grid points either side of f_top / k); a lattice's
    # |C(k/q)| = exp(-2π² k² s²/q²) falls with k, so the fundamental is as high as the top
    df = float(f[1] - f[0])
    ks = np.arange(2, int(min(f[k_top] * q_max, 64)) + 1)
    at = np.rint(f[k_top] / ks / df).astype(np.int64)
    near = np.maximum(spec[np.maximum(at - 1, 0)], np.maximum(spec[at], spec[at + 1]))
    ok = ks[(near >= max(bar, 0.7 * spec[k_top])) & (f[at] >= 1 / q_max)]
    f_q = _refine(values, weights, float(f[k_top]) / (int(ok.max()) if ok.size else 1), span)
    c = weighted_coherence(values, weights, np.array([f_q]))[0]
    q = 1.0 / f_q
    offset = float(np.mod(values[0] + np.angle(c) / (2 * np.pi) * q, q))
    return Lattice(q, offset, float(abs(c)), 0)


def _refine(values: FloatArray, weights: FloatArray, f0: float, span: float) -> float:
    """The frequency of the largest |C| within ±1/span of `f0` (two grid passes)."""
    half = 1.0 / span
    for _ in range(2):
        grid = f0 + np.linspace(-half, half, 41)
        grid = grid[grid > 0]
        f0 = float(grid[np.argmax(np.abs(weighted_coherence(values, weights, grid)))])
        half /= 20
    return f0
