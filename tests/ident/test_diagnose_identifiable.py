"""Two carts read through cart 1's encoder: cart 2's friction is reported as f2 / k2 (metres),
the one form cart 1's reading fixes, with a standard deviation that does not depend on the
scale the fit happened to land on.

The gauge test builds a chain and its rescaled twin (x2 = α z) by hand from the equations of
motion; the diagnosis test draws its runs from the independent generator `testkit.effects`
(its own physics and integrator), whose truth is f2 / k2 for these runs.
"""

from __future__ import annotations

import numpy as np
import pytest

from ident.diagnose import diagnose
from ident.diagnose.fitting import evaluate
from ident.diagnose.identifiable import CART2_ACCEL, CART2_FRICTION, flat_direction, identifiable_friction
from ident.diagnose.models import ModelSpec
from ident.diagnose.problem import Problem
from ident.diagnose.valley import valley_chains
from testkit.effects import judge, make_case, noise_floor_percent

SPEC = ModelSpec(("coulomb_friction",), 2, {"rest_2_m": 0.0}, None, None, 1)


def _theta(lin: list[float], x0: tuple[float, float], v0: tuple[float, float], f: tuple[float, float]) -> np.ndarray:
    # linear | x0_1 x0_2 | v0_1 v0_2 | rest_1 rest_2 | F1 F2
    return np.array([*lin, *x0, *v0, 0.01, 0.0, *f], dtype=np.float64)


def _rescaled(theta: np.ndarray, alpha: float) -> np.ndarray:
    """The same run with cart 2's coordinate divided by α: b1 -> α b1, b2 -> b2/α, a1 + b1 and
    b2 + a2 kept, cart 2's state and friction divided by α."""
    out = theta.copy()
    a1, b1, b2, a2 = theta[:4]
    out[1], out[2] = alpha * b1, b2 / alpha
    out[0], out[3] = a1 + b1 - out[1], a2 + b2 - out[2]
    out[7], out[9], out[13] = theta[7] / alpha, theta[9] / alpha, theta[13] / alpha
    return out


@pytest.mark.parametrize("seed", range(3))
def test_cart_two_friction_and_its_std_are_the_same_in_any_scale(seed: int) -> None:
    rng = np.random.default_rng([seed, 71])
    m1, m2 = rng.uniform(0.5, 1.5, 2)
    k1, k2, k3 = rng.uniform(20.0, 120.0, 3)
    lin = [k1 / m1, k2 / m1, k2 / m2, k3 / m2, rng.uniform(0.05, 0.3), rng.uniform(0.05, 0.3)]
    f = (float(rng.uniform(0.05, 0.3)), float(rng.uniform(0.05, 0.3)))
    theta = _theta(lin, (0.01 - 0.05, -0.02), (0.0, 0.1), f)
    dt, n = 0.005, 1200
    clean = SPEC.predict(theta[None], dt, n)[0]
    y = clean + rng.normal(0.0, 2e-5, clean.shape)
    prob = Problem(dt * np.arange(n, dtype=np.float64), y, dt, np.ones(n, dtype=bool), 2, float(np.ptp(y)))
    alpha = float(rng.uniform(0.4, 2.5))
    twin = _rescaled(theta, alpha)
    # the twin is the same run through cart 1's encoder, and the flat direction is tangent to the family
    assert np.max(np.abs(SPEC.predict(twin[None], dt, n)[0] - clean)) < 1e-9
    res, res_twin = evaluate(SPEC, theta, dt, y, prob.train), evaluate(SPEC, twin, dt, y, prob.train)
    eps = 1e-4
    along = _rescaled(theta, 1 + eps) - theta
    assert np.allclose(flat_direction(res) * eps, along, rtol=1e-3, atol=1e-12)
    scale = np.maximum(np.abs(theta), 1e-3)
    names = ("coulomb_accel_m_s2", CART2_ACCEL)
    got, std = identifiable_friction(prob, res, scale, dict(zip(names, f)), {})
    got_twin, std_twin = identifiable_friction(prob, res_twin, _rescaled(scale, alpha),
                                               dict(zip(names, (f[0], f[1] / alpha))), {})
    assert CART2_ACCEL not in got and CART2_ACCEL not in std
    assert got[CART2_FRICTION] == pytest.approx(f[1] * m2 / k2, rel=1e-9)    # f2 / k2 with f2 = m2 F2
    assert got_twin[CART2_FRICTION] == pytest.approx(got[CART2_FRICTION], rel=1e-9)
    assert 0.0 < std[CART2_FRICTION] < 0.2 * got[CART2_FRICTION]
    assert std_twin[CART2_FRICTION] == pytest.approx(std[CART2_FRICTION], rel=0.05)
    assert std_twin["coulomb_accel_m_s2"] == pytest.approx(std["coulomb_accel_m_s2"], rel=0.05)


STATIC = ModelSpec(("coulomb_friction", "static_friction"), 2, {"rest_2_m": 0.0}, None, None, 1)


