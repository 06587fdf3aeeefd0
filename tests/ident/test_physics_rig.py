"""The sim rig's stepper (`ident.physics.rig.advance`) while a hand holds a cart, against
closed forms and an independent ODE solve of the chain with the held cart's path imposed."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from ident.physics.rig import ChainParams, ChainState, Grip, advance

DT = 5e-4


def _params(**changes: float) -> ChainParams:
    base = dict(carts=2, m1=0.8, m2=0.7, k1=60.0, k2=45.0, k3=50.0, c1=0.5, c2=0.6, fc1=0.0, fc2=0.0, cubic=0.0)
    base.update(changes)
    return ChainParams(**base)  # type: ignore[arg-type]


def _run(p: ChainParams, s: ChainState, seconds: float, path1: object, path2: object,
         per_call: int = 10) -> tuple[np.ndarray, np.ndarray]:
    """Advance in calls of `per_call` steps (as the rig does per sample); t (K,), (x1, x2) (K, 2)."""
    ts, xs = [], []
    for _ in range(round(seconds / (DT * per_call))):
        advance(p, s, DT, per_call, path1, path2)  # type: ignore[arg-type]
        ts.append(s.t)
        xs.append((s.x1, s.x2))
    return np.array(ts), np.array(xs)


def test_cart_2_rings_about_the_hands_fixed_position_with_wn2_k2_plus_k3_over_m2() -> None:
    # cart 1 held still at p: m2 x2'' = -k2 (x2 - p) - k3 x2 - c2 x2'  (from rest at 0)
    p = _params()
    hold = -0.1
    t, x = _run(p, ChainState(x1=hold), 3.0, lambda _t: hold, None)
    wn = math.sqrt((p.k2 + p.k3) / p.m2)
    zeta = p.c2 / (2 * p.m2 * wn)
    wd = wn * math.sqrt(1 - zeta ** 2)
    centre = p.k2 * hold / (p.k2 + p.k3)
    exact = centre - centre * np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta * wn / wd * np.sin(wd * t))
    assert np.all(x[:, 0] == hold)
    assert np.max(np.abs(x[:, 1] - exact)) < 1e-9


def test_cart_1_follows_a_moving_hand_and_cart_2_matches_an_independent_ode_solve() -> None:
    # the hand moves cart 2 along a smooth path; cubic springs and the coupling's cubic part
    # act on cart 1: reference = solve_ivp of cart 1's equation with x2 = path imposed
    p = _params(cubic=30.0)
    amp, omega = 0.08, 5.0

    def path(t: float) -> float:
        return amp * (1.0 - math.cos(omega * t))

    def rhs(t: float, z: np.ndarray) -> list[float]:
        x1, v1 = z
        e12 = path(t) - x1
        force = (-p.k1 * (x1 + p.cubic * x1 ** 3) + p.k2 * (e12 + p.cubic * e12 ** 3) - p.c1 * v1)
        return [v1, force / p.m1]

    t, x = _run(p, ChainState(), 4.0, None, path)
    ref = solve_ivp(rhs, (0.0, 4.0), [0.0, 0.0], t_eval=t, rtol=1e-10, atol=1e-12, method="DOP853")
    assert np.max(np.abs(x[:, 1] - [path(ti) for ti in t])) < 1e-12
    assert np.max(np.abs(x[:, 0] - ref.y[0])) < 2e-7          # 0.2 µm on a 10 cm motion


def test_free_cart_with_dry_friction_beside_a_held_cart_loses_2f_over_wn2_per_half_cycle() -> None:
    # undamped cart 2, Coulomb F = fc2/m2 (m/s²) about the centre set by the held cart 1
    p = _params(c2=0.0, fc2=0.35)
    s = ChainState(x2=0.06)
    _, x = _run(p, s, 6.0, lambda _t: 0.0, None, per_call=1)
    wn2 = (p.k2 + p.k3) / p.m2
    step = 2 * (p.fc2 / p.m2) / wn2
    z = x[:, 1]
    k = np.flatnonzero((z[1:-1] - z[:-2]) * (z[2:] - z[1:-1]) < 0) + 1
    peaks = np.abs(z[k])
    expected = 0.06 - step * np.arange(1, peaks.size + 1)
    assert peaks.size >= 5
    assert np.max(np.abs(peaks - expected)) < 2e-5
    stuck = abs(z[-1])
    assert wn2 * stuck <= p.fc2 / p.m2 + 1e-12                   # the spring cannot beat the friction
    assert np.all(z[-200:] == z[-1])


def test_a_cart_let_go_leaves_with_the_hands_speed() -> None:
    speed = 0.3
    s = ChainState()
    p = _params()
    advance(p, s, DT, 40, lambda t: speed * t, None)
    assert s.v1 == pytest.approx(speed, rel=1e-12)
    assert s.x1 == pytest.approx(speed * 40 * DT, rel=1e-12)


def test_one_cart_rig_held_by_the_hand_is_the_path_and_cart_2_stays_clamped() -> None:
    p = _params(carts=1)
    s = ChainState()
    advance(p, s, DT, 10, lambda t: 0.5 * t * t, lambda _t: 1.0)
    assert (s.x1, s.x2, s.v2) == (pytest.approx(0.5 * (10 * DT) ** 2), 0.0, 0.0)
    assert s.v1 == pytest.approx(10 * DT, rel=1e-9)


@pytest.mark.parametrize("carts", [1, 2])
def test_a_gripping_hand_is_a_spring_and_damper_towards_its_path(carts: int) -> None:
    # a hand grips cart 1 (cart 2 pinned by the other hand for carts=2) and swings it along a
    # half cosine; reference: solve_ivp of m1 x1'' = -(k1 + k2) x1 - c1 x1' + m1 h, with
    # h = wg² (p - x1) + 2 zg wg (p' - x1') (cart 2 held at 0, or clamped for carts=1)
    p = _params(carts=carts, cubic=0.0)
    wg, zg, amp, dur = 50.0, 0.7, 0.05, 0.2

    def path(t: float) -> float:
        return 0.5 * amp * (1.0 - math.cos(math.pi * min(t, dur) / dur))

    def speed(t: float) -> float:
        return 0.5 * amp * math.pi / dur * math.sin(math.pi * t / dur) if t < dur else 0.0

    def rhs(t: float, z: np.ndarray) -> list[float]:
        x1, v1 = z
        hand = wg ** 2 * (path(t) - x1) + 2 * zg * wg * (speed(t) - v1)
        return [v1, (-(p.k1 + p.k2) * x1 - p.c1 * v1) / p.m1 + hand]

    grip = Grip(path, wg, zg)
    t, x = _run(p, ChainState(), 1.0, grip, (lambda _t: 0.0) if carts == 2 else None)
    ref = solve_ivp(rhs, (0.0, t[-1]), [0.0, 0.0], t_eval=t, rtol=1e-10, atol=1e-12, method="DOP853", max_step=1e-3)
    assert np.max(np.abs(x[:, 0] - ref.y[0])) < 2e-6        # 2 µm on a 5 cm swing
    # held still, the grip balances the spring: x = wg² p / (wg² + (k1 + k2)/m1), short of the path
    assert x[-1, 0] == pytest.approx(wg ** 2 * amp / (wg ** 2 + (p.k1 + p.k2) / p.m1), rel=1e-4)


def test_a_released_grip_leaves_the_cart_with_its_own_speed_and_the_hands_force_gone() -> None:
    p = _params()
    s = ChainState()
    grip = Grip(lambda t: 0.4 * t, 40.0, 0.8)
    advance(p, s, DT, 400, grip, lambda _t: 0.0)
    x, v = s.x1, s.v1
    assert 0.0 < x < 0.4 * s.t and v > 0.0                 # the grip drags the cart, which lags the hand
    advance(p, s, DT, 1, None, lambda _t: 0.0)             # let go: the spring alone decelerates it
    accel = (s.v1 - v) / DT
    assert accel == pytest.approx(-(p.k1 + p.k2) / p.m1 * x - p.c1 / p.m1 * v, rel=0.02)
