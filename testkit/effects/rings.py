"""A cart let go from a still hold, with a second mass's ring, in closed form (no integrator).

One cart with a second mass on a spring, read at the cart, is a sum of two damped rings after
a release from rest: the cart's own mode and the second mass's. Written from the linear
system's modes, independently of `ident`, for tests whose second ring must be known exactly.
"""

from __future__ import annotations

import numpy as np

from testkit.effects.rig import FloatArray


def released_with_second_ring(t: FloatArray, t_r: float, pull: float, wn: float, sigma: float,
                              a2: float, f2_hz: float, decay2: float) -> FloatArray:
    """Position (m) at `t` (s) of a cart held still at -`pull` until `t_r` and let go from rest:
    its ring (undamped ω `wn` rad/s, decay `sigma` 1/s, so that it starts at rest) plus a second
    ring of amplitude `a2` m at `f2_hz` decaying at `decay2` 1/s, set off at the release from zero
    displacement (the held pair was at rest)."""
    tau = np.maximum(t - t_r, 0.0)
    wd = float(np.sqrt(wn ** 2 - sigma ** 2))
    main = -pull * np.exp(-sigma * tau) * (np.cos(wd * tau) + sigma / wd * np.sin(wd * tau))
    second = a2 * np.exp(-decay2 * tau) * np.sin(2 * np.pi * f2_hz * tau)
    return np.asarray(np.where(t < t_r, -pull, main + second), dtype=np.float64)
