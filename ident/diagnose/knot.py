"""Where the hand lets go of a cart it held still: the acceleration jump at the first motion.

When a hand lets a held cart go, position and velocity are continuous (the cart is at rest)
but the hand's force drops to zero at once: the acceleration jumps from 0 to the spring's
pull per mass, wn² d. The record is the hold level until t_r and a smooth curve leaving it
with zero slope after, so t_r is found by least squares on a sub-sample grid, well within one
sample even when the motion onset (a threshold crossing) lags it by several. No I/O here.
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
