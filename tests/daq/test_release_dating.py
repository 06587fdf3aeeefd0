"""`daq.release_dating.date_release` against an independent ODE solve of a hand's force that
ends at the release (the truth is used only in the assertions).

A cart on a spring with viscous damping, `x'' = -wn² x - 2 ζ wn x' + h(t)`, with a hand force
per unit mass `h(t) = F_r + S (t_r - t)` before the release t_r and 0 after (the shape measured
on the real ECP-210 flicks: still 0.2-1.2 times the spring's pull when the hand lets go, ending
at once). Solved by `scipy.integrate.solve_ivp` (not `ident.physics`), sampled, quantized.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from daq.release_dating import date_release
from daq.ringing import fit_free, motion_sign

WN, ZETA = 11.0, 0.03


def _flick(t_r: float, x_r: float, v_r: float, ratio: float, slope: float, rate_hz: float, q_m: float,
           rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Samples (t, quantized x) of a flick: state (x_r, v_r) at the release, the hand's force at
    let-go `ratio` times the spring's pull (outward), growing by `slope` m/s³ going back in time."""
    f_r = ratio * WN ** 2 * x_r
    direction = math.copysign(1.0, x_r)

    def rhs(t: float, z: np.ndarray) -> list[float]:
        hand = f_r + direction * slope * (t_r - t) if t < t_r else 0.0
        return [z[1], -WN ** 2 * z[0] - 2 * ZETA * WN * z[1] + hand]

    t_start, t_end = t_r - 0.12, t_r + 1.2
    phase = rng.uniform(0.0, 1.0)
    t = t_start + (np.arange(int((t_end - t_start) * rate_hz)) + phase) / rate_hz
    back = t[t < t_r][::-1]
    ahead = t[t >= t_r]
    kw = dict(rtol=1e-10, atol=1e-12, max_step=1e-3)
    x_back = solve_ivp(rhs, (t_r, back[-1]), [x_r, v_r], t_eval=back, **kw).y[0][::-1]
    x_ahead = solve_ivp(rhs, (t_r, ahead[-1]), [x_r, v_r], t_eval=ahead, **kw).y[0]
    x = np.concatenate([x_back, x_ahead])
    return t, np.round(x / q_m) * q_m


@pytest.mark.parametrize("rate_hz", [50, 100, 200, 1000])
def test_a_hand_force_ending_at_the_release_is_dated_within_one_sample(rate_hz: int) -> None:
    rng = np.random.default_rng(rate_hz)
    half = math.pi / WN
    errors = []
    for _ in range(12):
        x_r = rng.uniform(0.03, 0.07) * rng.choice([-1.0, 1.0])
        v_r = math.copysign(rng.uniform(0.2, 0.6), x_r)                 # still moving outward
        ratio, slope = rng.uniform(0.3, 1.2), rng.uniform(0.0, 60.0)   # m/s² per s going back
        t_r = 1.0 + rng.uniform(0.0, 1.0 / rate_hz)
        t, y = _flick(t_r, x_r, v_r, ratio, slope, rate_hz, 5e-5, rng)
        vs = motion_sign(t, y)
        window = (t >= t_r + 0.3) & (t <= t_r + 0.3 + 1.5 * half)
        free = fit_free(t[window], y[window], 0.0 * vs[window], 0.0, WN)
        assert free is not None
        # the coarse start as the detector's slide-back leaves it: within a few samples
        t_coarse = t_r + rng.uniform(-3.0, 3.0) / rate_hz
        date = date_release(t, y, 0.0 * vs, free, t_coarse, half)
        assert date is not None
        errors.append(date.t0_s - t_r)
        # the spring's and damper's acceleration at the release, from the fitted free response
        print(rate_hz, (date.t0_s - t_r) * rate_hz, date.accel_m_s2 / abs(WN ** 2 * x_r + 2 * ZETA * WN * v_r))
    assert max(abs(e) for e in errors) <= 1.0 / rate_hz, errors
