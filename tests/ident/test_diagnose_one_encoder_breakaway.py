"""Two carts with dry friction read through cart 1's encoder, a breakaway (static) friction
well above the kinetic one: the friction is fitted to the truth and no mode or cubic spring
stands in for the breakaway.

Two causes had left the kinetic-only model many times the noise floor's misfit, which a
searched mode and a cubic spring then took: the kinetic friction's upper bound came from the
linear baseline's lowest mode, which a beat imitating friction's straight decay had put far
under the carts' own (`bounds._bounds_of`), and a breakaway ratio was only fitted from the
kinetic-only model's chain, in whose narrow basin no ratio gains
(`friction_fit._walked_ratio_fits`). Runs of the independent generator `testkit.effects` (static
friction 1-1.5 x kinetic, a detail its judge does not score); the truth is cart 1's friction and
f2 / k2.
"""

from __future__ import annotations

import pytest

from ident.diagnose import diagnose
from testkit.effects import judge, make_case, noise_floor_percent


@pytest.mark.parametrize("seed", [
    1359388729,   # bench seed 54 (--one-encoder 40): breakaway 1.38 and 1.39 x kinetic; a mode named, f2/k2 14 % off
    1566055967,   # bench seed 54: 1.20 and 1.24 x; friction held at a bound 10 % under, a mode and a cubic named
])
def test_a_breakaway_through_one_encoder_is_not_taken_for_a_mode_or_a_cubic(seed: int) -> None:
    case = make_case(seed, "coulomb_friction", carts=2, encoders=1)
    report = diagnose(case.observed.t, case.observed.y, carts=2).report
    named = [e.effect for e in report.effects]
    assert set(named) <= {"coulomb_friction", "static_friction"}, named
    errors = judge(case, report).errors
    assert set(errors) == {"coulomb_accel_m_s2", "coulomb_cart2_per_coupling_m"}
    assert max(errors.values()) <= 0.05, errors
    floor = noise_floor_percent(case, report.window_start_s)
    assert floor - report.extended.fit_percent <= 0.3, (floor, report.extended.fit_percent)
