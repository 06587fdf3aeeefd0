"""Where the hand's force ends: the release of a held or flicked cart, to a fraction of a sample.

When a hand lets a cart go, position and velocity are continuous but the hand's force drops
to zero at once, so the acceleration jumps. A cart held still (`hold_release`): the record is
the hold level until t_r and a smooth curve leaving it with zero slope after (the jump is the
spring's pull, wn² d). A cart let go while moving (`flick_release`): the hand's smooth path
before t_r and the carts' free modes after, joined C¹ at t_r. Either way t_r is found by least
squares on a sub-sample grid, well within one sample even where the motion onset (a threshold
crossing) or a scan of window starts misses it by many. No I/O here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

#: samples on each side of a candidate knot, at least
MIN_SIDE = 5


@dataclass(frozen=True)
class Knot:
    """A release: `time_s` (s), the acceleration jump `jump_m_s2` (m/s²), and `z`, how far the
    jump has moved the cart by the end of the fitted stretch in noise standard deviations."""

    time_s: float
    jump_m_s2: float
    z: float


def hold_release(t: FloatArray, y: FloatArray, hold: float, onset: int, period_s: float) -> Knot | None:
    """The release of a cart held still at `hold` (m) and let go: on the samples from T/8
    before the motion `onset` to a tenth of a period (at least `MIN_SIDE` samples) after it,

        y = h before t_r,   y = h + c_2 (t - t_r)² + c_3 (t - t_r)³ + c_4 (t - t_r)⁴ after

    (let go from rest: no velocity term), t_r by least squares on a grid of a tenth of a
    sample; the jump is 2 c_2. None when the stretch is too short."""
    dt = float(t[1] - t[0])
    first = max(onset - max(MIN_SIDE, round(0.125 * period_s / dt)), 0)
    last = min(onset + max(MIN_SIDE, round(0.1 * period_s / dt)), t.size - 1)
    if last - onset < 3 or onset - first < 2:
        return None
    tt, yy = t[first:last + 1], y[first:last + 1] - hold
    scale = float(tt[-1] - tt[0])
    grid = np.arange(tt[0], t[onset] + 0.5 * dt, 0.1 * dt)
    best: tuple[float, float, float] = (np.inf, float(t[onset]), 0.0)
    for t_r in grid:
        s = np.maximum(tt - t_r, 0.0) / scale
        a = np.column_stack([np.ones_like(s), s * s, s ** 3, s ** 4])
        coef, *_ = np.linalg.lstsq(a, yy, rcond=None)
        res = yy - a @ coef
        sse = float(res @ res)
        if sse < best[0]:
            best = (sse, float(t_r), 2.0 * float(coef[1]) / scale ** 2)
    sse, t_r, jump = best
    sigma = np.sqrt(sse / max(yy.size - 5, 1))
    return Knot(t_r, jump, abs(jump) * (tt[-1] - t_r) ** 2 / 2 / max(sigma, 1e-15))


def flick_release(t: FloatArray, y: FloatArray, first: int, last: int, stop: int, freqs: FloatArray,
                  decays: FloatArray) -> Knot | None:
    """The release of a cart the hand let go while it moved (a flick), in samples [first, last].

    On the samples [first, stop] the record is fitted as the hand's smooth path before t_r (a
    cubic) and the carts' free response after it (a constant and e^{-σ_j τ}(a_j cos ω_j τ +
    b_j sin ω_j τ) for each mode of the window's modal fit, `freqs` ω_j rad/s and `decays` σ_j
    1/s; between velocity reversals dry friction only shifts the constant), joined with the
    same position and velocity at t_r (the hand's force ends, the motion does not jump):

        y = p_r + v_r (t - t_r) + c_2 (t - t_r)² + c_3 (t - t_r)³      t < t_r
        y = f(t)                                                     t ≥ t_r

    with p_r, v_r the free part's position and velocity at t_r. Linear least squares for each
    t_r on every sample, then on a twentieth of a sample about the best; the acceleration jump
    is f''(t_r) - 2 c_2. None when the stretch is too short for the parameters."""
    tt, yy = t[first:stop + 1], y[first:stop + 1]
    n_modes = freqs.size
    if last <= first or yy.size < 2 * (3 + 2 * n_modes):
        return None
    dt = float(t[1] - t[0])

    def sse_at(t_r: float) -> tuple[float, float]:
        tau = tt - t_r
        post = tau >= 0
        cols, vel, acc = [np.ones_like(tau)], [0.0], [0.0]
        for w, s in zip(freqs, decays):
            env = np.exp(-s * tau)
            cols += [env * np.cos(w * tau), env * np.sin(w * tau)]
            # position, velocity, acceleration at τ = 0 of the cos and sin terms
            vel += [-s, w]
            acc += [s * s - w * w, -2 * s * w]
        free = np.column_stack(cols)
        a = np.zeros((tau.size, free.shape[1] + 2))
        a[post, :free.shape[1]] = free[post]
        pre = ~post
        # before t_r: the free part's position and velocity at t_r continued by the hand's cubic
        a[pre, :free.shape[1]] = np.array([1.0] + [1.0, 0.0] * n_modes)[None, :] + np.outer(tau[pre], vel)
        a[pre, -2] = tau[pre] ** 2
        a[pre, -1] = tau[pre] ** 3
        coef, *_ = np.linalg.lstsq(a, yy, rcond=None)
        res = yy - a @ coef
        jump = float(np.dot(acc, coef[:free.shape[1]]) - 2.0 * coef[-2])
        return float(res @ res), jump

    coarse = [sse_at(float(t[k]))[0] for k in range(first, last + 1)]
    k = first + int(np.argmin(coarse))
    fine = np.linspace(t[k] - dt, t[k] + dt, 41)
    scores = [sse_at(float(x)) for x in fine]
    i = int(np.argmin([s for s, _ in scores]))
    sse, jump = scores[i]
    sigma = np.sqrt(sse / max(yy.size - (5 + 2 * n_modes), 1))
    return Knot(float(fine[i]), jump, abs(jump) * (0.1 * (tt[-1] - tt[0])) ** 2 / max(sigma, 1e-15))


#: samples of the hand's path a join on a known free response keeps before the release, at least
MIN_PRE = 3


def model_join(t: FloatArray, y: FloatArray, free: FloatArray, lo: int, hi: int) -> Knot | None:
    """The release of a flick whose free response is known: `free` (N,) m, the fitted model's
    positions on the samples `t` (N,) s read as `y` (N,) m, from the hand's push on. The hand's
    path before t_r (a cubic) joins the free response with its position and velocity at t_r:

        y = f(t_r) + f'(t_r) (t - t_r) + c_2 (t - t_r)² + c_3 (t - t_r)³      t < t_r
        y = f(t)                                                            t ≥ t_r

    f the cubic spline through `free`; t_r by least squares (c_2, c_3 linear for each t_r) on
    every sample from `t[lo]` to `t[hi]`, then on a twentieth of a sample about the best. Unlike
    `flick_release`, the free response has no parameter here: only where the hand's path ends
    moves the cost. The acceleration jump is f''(t_r) - 2 c_2. None when fewer than `MIN_PRE`
    samples precede `lo` or the range is empty."""
    import scipy.interpolate  # deferred: keeps `import ident` fast

    lo = max(lo, MIN_PRE)
    hi = min(hi, t.size - 1)
    if hi < lo:
        return None
    spline = scipy.interpolate.CubicSpline(t, free)
    # the cost of the samples from k on read against the free response: a sum from the end
    tail = np.concatenate([np.cumsum(((y - free) ** 2)[::-1])[::-1], [0.0]])
    dt = float(t[1] - t[0])

    def cost_at(t_r: float) -> tuple[float, float]:
        k = int(np.searchsorted(t, t_r))     # the first sample of the free response
        tau = t[:k] - t_r
        hand = y[:k] - float(spline(t_r)) - float(spline(t_r, 1)) * tau
        a = np.column_stack([tau ** 2, tau ** 3])
        coef, *_ = np.linalg.lstsq(a, hand, rcond=None)
        res = hand - a @ coef
        return float(res @ res) + float(tail[k]), float(spline(t_r, 2)) - 2.0 * float(coef[0])

    coarse = [cost_at(float(t[k]))[0] for k in range(lo, hi + 1)]
    k = lo + int(np.argmin(coarse))
    fine = np.linspace(max(t[k] - dt, t[lo]), min(t[k] + dt, t[hi]), 41)
    scores = [cost_at(float(x)) for x in fine]
    i = int(np.argmin([s for s, _ in scores]))
    sse, jump = scores[i]
    sigma = np.sqrt(sse / max(y.size - 3, 1))
    return Knot(float(fine[i]), jump, abs(jump) * (0.1 * (t[-1] - t[0])) ** 2 / max(sigma, 1e-15))
