"""A pull-hold-release while the other cart is held by a loose hand: dated where the hand lets go.

The two-cart chain (wall -k1- cart 1 -k2- cart 2 -k3- wall) is integrated here by scipy's own
Runge-Kutta at a tight tolerance (no `ident` code). The hand pulls cart 1 to 4-9 cm, holds it
still and lets go between two samples; cart 2 is held by a hand that is a soft spring (20-50
times k2: the cart follows cart 1 by 2-5 %, damped) around a point that wanders by a few mm. Read at
1 kHz by a 10 µm encoder with 3 µm noise. Right after the let-go the held cart's following and
the free model's stiffness (fitted on the whole record) each leave a few per cent of the hold's
force in the residual: the release must still be dated within one sample.
"""

from __future__ import annotations

from itertools import pairwise

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from ident.releases import find_releases

RATE_HZ = 1000.0


def _hold_release(seed: int, pull_m: tuple[float, float] = (0.04, 0.09),
                  hold_s: tuple[float, float] = (0.3, 1.0)) -> tuple[np.ndarray, np.ndarray, float]:
    rng = np.random.default_rng(seed)
    m = rng.uniform(0.5, 1.5, 2)
    k = rng.uniform(20.0, 120.0, 3)
    zeta = rng.uniform(0.005, 0.04, 2)
    c = 2 * zeta * np.sqrt(np.array([k[0] + k[1], k[1] + k[2]]) * m)
    k_hand = k[1] / rng.uniform(0.02, 0.05)
    c_hand = k_hand * rng.uniform(0.02, 0.03)              # N·s/m: a hand damps (ζ ≈ 0.3-0.7)
    wander, wander_hz = rng.uniform(2e-3, 7e-3), rng.uniform(0.1, 0.4)
    held_at = rng.choice([-1.0, 1.0]) * rng.uniform(*pull_m)
    start, pull, hold = 0.8, rng.uniform(0.4, 0.8), rng.uniform(*hold_s)
    release = start + pull + hold + rng.uniform(0.0, 1.0 / RATE_HZ)    # between samples

    def pulled(t: float) -> tuple[float, float, float]:
        """Cart 1's position, velocity and acceleration while the hand has it (min-jerk pull)."""
        s = min(max((t - start) / pull, 0.0), 1.0)
        return (held_at * (10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5),
                held_at * (30 * s ** 2 - 60 * s ** 3 + 30 * s ** 4) / pull,
                held_at * (60 * s - 180 * s ** 2 + 120 * s ** 3) / pull ** 2)

    def hand_on_cart_2(t: float, x2: float, v2: float) -> float:
        w = 2 * np.pi * wander_hz
        target, target_v = wander * np.sin(w * t), wander * w * np.cos(w * t)
        return k_hand * (target - x2) + c_hand * (target_v - v2)

    def cart_2(t: float, x1: float, x2: float, v2: float) -> float:
        return (-(k[1] + k[2]) * x2 + k[1] * x1 - c[1] * v2 + hand_on_cart_2(t, x2, v2)) / m[1]

    def held(t: float, z: np.ndarray) -> list[float]:          # z = (x2, v2); cart 1 in the hand
        return [z[1], cart_2(t, pulled(t)[0], z[0], z[1])]

    def free(t: float, z: np.ndarray) -> list[float]:          # z = (x1, v1, x2, v2)
        a1 = (-(k[0] + k[1]) * z[0] + k[1] * z[2] - c[0] * z[1]) / m[0]
        return [z[1], a1, z[3], cart_2(t, z[0], z[2], z[3])]

    t = np.arange(0.0, release + 4.0, 1.0 / RATE_HZ)
    x = np.empty((t.size, 2))
    before = t < release
    sol = solve_ivp(held, (0.0, release), [0.0, 0.0], rtol=1e-11, atol=1e-13, max_step=2e-4,
                    dense_output=True)
    x[before, 0] = [pulled(float(s))[0] for s in t[before]]
    x[before, 1] = sol.sol(t[before])[0]
    x1, v1, _ = pulled(release)
    z = [x1, v1, *sol.y[:, -1]]
    for a, b in pairwise([release, t[-1] + 1e-9]):
        after = (t >= a) & (t < b)
        sol = solve_ivp(free, (a, b), z, rtol=1e-11, atol=1e-13, max_step=2e-4, dense_output=True)
        x[after] = sol.sol(t[after])[[0, 2]].T
    y = 1e-5 * np.round((x + rng.normal(0.0, 3e-6, x.shape)) / 1e-5)
    return t, y - y[0], release


@pytest.mark.parametrize("seed", range(4))
def test_a_hold_released_beside_a_loosely_held_cart_is_dated_within_one_sample(seed: int) -> None:
    t, y, release = _hold_release(seed)
    found = find_releases(t, y)
    assert len(found) == 1
    assert found[0].pulled_cart == 1 and found[0].moving_carts == (1,)
    assert abs(found[0].release_time_s - release) <= 1.0 / RATE_HZ


@pytest.mark.parametrize("seed", range(4))
def test_a_short_pull_held_for_seconds_beside_a_wandering_cart_is_one_release(seed: int) -> None:
    """A 2.5-4 cm pull held 1.5-3 s: over that long the held cart's few mm of wander reach a
    fifth of the pull, which is no touch of it (it moves no more than it does all record).
    Found once, as the benchmarks match a release (within 0.25 s): a weak hold on a soft
    spring (seed 0: 1.5 m/s² at ω 6.3 rad/s) is dated 135 ms late, a weakness of the instant
    and not of what this test is about."""
    t, y, release = _hold_release(seed, pull_m=(0.025, 0.04), hold_s=(1.5, 3.0))
    found = find_releases(t, y)
    assert [round(r.release_time_s, 4) for r in found] == pytest.approx([release], abs=0.25)
    assert found[0].pulled_cart == 1
