"""An independent judge of where a hand let a cart go, for the release-finder tests.

Not the finders' methods: here a free response is fitted as a trajectory, the hand's force is
read off as what the free equation of motion leaves unexplained, and the instant that force
ends is located by a change-point fit.

1. Around a by-eye time, the cart's largest extreme e0 (the flick's end: the hand lets go
   near it).
2. A nonlinear free response of one cart with viscous and dry friction,
   x'' = -wn²(x - c) - 2ζ wn x' - f·sgn(x'), is fitted to the two periods after e0 + T/4
   (initial state, wn, ζ, f, c free; RK4 at 1 ms with the dry term smoothed over 1 mm/s).
3. The hand's force per unit mass is that equation's residual,
   h = x'' + 2ζ wn x' + wn²(x - c) + f·sgn(x') (m/s²), with the derivatives of cubic
   Savitzky–Golay fits over `window_s` (9 ms) on [e0 - T/2, e0 + T/4]. A device that stamps a
   coarse clock on evenly taken samples (the ECP-210: whole ms on ~1.13 ms samples) is read
   on the straight line through (index, stamp) first: its ±0.5 ms stamps would otherwise add
   ±v·0.5 ms to every derivative.
4. From the force's largest value before e0 (the hand's push declines from there to the
   let-go) to e0 + T/4, h is fitted by a force that ends at t_r,
   h(t) = H(t_r - t)·(F0 + F1 (t_r - t) + F2 (t_r - t)²) + b, as the filter sees it (each term's
   position, of second derivative the term, through the same second-derivative filter), with
   (F0, F1, F2, b) linear; t_r is scanned on a quarter-sample grid. F0 ≠ 0 is a hand that lets
   go at once; F0 = 0 with F1 > 0 one whose force comes down to zero at t_r.

The release is where the free response begins: where the hand's force ends. The previous
judge (a change point of the position's departure, α τ² + β τ³ with no spring, fitted over
[e0 - T/2, e0 + T/4]) let the 0.2 s of rising and falling push before the let-go decide the
fit and dated every real 2025 flick 4-30 ms before the hand's force had ended (plots of h in
docs/daq.md), and synthetic flicks with a sharp let-go 4-12 ms early.
"""

from __future__ import annotations

import numpy as np
import scipy.optimize
from numpy.typing import NDArray
from scipy.signal import savgol_coeffs, savgol_filter

FloatArray = NDArray[np.float64]
SMOOTH_V = 1e-3   # m/s
WINDOW_S = 0.009  # the derivatives' window: a few samples at the ECP's ~890 Hz, a tenth of the let-go's ~0.1 s decline
GRID = 0.25       # the change point's grid, in samples


def _rhs(state: FloatArray, p: FloatArray) -> FloatArray:
    wn, zeta, f, c = p
    x, v = state
    return np.array([v, -wn ** 2 * (x - c) - 2 * zeta * wn * v - f * np.tanh(v / SMOOTH_V)])


def integrate(x0: float, v0: float, p: FloatArray, t: FloatArray) -> FloatArray:
    """Positions at times `t` (monotonic, forward or backward from t[0]) by RK4 at ≤ 1 ms."""
    out = np.empty(t.size)
    state = np.array([x0, v0])
    out[0] = x0
    for k in range(1, t.size):
        span = t[k] - t[k - 1]
        n = max(1, int(np.ceil(abs(span) / 1e-3)))
        h = span / n
        for _ in range(n):
            k1 = _rhs(state, p)
            k2 = _rhs(state + 0.5 * h * k1, p)
            k3 = _rhs(state + 0.5 * h * k2, p)
            k4 = _rhs(state + h * k3, p)
            state = state + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        out[k] = state[0]
    return out


def even_clock(t: FloatArray) -> FloatArray:
    """`t` (N,) on the line through (index, stamp) when every stamp lies within half a spacing of
    it (a coarse clock on evenly taken samples, none missing); else `t` unchanged."""
    k = np.arange(t.size, dtype=np.float64)
    slope, intercept = np.polyfit(k, t, 1)
    line: FloatArray = intercept + slope * k
    return line if float(np.max(np.abs(t - line))) < 0.5 * slope else t


