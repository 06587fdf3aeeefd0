"""An independent judge of where a hand let a cart go, for the release-finder tests.

Not the finder's method (that one regresses smoothed accelerations): here a free response
is fitted as a trajectory and extrapolated backwards, and the departure of the data from it
is located by a change-point fit.

1. Around a by-eye time, the cart's largest extreme e0 (the flick's end: the hand lets go
   near it).
2. A nonlinear free response of one cart with viscous and dry friction,
   x'' = -wn²(x - c) - 2ζ wn x' - f·sgn(x'), is fitted to the two periods after e0 + T/4
   (initial state, wn, ζ, f, c free; RK4 at 1 ms with the dry term smoothed over 1 mm/s).
3. The fit is integrated backwards to e0 - T/2; the deviation d(t) of the data from it is
   zero after the release and grows like a hand's push before it. The release t_r is the
   change point of d(t) = H(t_r - t)·(α (t_r - t)² + β (t_r - t)³), fitted over
   [e0 - T/2, e0 + T/4] by scanning t_r on the samples and solving (α, β) linearly.
"""

from __future__ import annotations

import numpy as np
import scipy.optimize
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
SMOOTH_V = 1e-3   # m/s


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


def judge_release(t: FloatArray, x: FloatArray, around_s: float, period_s: float = 0.4,
                  search_s: float = 0.35) -> float:
    """The release instant (s) of the cart `x` (N,) m near the by-eye time `around_s`."""
    region = np.flatnonzero((t >= around_s - search_s) & (t <= around_s + search_s))
    e0 = int(region[np.argmax(np.abs(x[region] - np.median(x[: max(region[0], 5)])))])
    dt = float(np.median(np.diff(t)))
    q = round(period_s / 4 / dt)
    a, b = e0 + q, min(e0 + q + round(2 * period_s / dt), t.size)
    step = max(1, round(0.004 / dt))
    ts, xs = t[a:b:step], x[a:b:step]
    wn0 = 2 * np.pi / period_s

    def resid(theta: FloatArray) -> FloatArray:
        return integrate(theta[0], theta[1], theta[2:], ts) - xs

    v0 = float((x[a + 1] - x[a - 1]) / (t[a + 1] - t[a - 1]))
    theta0 = np.array([xs[0], v0, wn0, 0.02, 0.2, float(np.median(xs))])
    fit = scipy.optimize.least_squares(resid, theta0, x_scale=np.array([0.01, 0.1, 1, 0.01, 0.1, 0.01]))
    lo = max(0, e0 - 2 * q)
    back_t = t[a:lo - 1 if lo > 0 else None:-1]
    d = (x[a:lo - 1 if lo > 0 else None:-1] - integrate(fit.x[0], fit.x[1], fit.x[2:], back_t))[::-1]
    tt = back_t[::-1]
    best, best_t = np.inf, float(t[e0])
    for k in range(1, tt.size - 1):
        tau = np.maximum(tt[k] - tt, 0.0)
        basis = np.column_stack([tau ** 2, tau ** 3])
        coef = np.linalg.lstsq(basis, d, rcond=None)[0]
        sse = float(np.sum((d - basis @ coef) ** 2))
        if sse < best:
            best, best_t = sse, float(tt[k])
    return best_t