@pytest.mark.parametrize("seed", range(3))
def test_each_cart_breaks_away_at_its_own_ratio_in_any_scale(seed: int) -> None:
    # cart 2 sticks while |b2 x1 - (b2 + a2) x2| <= r2 F2: both sides scale by 1/α, so each
    # cart's own breakaway ratio is kept by the scale symmetry (identifiable where it sticks)
    rng = np.random.default_rng([seed, 72])
    m1, m2 = rng.uniform(0.5, 1.5, 2)
    k1, k2, k3 = rng.uniform(20.0, 120.0, 3)
    lin = [k1 / m1, k2 / m1, k2 / m2, k3 / m2, rng.uniform(0.05, 0.3), rng.uniform(0.05, 0.3)]
    f = (float(rng.uniform(0.3, 0.6)), float(rng.uniform(0.3, 0.6)))   # a cart sticks while the other moves
    ratios = np.array([1.0, float(rng.uniform(1.5, 2.0))])
    if seed % 2:
        ratios = ratios[::-1].copy()
    assert STATIC.names[-2:] == ("static_friction_ratio", "static_friction_ratio_cart2")
    theta = np.concatenate([_theta(lin, (0.01 - 0.05, -0.02), (0.0, 0.1), f), ratios])
    twin = np.concatenate([_rescaled(theta[:-2], float(rng.uniform(0.4, 2.5))), ratios])
    dt, n = 0.005, 1600
    clean = STATIC.predict(theta[None], dt, n)[0]
    assert np.max(np.abs(STATIC.predict(twin[None], dt, n)[0] - clean)) < 1e-9
    # and the ratios are the carts' own: swapped, or one shared, cart 1 moves otherwise
    swapped = np.concatenate([theta[:-2], ratios[::-1]])
    shared = np.concatenate([theta[:-2], np.full(2, ratios.max())])
    for other in (swapped, shared):
        assert np.max(np.abs(STATIC.predict(other[None], dt, n)[0] - clean)) > 1e-4


@pytest.mark.parametrize("seed", range(4))
def test_the_friction_starts_span_what_one_encoder_cannot_tell_apart(seed: int) -> None:
    # x1 sees the characteristic polynomial only: the one-encoder starts keep the undamped modes
    # (trace and determinant of the stiffness matrix) and the total damping, every spring
    # positive, with A = (k1 + k2)/m1 spread between the two modes' wn²
    rng = np.random.default_rng([seed, 73])
    m1, m2 = rng.uniform(0.5, 1.5, 2)
    k1, k2, k3 = rng.uniform(20.0, 120.0, 3)
    lin = [k1 / m1, k2 / m1, k2 / m2, k3 / m2, float(rng.uniform(0.05, 0.3)), float(rng.uniform(0.05, 0.3))]
    theta = _theta(lin, (-0.04, -0.02), (0.0, 0.1), (0.1, 0.1))

    def stiffness(row: np.ndarray) -> np.ndarray:
        return np.array([[row[0] + row[1], -row[1]], [-row[2], row[2] + row[3]]])

    kt = stiffness(theta)
    wn2 = np.sort(np.linalg.eigvals(kt).real)
    pairs = valley_chains(theta, SPEC)
    assert len(pairs) >= 4
    big_a = []
    for row, still in pairs:
        assert np.all(row[:4] > 0) and np.all(row[4:6] >= 0)
        assert np.trace(stiffness(row)) == pytest.approx(np.trace(kt), rel=1e-9)
        assert np.linalg.det(stiffness(row)) == pytest.approx(np.linalg.det(kt), rel=1e-9)
        assert row[4] + row[5] == pytest.approx(lin[4] + lin[5], rel=1e-9)
        assert np.array_equal(still[:6], row[:6]) and still[7] == still[11] and still[9] == 0.0
        big_a.append(row[0] + row[1])
    span = wn2[1] - wn2[0]
    assert min(big_a) < wn2[0] + 0.2 * span and max(big_a) > wn2[1] - 0.2 * span


SEEDS = [int(s) for s in np.random.default_rng([2026, 11, 2]).integers(0, 2**31, 6)]


@pytest.mark.slow
def test_cart_two_friction_through_one_encoder_is_recovered_in_its_identifiable_form() -> None:
    # tools/bench_diagnose.py --one-encoder 20: 15/20 within 5 % (7/20 in m/s², before); the
    # misses are fits that stop short of the noise floor or put cart 1's friction on cart 2
    within = 0
    for seed in SEEDS:
        case = make_case(seed, "coulomb_friction", carts=2, encoders=1)
        report = diagnose(case.observed.t, case.observed.y, carts=2).report
        friction = next(e for e in report.effects if e.effect == "coulomb_friction")
        assert CART2_ACCEL not in friction.parameters       # not identifiable: never printed as a number
        assert CART2_ACCEL not in report.extended.parameters and CART2_ACCEL not in report.extended.parameter_std
        assert report.extended.parameters[CART2_FRICTION] == friction.parameters[CART2_FRICTION]
        assert set(friction.parameter_std) >= {"coulomb_accel_m_s2", CART2_FRICTION}
        errors = judge(case, report).errors
        print(seed, errors, friction.parameters, friction.parameter_std)
        within += errors[CART2_FRICTION] <= 0.05
    assert within >= 4


@pytest.mark.slow
def test_a_linear_fit_elsewhere_in_the_one_encoder_family_still_finds_the_friction() -> None:
    # bench_diagnose --one-encoder 20 --seed 12, seed 1950055679 (friction on cart 1 only, a
    # flick): the linear chain landed at A = 107 /s² (truth 76, modes kept), and friction started
    # there stuck 0.64 points short of the noise floor with cart 1's friction 27 % off and a third
    # of it on cart 2; started across the family it reaches the floor
    case = make_case(1950055679, "coulomb_friction", carts=2, encoders=1)
    report = diagnose(case.observed.t, case.observed.y, carts=2).report
    floor = noise_floor_percent(case, report.window_start_s)
    assert report.extended.fit_percent > floor - 0.1
    assert judge(case, report).errors["coulomb_accel_m_s2"] < 0.1
