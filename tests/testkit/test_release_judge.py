"""`testkit.release_judge` on flicks simulated from the physical description of the real ones.

The hand's push (measured on the ECP-210 2025 records, see docs/daq.md): it rises over
0.10-0.25 s to 10-19 m/s², peaks 20-100 ms before the let-go and is still 3-9 m/s² there; it
ends at once or comes down to zero over up to 20 ms. The cart: wn 14.5-16.5 rad/s, ζ 0.01-0.04,
dry friction 0.2-0.5 m/s², read at 1/56,000 m on samples 1.05-1.2 ms apart stamped in whole ms
(as the ECP-210 does). Truth: where the hand's force ends (the free response begins there).
Written from that description, not from the judge: solve_ivp with a steep tanh for the
friction, not the judge's RK4.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pytest
from scipy.integrate import solve_ivp

from testkit.release_judge import judge_release

Array = npt.NDArray[np.float64]


def _flick(seed: int, fade_s: float) -> tuple[Array, Array, float, float]:
    """(stamps s, position m, end of the hand's force s, start of its fade s)."""
    rng = np.random.default_rng(seed)
    wn, zeta, dry = rng.uniform(14.5, 16.5), rng.uniform(0.01, 0.04), rng.uniform(0.2, 0.5)
    sign = float(rng.choice([-1.0, 1.0]))
    push = rng.uniform(0.10, 0.25)
    decline = rng.uniform(0.02, min(0.10, push - 0.05))
    peak, at_let_go = rng.uniform(10.0, 19.0), rng.uniform(3.0, 9.0)
    t_start = rng.uniform(0.4, 0.6)
    t_peak = t_start + push - decline
    t_fade = t_start + push
    t_end = t_fade + fade_s

    def hand(t: float) -> float:
        if t < t_start or t >= t_end:
            return 0.0
        if t < t_peak:
            return float(peak * np.sin(0.5 * np.pi * (t - t_start) / (t_peak - t_start)) ** 2)
        if t < t_fade:
            return float(peak + (at_let_go - peak) * (t - t_peak) / decline)
        return float(at_let_go * (t_end - t) / fade_s)

    def rhs(t: float, s: Array) -> list[float]:
        x, v = s
        return [v, -wn ** 2 * x - 2 * zeta * wn * v - dry * np.tanh(v / 3e-4) + sign * hand(t)]

    dt = rng.uniform(1.05e-3, 1.2e-3)
    t = np.arange(0.0, 2.5, dt) + rng.uniform(0.0, dt)
    sol = solve_ivp(rhs, (0.0, float(t[-1]) + 0.01), [0.0, 0.0], t_eval=t, max_step=2e-4, rtol=1e-8, atol=1e-10)
    x = np.round(sol.y[0] * 56000.0) / 56000.0
    return np.round(t * 1000.0) / 1000.0, x, t_end, t_fade


@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_a_hand_that_lets_go_at_once_is_dated_within_two_ms(seed: int) -> None:
    t, x, t_end, _ = _flick(seed, 0.0)
    by_eye = t_end + np.random.default_rng(seed + 100).uniform(-0.1, 0.1)
    assert abs(judge_release(t, x, by_eye) - t_end) <= 0.002


@pytest.mark.parametrize("seed", [5, 6, 7, 8])
def test_a_force_that_fades_is_dated_within_its_fade(seed: int) -> None:
    fade = np.random.default_rng(seed + 200).uniform(0.005, 0.02)
    t, x, t_end, t_fade = _flick(seed, fade)
    by_eye = t_end + np.random.default_rng(seed + 100).uniform(-0.1, 0.1)
    judged = judge_release(t, x, by_eye)
    assert t_fade - 0.001 <= judged <= t_end + 0.002, (judged - t_fade, t_end - t_fade)
