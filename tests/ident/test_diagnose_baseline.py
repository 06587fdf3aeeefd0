"""The linear baseline of `ident diagnose` starts at the right mode.

A cart released beside a hand-held one rings down by dry friction within a few periods and
then follows the held cart's slow wander through the spring for the rest of the record: the
position spectrum of the window can peak at that slow drift (the ring's peak is broad and
low), and a baseline started there fits the drift (fit ~1 %) and leaves nothing for any
effect. The baseline also starts at the velocity spectrum's peaks and keeps the better fit.
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
