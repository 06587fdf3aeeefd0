"""The linear baseline of `ident diagnose` starts at the right mode.

A cart released beside a hand-held one rings down by dry friction within a few periods and
then follows the held cart's slow wander through the spring for the rest of the record: the
position spectrum of the window can peak at that slow drift (the ring's peak is broad and
low), and a baseline started there fits the drift (fit ~1 %) and leaves nothing for any
effect. The baseline also starts at the velocity spectrum's peaks (`baseline.one_cart_peaks`) and
keeps the better fit.
Cases: `testkit.effects` Coulomb + held cart runs over the family's whole range (and the bench
case that showed it), those whose
free cart's position spectrum peaks below half the ring's frequency.
"""

from __future__ import annotations

import numpy as np
import pytest

from ident.diagnose import diagnose
from ident.diagnose.baseline import linear_starts
from ident.diagnose.problem import Problem
from ident.physics.measures import spectral_peaks
from testkit.effects import Case, judge, make_case

#: the first two seeds of `default_rng(20261125).integers(0, 2**31, 80)` whose drift dominates
#: (`_drift_dominates`): listed, as searching the stream makes ~20 cases (32 s) each run
DRIFT_SEEDS = (494206500, 1684674824)


def _drift_dominates(case: Case) -> bool:
    y = case.observed.y[:, 1]
    moved = np.flatnonzero(np.abs(y - y[0]) > 0.05 * np.max(np.abs(y - y[0])))
    after = y[moved[0]:] - np.mean(y[moved[0]:])
    dt = float(case.observed.t[1] - case.observed.t[0])
    slow = spectral_peaks(after[:, None], dt, 1)[0]
    return bool(slow < 0.5 * case.truth.details["wn_rad_s"])   # the drift far slower than the ring


def _free_response(case: Case) -> Problem:
    """The free cart's record from the release on, decimated to <= 500 samples as a diagnosis does."""
    t, y = case.observed.t, case.observed.y[:, 1:]
    start = int(np.searchsorted(t, case.truth.release_time_s))
    step = max(1, int(np.ceil((t.size - start) / 500)))
    idx = np.arange(start, t.size, step)
    return Problem(t[idx] - t[idx[0]], y[idx], float(t[1] - t[0]) * step, np.ones(idx.size, dtype=bool), 1,
                   float(np.ptp(y[idx])))


@pytest.mark.slow
def test_a_ring_stopped_by_friction_beside_a_wandering_held_cart_is_fitted_not_the_drift() -> None:
    # DRIFT_SEEDS (checked here to be such cases) and bench seed 1437021865 (tools/bench_diagnose.py
    # --seed 11, coulomb+held_cart case 17), where the window's own spectrum peaked at the drift
    # and the baseline fitted it (fit 1.2 %, no effect)
    for seed in [*DRIFT_SEEDS, 1437021865]:
        case = make_case(seed, "coulomb+held_cart")
        assert _drift_dominates(case) or seed == 1437021865, f"seed {seed}: the drift does not dominate"
        wn = case.truth.details["wn_rad_s"]
        # the baseline is started at the ring too, not only at the drift
        starts = [float(theta[0]) for theta in linear_starts(_free_response(case))]
        assert any(abs(w / wn - 1.0) < 0.2 for w in starts), f"seed {seed}: starts {starts} rad/s, ring {wn:.2f}"
        report = diagnose(case.observed.t, case.observed.y, carts=1).report
        assert report.baseline.fit_percent > 50.0, f"seed {seed}: baseline fit {report.baseline.fit_percent:.1f} %"
        assert judge(case, report).all_found, f"seed {seed}: found {[e.effect for e in report.effects]}"


@pytest.mark.slow
@pytest.mark.parametrize("seed", [108, 111, 112, 122])
def test_a_stiff_ring_stopped_early_in_a_long_held_cart_record_is_diagnosed(seed: int) -> None:
    # `testkit.effects` coulomb+held_cart over wide carts (up to ~6 Hz), 18 s records: the cart
    # stops within its first 0.6-2 s and the held cart wanders to the end. Of seeds 100-123 the
    # old code failed these four: 112 and 122 started the baseline only at the wander's slow
    # peaks (the Hann window weighs the ring's start ~0.01; no effect found, baseline fit ~1 %),
    # 108 and 111 cut no still tail (the held cart's column judged as moving) and fitted the
    # ring on 5-7 samples a period (friction 43 % off and a 4.9 Hz 'mode' the headline). Seed
    # 110 (static friction 1.36 x kinetic, stick-slip dragged by the wander for 8 s) still
    # misses (friction 11 % off, the coupling 8x), and is not listed
    case = make_case(seed, "coulomb+held_cart", record_s=18.0, wide_carts=True)
    wn = case.truth.details["wn_rad_s"]
    starts = [float(theta[0]) for theta in linear_starts(_free_response(case))]
    assert any(abs(w / wn - 1.0) < 0.2 for w in starts), f"starts {starts} rad/s, ring {wn:.2f}"
    report = diagnose(case.observed.t, case.observed.y, carts=1).report
    verdict = judge(case, report)
    assert verdict.all_found, f"found {[e.effect for e in report.effects]}"
    assert max(verdict.errors.values()) < 0.05, verdict.errors
