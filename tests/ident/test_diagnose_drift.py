"""The rest drift: a free cart let go while the hand holds the other, which nobody reads.

The runs come from the independent generator `testkit.effects` (`coulomb+held_cart`: cart 2
let go with dry friction, cart 1 held by a loose, wandering hand), with the held cart's column
dropped, as in the 2023 ECP `DOF1_en2_manual2` records where only encoder 2 was recorded.
"""

from __future__ import annotations

import numpy as np
import pytest

from ident.diagnose import diagnose
from ident.diagnose.drift import MIN_SPANS, drift_basis, slow_residual
from ident.diagnose.problem import Problem
from testkit.effects import make_case


@pytest.mark.parametrize("spacing", [0.4, 1.0, 2.3])
def test_the_drift_basis_is_slow_zero_at_the_release_and_spans_every_slow_path(spacing: float) -> None:
    tau = np.arange(0.0, 6.0, 0.01)
    basis = drift_basis(tau, spacing)
    assert basis is not None
    assert np.all(basis[0] == 0.0)                       # the rest at the release is the fitted rest
    assert np.all(basis >= 0.0)
    # with the one function that is not 0 at τ = 0, the splines sum to 1; every line through the
    # origin and every C² cubic piece that starts at a knot are in the span
    assert np.all(np.sum(basis, axis=1) <= 1.0 + 1e-12)
    for path in (tau, np.maximum(tau - 2 * spacing, 0.0) ** 3):
        coef = np.linalg.lstsq(basis, path, rcond=None)[0]
        assert np.max(np.abs(basis @ coef - path)) < 1e-9 * max(1.0, float(np.max(np.abs(path))))
    # slow: a ring at 3 spacings' period or faster is nearly outside the span
    ring = np.sin(2 * np.pi * tau / (spacing / 3.0))
    coef = np.linalg.lstsq(basis, ring, rcond=None)[0]
    assert np.linalg.norm(basis @ coef) < 0.15 * np.linalg.norm(ring)


def test_a_window_shorter_than_two_spacings_has_no_drift() -> None:
    tau = np.arange(0.0, 2.0, 0.01)
    assert drift_basis(tau, tau[-1] / (MIN_SPANS - 0.1)) is None
    assert drift_basis(tau, tau[-1] / (MIN_SPANS + 0.1)) is not None


@pytest.mark.parametrize("seed", range(4))
def test_a_drift_is_offered_only_when_something_slow_is_left(seed: int) -> None:
    rng = np.random.default_rng([seed, 9])
    tau = np.arange(0.0, 8.0, 0.005)
    noise = float(rng.uniform(1e-5, 1e-4))
    basis = drift_basis(tau, 1.2)
    assert basis is not None
    ring = 0.02 * np.exp(-0.3 * tau) * np.cos(15.0 * tau)

    def offered(y: np.ndarray) -> bool:
        prob = Problem(tau, y[:, None], 0.005, np.ones(tau.size, dtype=bool), 1, 0.04, drift=basis,
                       drift_spacing_s=1.2)
        return slow_residual(prob, ring[:, None])

    assert not offered(ring + rng.normal(0.0, noise, tau.size))              # white noise only
    assert not offered(ring + 0.05 * ring + rng.normal(0.0, noise, tau.size))  # a ring misfit is no drift
    hump = 10 * noise * np.sin(np.pi * np.minimum(tau / 3.0, 1.0)) ** 2        # a slow hump of 10 noise std
    assert offered(ring + hump + rng.normal(0.0, noise, tau.size))


SEEDS = [int(s) for s in np.random.default_rng([2026, 11, 3]).integers(0, 2**31, 4)]


@pytest.mark.slow
def test_an_unread_wandering_held_cart_is_named_and_the_fit_reaches_the_noise_floor() -> None:
    named, gaps = 0, []
    for seed in SEEDS:
        case = make_case(seed, "coulomb+held_cart")
        y = case.observed.y
        free = int(np.argmax(np.ptp(y, axis=0)))          # the released cart; the held one is not read
        report = diagnose(case.observed.t, y[:, free], carts=1).report
        window = case.observed.t >= report.window_start_s
        yw, clean = y[window, free], case.truth.clean[window, free]
        floor = 100.0 * (1.0 - np.linalg.norm(yw - clean) / np.linalg.norm(yw - yw.mean()))
        effects = [e.effect for e in report.effects]
        friction = next(e for e in report.effects if e.effect == "coulomb_friction")
        error = abs(friction.parameters["coulomb_accel_m_s2"] / case.truth.parameters["coulomb_accel_m_s2"] - 1)
        print(seed, effects, f"fit {report.extended.fit_percent:.2f} floor {floor:.2f}",
              f"friction {100 * error:.1f} %")
        assert report.cause == "coulomb_friction"
        assert error <= 0.05
        named += "rest_drift" in effects
        gaps.append(floor - report.extended.fit_percent)
    assert named >= 3
    assert float(np.median(gaps)) <= 0.3


@pytest.mark.slow
def test_a_cart_dragged_in_steps_by_a_wandering_held_cart_starts_from_its_ring() -> None:
    # bench seed 1437021865 (coulomb+held_cart, seed set 11): cart 2 rings for 1.5 s, then sticks
    # and is dragged in steps by the held cart's 0.4 Hz wander for 6 s, the strongest peak of
    # its position; the linear baseline started there fitted 1.2 % and no effect was found
    case = make_case(1437021865, "coulomb+held_cart")
    report = diagnose(case.observed.t, case.observed.y, carts=1).report
    assert report.baseline.fit_percent > 50.0
    assert report.corrected_linear["wn_rad_s"] == pytest.approx(case.truth.details["wn_rad_s"], rel=0.05)
    friction = next(e for e in report.effects if e.effect == "coulomb_friction")
    assert friction.parameters["coulomb_accel_m_s2"] == pytest.approx(case.truth.parameters["coulomb_accel_m_s2"],
                                                                      rel=0.05)