def free_parameters(t: FloatArray, x: FloatArray, a: int, b: int, period_s: float) -> FloatArray:
    """(wn, ζ, f, c) of the free response fitted on samples [a, b) (every ~4 ms)."""
    step = max(1, round(0.004 / float(np.median(np.diff(t[a:b])))))
    ts, xs = t[a:b:step], x[a:b:step]

    def resid(theta: FloatArray) -> FloatArray:
        return integrate(theta[0], theta[1], theta[2:], ts) - xs

    v0 = float((x[a + 1] - x[a - 1]) / (t[a + 1] - t[a - 1]))
    theta0 = np.array([xs[0], v0, 2 * np.pi / period_s, 0.02, 0.2, float(np.median(xs))])
    fit = scipy.optimize.least_squares(resid, theta0, x_scale=np.array([0.01, 0.1, 1, 0.01, 0.1, 0.01]))
    return np.asarray(fit.x[2:], dtype=np.float64)


def hand_force(x: FloatArray, dt: float, p: FloatArray, window: int) -> FloatArray:
    """The free equation's residual h (N,) m/s² of positions `x` (N,) m on an even step `dt` s,
    with (wn, ζ, f, c) = `p` and derivatives over `window` samples (odd)."""
    wn, zeta, f, c = p
    pos = savgol_filter(x, window, 3)
    v = savgol_filter(x, window, 3, deriv=1, delta=dt)
    acc = savgol_filter(x, window, 3, deriv=2, delta=dt)
    out: FloatArray = acc + 2 * zeta * wn * v + wn ** 2 * (pos - c) + f * np.tanh(v / SMOOTH_V)
    return out


def force_end(h: FloatArray, dt: float, window: int, lo: int, hi: int) -> float:
    """The change point (fractional sample index) of a force ending in h[lo:hi] (step 4)."""
    kernel = savgol_coeffs(window, 3, deriv=2, delta=dt)
    half = window // 2
    n = np.arange(lo - half, hi + half, dtype=np.float64)
    part = h[lo:hi]
    best, best_k = np.inf, float(lo)
    for k in np.arange(lo + 2, hi - 2, GRID):
        tau = np.maximum(k - n, 0.0) * dt
        # the position each force term adds, seen through the filter's second derivative
        cols = [np.convolve(tau ** (p + 2) / ((p + 1) * (p + 2)), kernel, mode="valid") for p in range(3)]
        basis = np.column_stack([*cols, np.ones(part.size)])
        coef = np.linalg.lstsq(basis, part, rcond=None)[0]
        r = part - basis @ coef
        cost = float(r @ r)
        if cost < best:
            best, best_k = cost, float(k)
    return best_k


def judge_release(t: FloatArray, x: FloatArray, around_s: float, period_s: float = 0.4,
                  search_s: float = 0.35, window_s: float = WINDOW_S) -> float:
    """The release instant (s, on `t`) of the cart `x` (N,) m near the by-eye time `around_s`."""
    region = np.flatnonzero((t >= around_s - search_s) & (t <= around_s + search_s))
    e0 = int(region[np.argmax(np.abs(x[region] - np.median(x[: max(region[0], 5)])))])
    dt = float(np.median(np.diff(t)))
    q = round(period_s / 4 / dt)
    lo, b = max(0, e0 - 2 * q), min(e0 + q + round(2 * period_s / dt), t.size)
    te = even_clock(t[lo:b])
    dt = float(np.median(np.diff(te)))
    p = free_parameters(te, x[lo:b], e0 + q - lo, b - lo, period_s)
    window = max(5, 2 * round(window_s / dt / 2) + 1)
    h = hand_force(x[lo:b], dt, p, window)
    top, end = e0 - lo, min(e0 + q - lo, h.size - window)
    peak = int(np.argmax(np.abs(h[window:top]))) + window
    k = force_end(h, dt, window, min(peak, top - q // 2), end)
    return float(np.interp(k, np.arange(te.size, dtype=np.float64), te))
