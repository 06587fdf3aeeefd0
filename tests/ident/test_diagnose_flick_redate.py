"""A flick's release dated again on the fitted model (`ident.diagnose.redate`).

The window's join fitted the free response after the let-go as modes with free amplitudes
and a constant: where the hand's acceleration jumps little, it could not follow a cart's
friction flipping at the cart's first turn, and dated generated two-cart flicks read through
cart 1's encoder up to 18 samples late. The join on the fitted model (run backward from the
window's first sample) dates them within a sample. The join itself is checked on a record
written here from the physics (an analytic two-mode free response, a cubic hand path).
"""

from __future__ import annotations

import numpy as np
import pytest

from ident.diagnose import diagnose
from ident.diagnose.knot import model_join
from ident.physics.free import NonlinearTerms, run_maps, step_maps
from testkit.effects import make_case


def _two_modes(t: np.ndarray, t_r: float) -> np.ndarray:
    """A free response from t_r: two damped modes about a rest of 1 mm (m)."""
    tau = t - t_r
    return (1e-3 + 0.03 * np.exp(-0.2 * tau) * np.cos(9.0 * tau + 0.4)
            + 0.006 * np.exp(-0.5 * tau) * np.sin(17.0 * tau + 1.1))


@pytest.mark.parametrize("seed", range(4))
def test_the_join_on_a_known_free_response_dates_a_small_jump_within_a_fifth_of_a_sample(seed: int) -> None:
    rng = np.random.default_rng([20261201, seed])
    rate = float(np.exp(rng.uniform(np.log(50.0), np.log(1000.0))))
    t_r = 0.5 + float(rng.uniform(0.0, 1.0)) / rate          # between samples
    t = np.arange(round(0.9 * rate)) / rate
    free = _two_modes(t, t_r)
    # the hand's path: the free response's position and velocity at t_r, an acceleration
    # 0.5 m/s² off the free one and a jerk of its own (a push the hand ends)
    before, p, after = (float(f) for f in _two_modes(np.array([t_r - 1e-4, t_r, t_r + 1e-4]), t_r))
    v, acc = (after - before) / 2e-4, (after - 2 * p + before) / 1e-8
    tau = t - t_r
    hand = p + v * tau + 0.5 * (acc - 0.5) * tau ** 2 + 4.0 * tau ** 3
    clean = np.where(tau < 0, hand, free)
    y = clean + rng.normal(0.0, 5e-6, t.size)
    pushed = t >= 0.35                                          # the push's stretch on
    lo, hi = int(np.searchsorted(t[pushed], 0.4)), int(np.searchsorted(t[pushed], 0.65))
    knot = model_join(t[pushed], y[pushed], free[pushed], lo, hi)
    assert knot is not None
    assert abs(knot.time_s - t_r) * rate < 0.2, (rate, knot)
    assert knot.jump_m_s2 == pytest.approx(0.5, rel=0.3)


def test_a_chain_with_friction_run_backward_retraces_its_forward_run() -> None:
    """`dt` < 0 runs the same equations backward: cart 1's velocity reverses inside the stretch
    and its friction flips there, as forward."""
    lin = np.array([[60.0, 30.0, 70.0, 110.0, 0.3, 0.4]])
    terms = NonlinearTerms(friction_m_s2=np.array([[0.2, 0.1]]))
    z0 = np.array([[0.04, 0.01, 0.25, -0.1]])       # cart 1 still moving out: it turns in the stretch
    dt, n = 1.0 / 400.0, 120
    forward, end = run_maps(step_maps(lin, dt, 2, terms), z0, n)
    assert np.any(np.diff(np.sign(np.diff(forward[0, :, 0]))) != 0)     # a turn inside
    backward, start = run_maps(step_maps(lin, -dt, 2, terms), end, n)
    assert np.max(np.abs(backward[0, ::-1] - forward[0])) < 1e-6 * 0.05
    assert np.max(np.abs(start - z0)) < 1e-5


@pytest.mark.parametrize("seed", [
    515667656,    # 380 Hz, bench seed 53 (--one-encoder 20): 17.9 samples late, at the cart's first turn
    1634917672,   # 83 Hz, bench seed 61 (--one-encoder 40): 2.1 samples late (a jump of 6 m/s²)
])
def test_a_one_encoder_flick_is_dated_within_a_sample(seed: int) -> None:
    case = make_case(seed, "coulomb_friction", carts=2, encoders=1)
    assert case.truth.release == "flick"
    report = diagnose(case.observed.t, case.observed.y, carts=2).report
    error = (report.release_time_s - case.truth.release_time_s) * case.truth.rate_hz
    assert abs(error) <= 1.0, error
