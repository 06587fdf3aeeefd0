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

from ident.physics.measures import noise_std

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
#: width (ratio of quanta) of the bands the noisy-lattice search weighs alike
BAND = 4.0


@dataclass(frozen=True)
class Lattice:
    """`quantum_m` q, `offset_m` in [0, q), `coherence` mean cos(2π (y - offset)/q) ∈ [-1, 1];
    `searched`: how many independent quanta a faint proposal was the best of (its likelihood
    ratio is charged 2 ln(searched)); 1 for a lattice established on its own."""

    quantum_m: float
    offset_m: float
    coherence: float
    levels: int
    searched: float = 1.0


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
    """Samples of every column of `y` (N, c) and their motion |ẏ| (central differences of a
    5-sample moving mean, so that it is not correlated with a sample's own noise), less three
    times its noise level (so that a resting cart weighs nothing: its readings cluster about
    one position whatever the lattice)."""
    ys, ws = [], []
    for col in np.atleast_2d(np.asarray(y, dtype=np.float64).T):
        if col.size < 9:
            continue
        smooth = np.convolve(col, np.ones(5) / 5, mode="same")
        w = np.zeros(col.size)
        w[3:-3] = np.abs(smooth[4:-2] - smooth[2:-4])
        # white noise σ (`noise_std`); the motion estimate's own noise is √(2/25) σ
        sigma = float(noise_std(col)[0])
        ys.append(col)
        ws.append(np.maximum(w - 3.0 * np.sqrt(2.0 / 25.0) * sigma, 0.0))
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

    The weighted |C(f)| is searched for f ≥ NOISY_MIN_LEVELS / swing, in bands of quanta a
    factor `BAND` wide: in the band of quanta above q_b each sample weighs min(|ẏ|, q_b), so
    that every sample moving a quantum or more between readings counts fully (its phase on the
    lattice is as good as any other's) while the slow samples near the turning points, whose
    positions crowd at the swing's ends, count by the distance they move. A peak counts when
    |C|² exceeds its noise mean Σw²/(Σw)² by ln(n_f/α) (an exponential under no lattice, n_f
    independent frequencies searched over every band). The most significant peak may be a
    harmonic k/q: the lowest significant sub-multiple of it is the quantum, then refined on |C|.
    """
    values, motion = _weighted(y)
    if values.size == 0 or np.sum(motion) <= 0:
        return None
    span = float(np.ptp(values))
    q_max, q_min = span / NOISY_MIN_LEVELS, max(NOISY_MIN_QUANTUM_M, 1e-7 * span)
    if q_max <= 2 * q_min:
        return None
    n_f = max(1.0, (1 / q_min - 1 / q_max) * span)
    best: tuple[float, FloatArray, FloatArray, FloatArray, float, int] | None = None
    q_b = q_min
    while q_b < q_max:
        weights = np.minimum(motion, q_b)
        f, spec = _spectrum(values, weights, q_b)
        band = (f >= 1 / min(BAND * q_b, q_max)) & (f <= 1 / q_b)
        null = float(np.sum(weights ** 2) / np.sum(weights) ** 2)
        bar = max(float(np.sqrt(null * np.log(n_f / NOISY_ALPHA))), NOISY_MIN_COHERENCE)
        if np.any(band):
            k_top = int(np.flatnonzero(band)[np.argmax(spec[band])])
            if spec[k_top] >= bar and (best is None or spec[k_top] / bar > best[0]):
                best = (float(spec[k_top] / bar), weights, f, spec, bar, k_top)
        q_b *= BAND
    if best is None:
        return None
    _, weights, f, spec, bar, k_top = best
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


#: The finest reading noise a lattice's likelihood resolves, in quanta (an exact encoder's
#: readings are levels to float rounding: its likelihood is unbounded without a floor).
MIN_READING_NOISE = 0.01


def reading_noise(lattice: Lattice) -> float:
    """Noise s (m) after the lattice from its coherence |C| = exp(-2π² s²/q²), ≥ 1 % of q."""
    q = lattice.quantum_m
    coh = float(np.clip(lattice.coherence, 1e-12, 1.0))
    return max(q * float(np.sqrt(-np.log(coh) / (2 * np.pi ** 2))), MIN_READING_NOISE * q)


def lattice_likelihood_gain(y: FloatArray, prediction: FloatArray, q: float, offset: float, noise: float) -> float:
    """2 (log L_lattice - log L_gauss): how much better the readings `y` (N, c) are explained as
    levels of the lattice `offset + q k` read with noise `noise` than as Gaussian scatter about
    `prediction` (N, c) (variance σ² = mean residual², profiled).

    Lattice model: the position is x ~ N(prediction, σ_x²), the encoder reports the level k
    that holds x (probability Φ((L_k + q/2 - p)/σ_x) - Φ((L_k - q/2 - p)/σ_x)) plus N(0, s²):
    a mixture over the reading's nearest level and its two neighbours; σ_x (what the
    prediction misses beyond the reading) is profiled on a grid from q/20 to 3σ, as σ is for
    the Gaussian, and s is the lattice's or σ if smaller. Unlike an SSE ratio this holds when
    the prediction is off by more than a quantum: readings ON a lattice are still far
    likelier under it (each gains about ln(q/(s√(2π)))), continuous readings are not.
    Each reading counts by how far the predicted position moved since the last, up to one
    quantum (w = min(1, |Δp|/q)): a resting cart's readings sit at one place relative to the
    lattice, one observation however many samples, and must not vote a lattice in.
    """

    step = np.abs(np.diff(prediction, axis=0, prepend=prediction[:1]))
    w = np.minimum(step / q, 1.0).ravel()
    p, yy = prediction.ravel(), y.ravel()
    total = float(np.sum(w))
    if total <= 0:
        return 0.0
    sigma2 = max(float(np.sum(w * (yy - p) ** 2) / total), 1e-30)
    ell0 = -0.5 * total * (np.log(2 * np.pi * sigma2) + 1.0)
    k = np.round((yy - offset) / q)
    best = -np.inf
    # s: the lattice's own, or the Gaussian's σ when smaller
    for s in {max(noise, 1e-12), max(min(noise, np.sqrt(sigma2)), 1e-12)}:
        reading = [(offset + q * (k + j), np.exp(-0.5 * ((yy - offset - q * (k + j)) / s) ** 2)
                    / (s * np.sqrt(2 * np.pi))) for j in (-1, 0, 1)]
        for sx in np.geomspace(0.05 * q, max(3.0 * np.sqrt(sigma2), 0.1 * q), 16):
            best = max(best, float(np.sum(w * _level_log_density(p, reading, q, sx))))
    return 2.0 * (best - float(ell0))


def _level_log_density(p: FloatArray, reading: list[tuple[FloatArray, FloatArray]], q: float,
                       sx: float) -> FloatArray:
    """Per reading, log of its density under the lattice model about the positions `p`: the
    position x ~ N(p, sx²), the level that holds x (probability Φ((L + q/2 - p)/sx) -
    Φ((L - q/2 - p)/sx)), times the reading's density about that level; `reading` pairs each
    candidate level L (the nearest and its two neighbours) with that density."""
    import scipy.special  # deferred: keeps `import ident` fast

    mix = np.zeros(p.size)
    for level, density in reading:
        mix += (scipy.special.ndtr((level + q / 2 - p) / sx) - scipy.special.ndtr((level - q / 2 - p) / sx)) * density
    return np.asarray(np.log(np.maximum(mix, 1e-300)), dtype=np.float64)


#: Reading noises s a comparison of two models' positions on one lattice profiles, in quanta
#: (`level_log_likelihood`): exact levels up to noise after the encoder of a third of a step.
LEVEL_READING_NOISES = (MIN_READING_NOISE, 0.03, 0.1, 0.3)


def level_log_likelihood(y: FloatArray, position: FloatArray, q: float, offset: float) -> float:
    """log L of the readings `y` (N, c) as levels `offset + q k` of an encoder lattice about the
    positions `position` (N, c) (the carts' model before the staircase): the lattice model of
    `lattice_likelihood_gain` (x ~ N(position, σ_x²), the level that holds x, plus N(0, s²)),
    every reading counted once, σ_x profiled (bounded search over ln σ_x, from q/50 to three
    times the larger of q and the rms residual) and s on `LEVEL_READING_NOISES`.

    Two models of the carts read through the same lattice are compared by twice the difference
    (a likelihood ratio, χ²_p under the smaller): a reading tells the position only to within
    its level, so moving the prediction across a few level edges gains what those readings
    say and no more. (An SSE of the staircase read counts each moved edge a whole quantum:
    a 23 µm, 2 Hz "mode" under a 1.23 mm lattice and 0.42 mm of noise took the SSE from
    2.11e-5 to 1.37e-5 m², ratio 45 against a bound of 29; as levels, 6.4.) On a lattice much
    finer than σ_x it is the Gaussian likelihood of the residual, σ_x profiled."""
    import scipy.optimize  # deferred: keeps `import ident` fast

    yy, p = y.ravel(), position.ravel()
    k = np.round((yy - offset) / q)
    levels = [offset + q * (k + j) for j in (-1, 0, 1)]
    rms = float(np.sqrt(np.mean((yy - p) ** 2))) if yy.size else q
    bounds = (float(np.log(0.02 * q)), float(np.log(3.0 * max(rms, q))))
    best = -np.inf
    for s in (f * q for f in LEVEL_READING_NOISES):
        reading = [(level, np.exp(-0.5 * ((yy - level) / s) ** 2) / (s * np.sqrt(2 * np.pi))) for level in levels]

        def cost(log_sx: float, reading: list[tuple[FloatArray, FloatArray]] = reading) -> float:
            return -float(np.sum(_level_log_density(p, reading, q, float(np.exp(log_sx)))))

        found = scipy.optimize.minimize_scalar(cost, bounds=bounds, method="bounded", options={"xatol": 1e-3})
        best = max(best, -float(found.fun), -cost(bounds[0]), -cost(bounds[1]))
    return best


def lattice_worth_points(y: FloatArray, q: float) -> float:
    """What a lattice of quantum `q` costs a perfect model of `y` (N, c), the window a fit % is
    taken on (the free response), in its fit-% points: 100 ‖e‖ / ‖y - ȳ‖ over every output, e
    the reading error, uniform on ±q/2 while the carts move (Widrow: variance q²/12) whatever
    the motion."""
    centred = y - np.mean(y, axis=0)
    total = float(np.sum(centred ** 2))
    return float(100.0 * q * np.sqrt(y.size / 12.0 / total)) if total > 0 else 0.0


def lattice_candidates(y: FloatArray, count: int = 8) -> list[Lattice]:
    """The `count` strongest peaks of the weighted |C(f)| (relative to their noise bar, over
    every band as in `find_noisy_lattice`), significant or not: lattices too faint for the
    characteristic function alone, for the diagnosis to weigh with the likelihood of the
    readings as levels about its model's prediction (`lattice_likelihood_gain`), which each
    reading near its predicted level makes far stronger. Sorted best first; [] if none."""
    values, motion = _weighted(y)
    if values.size == 0 or np.sum(motion) <= 0:
        return []
    span = float(np.ptp(values))
    q_max, q_min = span / NOISY_MIN_LEVELS, max(NOISY_MIN_QUANTUM_M, 1e-7 * span)
    if q_max <= 2 * q_min:
        return []
    peaks: list[tuple[float, float, FloatArray]] = []
    q_b = q_min
    while q_b < q_max:
        weights = np.minimum(motion, q_b)
        f, spec = _spectrum(values, weights, q_b)
        band = np.flatnonzero((f >= 1 / min(BAND * q_b, q_max)) & (f <= 1 / q_b))
        null = float(np.sum(weights ** 2) / np.sum(weights) ** 2)
        inner = band[(band > 0) & (band < f.size - 1)]
        local = inner[(spec[inner] > spec[inner - 1]) & (spec[inner] >= spec[inner + 1])]
        for k in local[np.argsort(spec[local])[::-1][:count]]:
            peaks.append((float(spec[k] / np.sqrt(null)), float(f[k]), weights))
        q_b *= BAND
    out = []
    for _, f_k, weights in sorted(peaks, key=lambda p: -p[0])[:count]:
        f_q = _refine(values, weights, f_k, span)
        c = weighted_coherence(values, weights, np.array([f_q]))[0]
        q = 1.0 / f_q
        out.append(Lattice(q, float(np.mod(values[0] + np.angle(c) / (2 * np.pi) * q, q)), float(abs(c)), 0,
                           max(1.0, (1 / q_min - 1 / q_max) * span)))
    return out
