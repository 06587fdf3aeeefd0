"""Where carts that had come to rest move again: a touch, whatever its force.

A free response ends at rest: dry friction holds a cart still once its spring force falls
below static friction, and a viscous one decays into the noise. Nothing in a free response
starts a cart that is still while every free cart is still, so a later departure from that
rest is a hand: a touch of the cart itself, or of a held cart that moves it through the
spring. Such a touch (an unread held cart shifted by hand moves the read cart by a fraction
of a millimetre, the 2023 hand steps' ~4.6 s bump) can push with less than the hand episodes'
limit: it is seen from the positions instead. No I/O.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ident.releases.motion import Motion

#: Carts are at rest where each free column stays within this many noise stds (peak to
#: peak) for `REST_PERIODS` periods...
REST_SIGMAS = 6.0
REST_PERIODS = 1.0
#: ... and a cart has moved again when it leaves that rest by this many noise stds.
DEPART_SIGMAS = 8.0
#: ... for this many periods.
PERSIST_PERIODS = 0.25


def moved_after_rest(m: Motion, columns: list[int], start: int, end: int) -> int | None:
    """The first index in (start, end] where one of `columns` leaves the rest all of them had
    come to after `start` (still within `REST_SIGMAS` noise stds for `REST_PERIODS`·T):
    where one of them was last within half that band of the rest before leaving it by
    `DEPART_SIGMAS` noise stds (or stds of the readings at rest, when fewer) for
    `PERSIST_PERIODS`·T, less half a smoothing window (the smoothed positions see a
    departure that early); None when they never rest, or never leave it."""
    from scipy.ndimage import maximum_filter1d, minimum_filter1d  # deferred: keeps `import ident` fast
    width = m.samples(REST_PERIODS * m.period_s)
    if end - start <= width or not columns:
        return None
    x = m.x[start:end + 1][:, columns]
    noise = np.maximum(m.noise_m[columns], 1e-12)
    # the peak-to-peak over the `width` samples from each index on, per column (a centred
    # filter's value at i + width//2)
    spread = maximum_filter1d(x, width, axis=0) - minimum_filter1d(x, width, axis=0)
    ahead = spread[width // 2:x.shape[0] - width + 1 + width // 2]
    still: NDArray[np.bool_] = np.all(ahead <= REST_SIGMAS * noise, axis=1)
    rests = np.flatnonzero(still)
    if rests.size == 0:
        return None
    # (half a period on: the first still stretch may hold the last settling step)
    at = min(int(rests[0]) + width // 2, x.shape[0] - width)
    level = np.median(x[at:at + width], axis=0)
    # the readings' own scatter at rest, when quieter than the record's noise: a coarse
    # lattice reads a stuck cart as one value, and one step off it is a move
    quiet = np.std(m.y[start + at:start + at + width][:, columns], axis=0)
    band = np.minimum(noise, np.maximum(quiet, 1e-6 * noise))
    off = np.abs(x[at + width:] - level) / band
    # away for a quarter period (a noise flip across a lattice line is back within a window)
    away = np.any(off > DEPART_SIGMAS, axis=1).astype(np.float64)
    last = m.samples(PERSIST_PERIODS * m.period_s)
    if away.size < last:   # the rest lasts to the end: too little left to leave it for long
        return None
    held = np.convolve(away, np.ones(last), mode="valid") >= last
    gone = np.flatnonzero(held)
    if gone.size == 0:
        return None
    # the move began where the carts were last within half the rest band
    within = np.flatnonzero(np.all(off[:gone[0] + 1] <= REST_SIGMAS / 2, axis=1))
    began = int(within[-1]) if within.size else 0
    return max(start + 1, start + at + width + began - m.window // 2)
