"""The release instant: where the hand's force on the pulled cart has ended.

The hand episodes (`hand`) come from accelerations smoothed over a tenth of a period, which
blurs where a force ends by half that window. Here the same free equation of motion is
evaluated with derivatives over a window four times shorter (a 25th of a period, at least
5 samples), which is noisier but sharp, and the release is the sample after the last one,
after the episode's peak force and before the first stretch of T/12 where it stays
below the limit, where that finer residual |r| exceeds

    max(FRACTION_OF_PEAK · max|r| over the episode, NOISE_SIGMAS · its robust std in the
        free period that follows):

a hand lets go by ramping its force down, and the free response begins where the force is
down to a tenth of its peak. No I/O.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import savgol_filter

from ident.releases.hand import FreeModel, regressors
from ident.releases.motion import Motion

FINE_FRACTION = 1.0 / 25.0
FRACTION_OF_PEAK = 0.1
NOISE_SIGMAS = 4.0
#: The force has ended when the residual stays below the limit this fraction of a period.
QUIET_FRACTION = 1.0 / 12.0


def release_instant(m: Motion, model: FreeModel, first: int, last: int) -> int:
    """Index of the release after the hand episode [first, last] of `model.column`."""
    period_n = m.samples(m.period_s)
    window = max(5, 2 * round(FINE_FRACTION * period_n / 2) + 1)
    lo = max(0, first - window)
    hi = min(m.n_samples, last + 2 * period_n)
    if hi - lo <= window:
        return min(last + 1, m.n_samples - 1)
    part = m.y[lo:hi]
    fine = Motion(m.t[lo:hi], part, savgol_filter(part, window, 3, axis=0),
                  savgol_filter(part, window, 3, deriv=1, delta=m.dt, axis=0),
                  savgol_filter(part, window, 3, deriv=2, delta=m.dt, axis=0),
                  m.dt, m.period_s, m.noise_m)
    coef = np.concatenate([model.stiffness, [model.viscous, model.dry, model.offset]])
    resid = fine.a[:, model.column] - regressors(fine, model.column, model.others, model.v_smooth) @ coef
    after = np.abs(resid[last + m.samples(m.period_s / 4) - lo:last + period_n - lo])
    noise = float(np.median(after)) / 0.6745 if after.size else 0.0
    peak = float(np.max(np.abs(resid[first - lo:last + 1 - lo])))
    limit = max(FRACTION_OF_PEAK * peak, NOISE_SIGMAS * noise)
    seg = np.abs(resid[first - lo:hi - lo])
    start = int(np.argmax(seg[:last + 1 - first]))
    quiet = m.samples(m.period_s * QUIET_FRACTION)
    loud = np.flatnonzero(seg[start:] > limit) + start
    # the first gap between loud samples that lasts a quiet stretch: the force has ended
    gaps = np.flatnonzero(np.diff(np.concatenate([loud, [seg.size + quiet]])) > quiet)
    release = first + int(loud[gaps[0]]) + 1 if loud.size else last + 1
    return min(release, m.n_samples - 1)
