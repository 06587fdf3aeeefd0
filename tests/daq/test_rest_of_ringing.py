"""The rest the release detector judges directions by, when the stream starts during a hold.

Written from the physics, independently of `daq.sim`: one cart on its springs,
`x'' = -ω² x - 2 ζ ω x'` (x from its rest), the other cart held by a hand (a wander of a few
tenths of a mm). The stream starts while the cart is held pulled (0.05-0.15 m; daq first sees
it still there), the hand lets go, and the cart rings; 2-3.5 s later the hand catches it and
brings it to within ±1 mm of its rest, holds it there 0.4-0.8 s, swings it out to 3-5 cm in
0.15-0.25 s (a minimum-jerk path) and lets go at 80-95 % of the swing, while it moves: a flick
from a held cart. Sampled at 100-200 Hz on 50 µm counts. The truth (the two let-go instants)
is used only in the assertions.

Before, the detector's rest stayed where the carts were first still (the pulled hold): the
hold near the true rest passed as a hold away from it, the swing out as a release "toward the
rest", and the run was dated where the swing began (sim student 200171: 188 ms early; record 7
here at 200 Hz: 203 ms early). Checked: two runs, each dated within 40 ms of its let-go, a
fifth of the swing. Not the issue's one sample: a let-go near the swing's extreme, where the
hand decelerates the cart about as the spring does, is dated 20-23 ms early in 2 of these 16
records before and after (the ringing path's slide-back takes in the hand's last deceleration),
a weakness of its own.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from testkit.release_tally import detect
from testkit.synth_runs import min_jerk

Q_M = 5e-5
LIMIT_S = 0.040     # a fifth of the swing: its start is 120-240 ms before the let-go


def _free(t: np.ndarray, t0: float, x0: float, v0: float, wn: float, zeta: float) -> np.ndarray:
    """The free cart from (x0, v0) at t0, at the times t >= t0."""
    sol = solve_ivp(lambda _t, z: [z[1], -wn * wn * z[0] - 2.0 * zeta * wn * z[1]], (t0, float(t[-1]) + 1.0),
                    [x0, v0], dense_output=True, rtol=1e-10, atol=1e-13)
    return np.asarray(sol.sol(t)[0])


def _record(rng: np.random.Generator, rate_hz: float) -> tuple[np.ndarray, np.ndarray, tuple[float, float]]:
    wn, zeta = rng.uniform(8.0, 16.0), rng.uniform(0.005, 0.03)
    pull = rng.uniform(0.05, 0.15) * rng.choice([-1.0, 1.0])
    t1 = rng.uniform(0.8, 1.5)                           # the first let-go, from the pulled hold
    catch = t1 + rng.uniform(2.0, 3.5)
    hold_at = rng.uniform(-1e-3, 1e-3)
    bring_s, hold_s, swing_s = 0.15, rng.uniform(0.4, 0.8), rng.uniform(0.15, 0.25)
    amp = rng.uniform(0.03, 0.05) * rng.choice([-1.0, 1.0])
    swing0 = catch + bring_s + hold_s
    t2 = swing0 + rng.uniform(0.80, 0.95) * swing_s      # let go while the swing still moves
    end = t2 + 4.0
    t = np.arange(0.0, end, 1.0 / rate_hz) + rng.uniform(0.0, 1.0 / rate_hz)
    x = np.full(t.size, pull)
    ring = t >= t1
    x[ring] = _free(t[ring], t1, pull, 0.0, wn, zeta)
    x_catch = float(_free(np.array([catch]), t1, pull, 0.0, wn, zeta)[0])
    hand = t >= catch
    x[hand] = (x_catch + (hold_at - x_catch) * min_jerk((t[hand] - catch) / bring_s)
               + (amp - hold_at) * min_jerk((t[hand] - swing0) / swing_s))
    # the hand's position and velocity where it lets go, then the free cart
    u = (t2 - swing0) / swing_s
    x2 = hold_at + (amp - hold_at) * float(min_jerk(np.array([u]))[0])
    v2 = (amp - hold_at) * 30.0 * u * u * (1.0 - u) ** 2 / swing_s
    after = t >= t2
    x[after] = _free(t[after], t2, x2, v2, wn, zeta)
    wander = sum(a * (np.sin(w * t + p) - math.sin(p)) for a, w, p in
                 [(rng.uniform(0.5e-4, 2e-4), 2 * math.pi * rng.uniform(0.2, 1.5), rng.uniform(0, 2 * math.pi))
                  for _ in range(3)])
    pos = np.round(np.stack([np.asarray(wander), x], axis=1) / Q_M) * Q_M
    return t, pos, (t1, t2)


@pytest.mark.parametrize("rate_hz", [100, 200])
def test_a_flick_from_a_hold_near_the_rest_is_dated_where_the_hand_lets_go(rate_hz: int) -> None:
    rng = np.random.default_rng(7300 + rate_hz)
    wrong = []
    for k in range(8):
        t, pos, truth = _record(rng, rate_hz)
        found = detect((float(t[i]), (float(pos[i, 0]), float(pos[i, 1]))) for i in range(t.size))
        near = [min(found, key=lambda f: abs(f - tr)) if found else math.nan for tr in truth]
        if len(found) != 2 or not all(abs(f - tr) <= LIMIT_S for f, tr in zip(near, truth)):
            wrong.append(f"record {k}: let go at {np.round(truth, 3).tolist()} s, found {np.round(found, 3).tolist()}")
    assert not wrong, "\n".join(wrong)
