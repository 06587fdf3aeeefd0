"""Start values of the simple identification (`ident.simple`), read off the data.

The damped period from the zero crossings of y - y_final, σ = ζ wn from the logarithmic
decrement of the successive extrema, the level and the velocity of the cart at the release,
the dry friction from the peak envelope, and the ζ with which explicit Euler rings like the
data. Pure numpy on arrays: t (N,) s, y (N,) m.
"""

from __future__ import annotations

import itertools

import numpy as np
from numpy.typing import NDArray

from ident.errors import FitFailed
from ident.physics.measures import encoder_quantum
from ident.release import noise_std, rest_window

FloatArray = NDArray[np.float64]
#: A swing about the final level counts as motion above this many noise std ...
SWING_NOISE = 10.0
#: ... and this many encoder quanta (a stuck cart dithers by one count).
SWING_QUANTA = 3.0
#: The release velocity is the slope of a quadratic fitted over this fraction of a period.
VELOCITY_PERIODS = 0.08


def start_values(t: FloatArray, y: FloatArray, amplitude: float, release0: float) -> FloatArray:
    """(wn, ζ, g, t_r, o) from the data: period from zero crossings, σ from the log decrement.

    A crossing counts only while the swings are larger than the noise and than the encoder's
    quantum (`swing_floor`): a cart stuck between two counts dithers across the final level
    every sample, and those crossings would set the period to two samples.
    """
    offset = release_level(t, y, release0)
    after = t > release0
    tail = y[after][-max(5, int(after.sum()) // 10):]
    final = float(np.mean(tail))
    gain = (final - offset) / amplitude
    e = y[after] - final
    ta = t[after]
    crossings = significant_crossings(e, swing_floor(y))
    if crossings.size < 3:
        raise FitFailed(f"expected an oscillation (≥ 3 crossings of the final level), got {crossings.size}")
    t_cross = ta[crossings] - e[crossings] * (ta[crossings + 1] - ta[crossings]) / (e[crossings + 1] - e[crossings])
    omega_d = np.pi / float(np.median(np.diff(t_cross)))
    peaks = np.array([np.max(np.abs(e[a:b + 1])) for a, b in itertools.pairwise(crossings)])
    times = np.array([ta[a + int(np.argmax(np.abs(e[a:b + 1])))] for a, b in itertools.pairwise(crossings)])
    usable = peaks > 0.05 * peaks[0]
    sigma = 0.05 * omega_d
    if usable.sum() >= 2:
        slope = np.polyfit(times[usable], np.log(peaks[usable]), 1)[0]
        sigma = max(-float(slope), 1e-3 * omega_d)
    wn = float(np.hypot(omega_d, sigma))
    return np.array([wn, sigma / wn, gain, release0, offset])


def release_level(t: FloatArray, y: FloatArray, release0: float) -> float:
    """Start value of the offset o (m): the level at the release, where the model's cart is.

    The median of the rest samples just before `release0` (`rest_window` of them) when there are
    at least 5, else y at `release0`: a window that starts at (or after) the release, as the
    release finder's do on a flicked cart, begins moving, and the median of its first samples
    lies inside the swing, which gave a start gain of the wrong sign.
    """
    before = np.flatnonzero(t < release0)
    if before.size >= 5:
        size = rest_window(len(y)).stop
        return float(np.median(y[before[-size:]]))
    return float(np.interp(release0, t, y))


def release_state(t: FloatArray, y: FloatArray, release0: float, wn: float) -> tuple[float, float]:
    """The cart's measured state at `release0`: position (m) and velocity (m/s), from a
    quadratic y ≈ a + b τ + c τ² fitted over the samples within `VELOCITY_PERIODS` of a
    period 2π/wn after it (at least 3 samples); (y at the release, 0) when there are fewer.

    The start of a fit with the initial state estimated: a flicked cart is let go moving."""
    span = VELOCITY_PERIODS * 2.0 * np.pi / wn if np.isfinite(wn) and wn > 0.0 else 0.0
    near = np.flatnonzero((t >= release0) & (t <= release0 + span))
    if near.size < 3:
        near = np.flatnonzero(t >= release0)[:3]
    if near.size < 3:
        return float(np.interp(release0, t, y)), 0.0
    _c, b, a = np.polyfit(t[near] - release0, y[near], 2)
    return float(a), float(b)


def swing_floor(y: FloatArray) -> float:
    """Smallest swing (m) about the final level that is motion, not noise: the larger of
    `SWING_NOISE` noise std and `SWING_QUANTA` encoder quanta.

    The quantum is the smallest non-zero step between samples. On a quantized record the rest
    reads one count, so its noise std is ~0 and the quantum is what bounds the dither.
    """
    return max(SWING_NOISE * float(noise_std(y)[0]), SWING_QUANTA * encoder_quantum(y))


def significant_crossings(e: FloatArray, floor: float) -> NDArray[np.int64]:
    """Indices k where e changes sign between k and k+1, kept while the swing between
    crossings exceeds `floor` (noise or a count's dither around a stuck cart makes spurious
    crossings)."""
    signs = np.signbit(e)
    crossings = np.flatnonzero(signs[1:] != signs[:-1])
    kept = [int(crossings[0])] if crossings.size else []
    for a, b in itertools.pairwise(crossings):
        if np.max(np.abs(e[a:b + 1])) < floor:
            break
        kept.append(int(b))
    return np.array(kept, dtype=np.int64)


def envelope_friction(t: FloatArray, y: FloatArray, release0: float, wn: float) -> tuple[float, float] | None:
    """Start values (ζ, f) of the dry-friction model (f in m/s²) from the successive extrema
    y_j of the ring after `release0`, one per half-cycle (each refined by the parabola through
    its sample and their neighbours: a coarse rate samples a peak up to 8 % low).

    With viscous and Coulomb friction each half-cycle rings about the rest c shifted by f/wn²
    against the motion, so |e_{j+1}| + f/wn² = ρ (|e_j| - f/wn²), e_j = y_j - c, ρ =
    e^{-πζ/√(1-ζ²)}. With s_j = sign(e_j) = -s_{j+1} that is linear in (ρ, (1+ρ) c, δ):
    y_{j+1} = -ρ y_j + (1+ρ) c + s_j δ, δ = (1+ρ) f/wn², fitted by least squares. c is not the
    level the cart sticks at (anywhere within ±f/wn² of it), which biased a regression about
    that level. None with fewer than four extrema.

    Both come from the line: the linear fit's ζ has the dry friction's decay in it, and a start
    with that ζ and the envelope's f double-counts the decay (the fit then stalled in a local
    minimum with ζ 73 % and f 52 % off on a clean 50 Hz hold)."""
    after = t > release0
    e = y[after] - float(np.mean(y[after][-max(5, int(after.sum()) // 10):]))
    crossings = significant_crossings(e, swing_floor(y))
    extrema = np.array([_refined_extreme(y[after], e, a, b) for a, b in itertools.pairwise(crossings)])
    if extrema.size < 4:
        return None
    sides = np.sign(e[crossings[1:]])   # e keeps its sign from a + 1 to b
    rows = np.column_stack([-extrema[:-1], np.ones(extrema.size - 1), sides[:-1]])
    (rho, _level, delta), *_ = np.linalg.lstsq(rows, extrema[1:], rcond=None)
    rho = float(np.clip(rho, 1e-3, 1.0 - 1e-9))
    log_rho = float(np.log(rho))
    return -log_rho / float(np.hypot(np.pi, log_rho)), float(max(delta, 0.0)) * wn * wn / (1.0 + rho)


def _refined_extreme(y: FloatArray, e: FloatArray, a: int, b: int) -> float:
    """The extreme of y between crossings a and b (indices into y), refined by the parabola
    through the largest |e| sample and its neighbours."""
    k = a + int(np.argmax(np.abs(e[a:b + 1])))
    if not 0 < k < y.size - 1:
        return float(y[k])
    left, mid, right = float(y[k - 1]), float(y[k]), float(y[k + 1])
    curvature = left - 2.0 * mid + right
    if curvature == 0.0:
        return mid
    shift = 0.5 * (left - right) / curvature
    return mid - 0.25 * (left - right) * shift if abs(shift) <= 1.0 else mid


def euler_zeta(wn: float, zeta: float, h: float) -> float:
    """The ζ with which explicit Euler at step h (s) decays like the true ring: the start of
    an Euler fit, whose answer is biased that way (`ident.simple`'s docstring).

    Euler's pole 1 + hλ has |1 + hλ|² = 1 - 2ζ_E wn h + (wn h)²; the ring decays by
    e^{-2ζ wn h} per step in energy, so ζ_E = (1 + (wn h)² - e^{-2ζ wn h}) / (2 wn h)
    (≈ ζ + wn h/2 for small wn h). Starting from the physical ζ instead, Euler's amplitude
    grows by √(1 + (wn h)²) per step, past any float on a long record at a coarse rate.
    """
    x = wn * h
    if not x > 0.0:
        return zeta
    return float((1.0 + x * x - np.exp(-2.0 * zeta * x)) / (2.0 * x))


def sample_step(t: FloatArray) -> float:
    """The median sample step (s) of the time base."""
    return float(np.median(np.diff(t))) if t.size > 1 else 0.0
