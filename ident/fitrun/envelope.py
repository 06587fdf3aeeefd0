"""The peak envelope of one cart's free response and the two reference laws fitted to it.

After the release the cart rings about its rest `x_rest`. Take the half-cycles of
`e(t) = x(t) - x_guess` (between sign changes) and the extreme of each, `x_k` at `t_k`; the
free ring runs from the largest extreme (where the hand let go) until the peaks fall into
the noise or grow again (the hand). The
rest is then estimated without taking sides between the laws: for both, three successive
extremes give `x_rest ≈ (x_k + 2 x_{k+1} + x_{k+2}) / 4` (the alternating part cancels; the
median over k is kept). A rest off by δ would make the peaks zig-zag by ±δ. The peaks are
`A_k = |x_k - x_rest|`. Two laws explain how they shrink:

- dry (Coulomb) friction `F_c` loses a constant amount per half-cycle,
  `A_{k+1} = A_k - 2 F_c / k_spring`, so the peaks fall on a straight line in time:
  `A(t) = A_0 - s·t` (s in m/s; loss per cycle `s·T`);
- viscous damping loses a constant ratio per cycle, `A_{k+2} / A_k = exp(-2π ζ / √(1 - ζ²))`,
  so the peaks follow an exponential: `A(t) = A_0·exp(-σ t)`, `σ = ζ ω_n` (1/s).

Both together: `A_{k+1} = q·A_k - b` (viscous ratio q per half-cycle, dry-friction loss b
per half-cycle), a straight-line regression of each peak on the one before.

The single laws are fitted by least squares on the peaks (the exponential on `A`, started from a fit of
`ln A`); the law with the smaller RMS misfit describes the run better. Pure: arrays in,
`schemas.fit.EnvelopeRec` out (the one definition of an envelope, the report's record; its
derived quantities are properties there, the laws as curves are `coulomb_line` and
`viscous_curve` here). Only meaningful for one free cart: two coupled carts beat, and the
peaks of one cart are not one decaying oscillation.
"""

from __future__ import annotations

import itertools

import numpy as np

from ident.data import FloatArray
from ident.physics.measures import encoder_quantum
from schemas.fit import EnvelopeRec

#: Peaks below this many noise standard deviations are not peaks of the ring...
PEAK_SIGMAS = 6.0
#: ... nor below this many encoder counts (a cart stuck on the lattice dithers by one count,
#: and on a quantized record the noise std is ~0).
PEAK_QUANTA = 3.0
#: Fewest peaks for a law to be fitted (two parameters each, and one to judge them).
MIN_PEAKS = 4
#: A peak this many times the one a cycle before is a new push, not the free ring.
REGROW = 1.2
#: A half-cycle this many times longer or shorter than the ring's median so far is not one:
#: the cart stopped (dry friction) and a later extreme is a touch, drift or a count's dither,
#: not the ring (neither friction law changes the period).
STRETCH = 1.5


def coulomb_line(env: EnvelopeRec, t: FloatArray) -> FloatArray:
    """The dry-friction law at times `t` (s): `max(a0 - s·(t - t_0), 0)` (m)."""
    return np.maximum(env.coulomb_a0_m - env.coulomb_slope_m_s * (t - env.t_s[0]), 0.0)


def viscous_curve(env: EnvelopeRec, t: FloatArray) -> FloatArray:
    """The viscous law at times `t` (s): `a0·exp(-σ (t - t_0))` (m)."""
    return env.viscous_a0_m * np.exp(-env.viscous_rate_1_s * (t - env.t_s[0]))


