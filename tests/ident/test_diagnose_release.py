"""Release dating of a held cart, the one-encoder chain's symmetry, the rest wording.

The held-still records are written from the physics here (a cart held at -d, let go at a
time between samples, its analytic free response after), seeded noise; none comes from
`ident`'s own simulator.
"""

from __future__ import annotations

import numpy as np
import pytest

from ident.diagnose.explain import rest_words
from ident.diagnose.knot import hold_release
from ident.diagnose.window import find_window, hold_level
from ident.physics.free import NonlinearTerms, simulate_free


def _held_then_free(rate: float, t_r: float, wn: float, zeta: float, d: float, noise: float,
                    rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Held still at 0 (rest at +d) until t_r, then the damped free response from rest."""
    t = np.arange(round(6.0 * rate)) / rate
    tau = np.maximum(t - t_r, 0.0)
    wd = wn * np.sqrt(1 - zeta ** 2)
    y = d - d * np.exp(-zeta * wn * tau) * (np.cos(wd * tau) + zeta * wn / wd * np.sin(wd * tau))
    return t, y + rng.normal(0.0, noise, t.size)


@pytest.mark.parametrize("seed", range(6))
def test_a_held_cart_is_dated_within_a_fifth_of_a_sample(seed: int) -> None:
    rng = np.random.default_rng([20261124, seed])
    rate = float(np.exp(rng.uniform(np.log(50.0), np.log(1000.0))))
    t_r = float(rng.uniform(0.3, 1.5))
    wn, zeta, d = rng.uniform(5.0, 20.0), rng.uniform(0.005, 0.05), rng.uniform(0.05, 0.2)
    noise = float(np.exp(rng.uniform(np.log(5e-6), np.log(2e-4))))
    t, y = _held_then_free(rate, t_r, wn, zeta, d, noise, rng)
    hold, _, onset = hold_level(y[:, None])
    knot = hold_release(t, y, float(hold[0]), onset, 2 * np.pi / wn)
    assert knot is not None
    assert abs(knot.time_s - t_r) * rate < 0.2, (rate, t_r, knot)
    # the jump is the spring's pull per mass at the hold, wn² d (from a quartic over a tenth of
    # a period, whose truncation biases it by ~10 %)
    assert knot.jump_m_s2 == pytest.approx(wn * wn * d, rel=0.25)
    # and the window places the release there, the fit starting after it
    win = find_window(t, y[:, None], 1)
    assert abs(win.release_time_s - t_r) * rate < 0.2
    assert t[win.start] >= t_r


def _flick(rate: float, t0: float, t1: float, x1: float, v1: float, wn: float, sigma: float, noise: float,
           rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """From rest at 0, the hand's C¹ cubic to x1 with velocity v1 at t1, then the damped free
    response e^{-στ}(x1 cos ωτ + (v1 + σ x1)/ω sin ωτ) from there."""
    t = np.arange(round(5.0 * rate)) / rate
    s = np.clip((t - t0) / (t1 - t0), 0.0, 1.0)
    hand = (3 * s * s - 2 * s ** 3) * x1 + (s ** 3 - s * s) * v1 * (t1 - t0)
    tau = np.maximum(t - t1, 0.0)
    w = np.sqrt(wn * wn - sigma * sigma)
    free = np.exp(-sigma * tau) * (x1 * np.cos(w * tau) + (v1 + sigma * x1) / w * np.sin(w * tau))
    return t, np.where(t > t1, free, hand) + rng.normal(0.0, noise, t.size)


@pytest.mark.parametrize("seed", range(6))
def test_a_flick_is_dated_where_the_hand_lets_go(seed: int) -> None:
    # the hand's acceleration at t1 is -6 x1/D² + 4 v1/D, the spring's -wn² x1 - 2σ v1: the jump
    # between them dates the release; it is asked within one sample where that jump moves the
    # cart by 20 noise std within a tenth of a period (else nothing in the record dates it)
    rng = np.random.default_rng([20261125, seed])
    rate = float(np.exp(rng.uniform(np.log(50.0), np.log(1000.0))))
    wn, zeta = rng.uniform(5.0, 20.0), rng.uniform(0.005, 0.05)
    t0, dur = rng.uniform(0.3, 1.0), rng.uniform(0.1, 0.2)
    x1 = float(rng.choice([-1.0, 1.0]) * rng.uniform(0.02, 0.06))
    v1 = float(rng.uniform(-0.5, 0.5) * wn * abs(x1))
    noise = float(np.exp(rng.uniform(np.log(5e-6), np.log(2e-4))))
    t, y = _flick(rate, t0, t0 + dur, x1, v1, wn, zeta * wn, noise, rng)
    win = find_window(t, y[:, None], 1)
    jump = abs(-6 * x1 / dur ** 2 + 4 * v1 / dur + wn * wn * x1 + 2 * zeta * wn * v1)
    if jump * (0.1 * 2 * np.pi / wn) ** 2 / 2 > 20 * noise:
        assert abs(win.release_time_s - (t0 + dur)) * rate <= 1.0, (rate, jump, win.release_time_s, t0 + dur)
    assert win.release_time_s > t0 + 0.05   # never where the hand started to move it
    assert t[win.start] >= win.release_time_s


def test_cart_two_seen_through_one_encoder_has_no_scale_of_its_own() -> None:
    # x2 = α z maps b = k2/m1, c = k2/m2, F2, x2(0), v2(0) to α b, c / α, F2 / α, z(0), z'(0)
    # with a = (k1+k2)/m1 and d = (k2+k3)/m2 kept, and leaves cart 1's motion unchanged, dry
    # friction included: cart 2's friction (m/s²) is not identifiable from cart 1's encoder alone (docs/diagnosis.md)
    lin = np.array([60.0, 40.0, 55.0, 70.0, 0.3, 0.2])
    z0 = np.array([-0.1, 0.02, 0.0, 0.1])
    f = np.array([0.2, 0.5])
    alpha = 1.7
    lin_a = lin.copy()
    lin_a[1], lin_a[2] = lin[1] * alpha, lin[2] / alpha
    lin_a[0], lin_a[3] = lin[0] + lin[1] - lin_a[1], lin[3] + lin[2] - lin_a[2]
    z0_a = z0.copy()
    z0_a[1], z0_a[3] = z0[1] / alpha, z0[3] / alpha
    f_a = np.array([f[0], f[1] / alpha])
    out = simulate_free(np.array([lin, lin_a]), np.array([z0, z0_a]), 0.005, 1200, 2,
                        NonlinearTerms(friction_m_s2=np.array([f, f_a])))
    assert np.max(np.abs(out[0, :, 0] - out[1, :, 0])) < 1e-9
    # cart 2 itself moves differently: the symmetry is in what cart 1's encoder sees only
    assert np.max(np.abs(out[0, :, 1] - out[1, :, 1])) > 1e-3


def test_a_record_that_ends_moving_is_not_said_to_rest() -> None:
    assert "still moving" in rest_words(0.0, 0.01)
    assert "at rest for the last 1.50 s" in rest_words(1.5, 0.01)