def half_cycle_peaks(t: FloatArray, e: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The extreme `e` (signed) of each half-cycle (between sign changes of `e`).

    `t` (N,) s, `e` (N,) m measured from a rest. A sample exactly at the rest (common on an
    encoder's lattice, where the rest guess is itself a reading) keeps the sign before it, so
    a crossing through it is still one change of sign."""
    sign = np.sign(e)
    filled = np.maximum.accumulate(np.where(sign != 0, np.arange(sign.size), 0))
    sign = sign[filled]
    flips = np.flatnonzero(sign[1:] * sign[:-1] < 0) + 1
    bounds = np.concatenate([[0], flips, [e.size]])
    times, peaks = [], []
    for start, stop in itertools.pairwise(bounds):
        if stop - start < 2:
            continue
        k = start + int(np.argmax(np.abs(e[start:stop])))
        times.append(t[k])
        peaks.append(e[k])
    return np.asarray(times), np.asarray(peaks)


def ring_of(times: FloatArray, peaks: FloatArray, floor_m: float) -> slice:
    """The free ring among the half-cycle peaks at `times` (s): from the largest (where the
    hand let go) while the peaks stay above `floor_m`, do not grow (a peak more than `REGROW`
    times the one a cycle before, same side, is the hand again) and keep their rhythm (a gap
    `STRETCH` times longer or shorter than the median half-cycle so far: the cart had stopped)."""
    size = np.abs(peaks)
    first = int(np.argmax(size)) if size.size else 0
    last = first
    for k in range(first + 1, size.size):
        if size[k] < floor_m or (k >= first + 2 and size[k] > REGROW * size[k - 2]):
            break
        if k >= first + 3:
            gap, usual = times[k] - times[k - 1], float(np.median(np.diff(times[first:k])))
            if not usual / STRETCH <= gap <= STRETCH * usual:
                break
        last = k
    return slice(first, last + 1)


def rest_from_extremes(extremes: FloatArray) -> float:
    """The rest `x_rest` from successive signed extremes `x_k` (K ≥ 3), as the median of
    `(x_k + 2 x_{k+1} + x_{k+2}) / 4`: exact for a constant loss per half-cycle, and for a
    constant ratio up to the square of the decay per half-cycle."""
    x = np.asarray(extremes, dtype=np.float64)
    return float(np.median((x[:-2] + 2.0 * x[1:-1] + x[2:]) / 4.0))


def fit_envelope(t: FloatArray, x: FloatArray, rest_guess_m: float, release_time_s: float,
                 noise_m: float, output: int = 1) -> EnvelopeRec | None:
    """The peaks of `x` (N,) m after `release_time_s`, about the rest estimated from them
    (`rest_guess_m` only splits the half-cycles), and both laws fitted; `output` the cart's
    number (1 or 2) the record names.

    None when fewer than `MIN_PEAKS` peaks stand above `PEAK_SIGMAS·noise_m` and
    `PEAK_QUANTA` encoder counts.
    """
    from scipy.optimize import least_squares  # deferred: keeps `import ident` fast
    after = t >= release_time_s
    times, signed = half_cycle_peaks(t[after], x[after] - rest_guess_m)
    floor = max(PEAK_SIGMAS * max(noise_m, 1e-9), PEAK_QUANTA * encoder_quantum(x[after]))
    ring = ring_of(times, signed, floor)
    times, extremes = times[ring], signed[ring] + rest_guess_m
    if extremes.size < MIN_PEAKS:
        return None
    rest_m = rest_from_extremes(extremes)
    peaks = np.abs(extremes - rest_m)
    tau = times - times[0]
    period = 2.0 * float(np.mean(np.diff(times)))
    slope, a0 = np.polyfit(tau, peaks, 1)
    coulomb_rms = float(np.sqrt(np.mean((a0 + slope * tau - peaks) ** 2)))
    log_slope, log_a0 = np.polyfit(tau, np.log(np.maximum(peaks, 1e-9)), 1)
    fit = least_squares(lambda p: p[0] * np.exp(-p[1] * tau) - peaks,
                        [float(np.exp(log_a0)), float(-log_slope)])
    v_a0, rate = (float(v) for v in fit.x)
    viscous_rms = float(np.sqrt(np.mean(fit.fun ** 2)))
    ratio, minus_loss = np.polyfit(peaks[:-1], peaks[1:], 1)
    return EnvelopeRec(output=output, t_s=[float(v) for v in times], peak_m=[float(v) for v in peaks],
                       rest_m=float(rest_m), period_s=period, coulomb_a0_m=float(a0),
                       coulomb_slope_m_s=float(-slope), coulomb_rms_m=coulomb_rms, viscous_a0_m=v_a0,
                       viscous_rate_1_s=rate, viscous_rms_m=viscous_rms, mixed_ratio_per_half=float(ratio),
                       mixed_loss_m_per_half=float(-minus_loss))


__all__ = ["MIN_PEAKS", "PEAK_QUANTA", "PEAK_SIGMAS", "REGROW", "STRETCH", "coulomb_line", "fit_envelope",
           "half_cycle_peaks", "rest_from_extremes", "ring_of", "viscous_curve"]
