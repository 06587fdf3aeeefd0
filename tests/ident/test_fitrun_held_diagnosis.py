"""The worker's and `ident report`'s diagnosis of a one-cart case takes the held cart's measured
motion as an input, as `ident diagnose` does (`ident.fitrun.analysis`): it had been given the
free cart's column alone, and the real 2025 record 07-Feb-2025_11_32_48 was reported at 97.50 %
by `ident report` against 98.71 % by `ident diagnose`, with a "coupled mode" standing in for
the held cart.

The run is drawn by the independent generator `testkit.effects` (its own physics and
integrator): cart 2 released with Coulomb friction, cart 1 held by a hand that wanders."""

from __future__ import annotations

import numpy as np

from ident.data import IdData
from ident.fitrun import analyse
from testkit.effects import make_case


def test_the_held_carts_motion_enters_the_diagnosis_of_a_one_cart_case() -> None:
    case = make_case(3, "coulomb+held_cart")
    truth = case.truth.parameters["held_cart_gain_per_s2"]
    analysis = analyse(IdData(case.observed.t, np.zeros(case.observed.t.size), case.observed.y))
    assert analysis.case == "cart2" and analysis.diagnosis is not None
    effects = {e.effect: e for e in analysis.diagnosis.effects}
    assert "held_cart_motion" in effects and analysis.diagnosis.cause == "coulomb_friction"
    gain = effects["held_cart_motion"].parameters["held_cart_gain_per_s2"]
    assert abs(gain - truth) <= 0.05 * truth, (gain, truth)
    # the fits' own data stay the free cart's
    assert analysis.data.y.shape[1] == 1


def test_a_pinned_cart_that_never_moves_is_left_out_of_the_diagnosis() -> None:
    case = make_case(5, "coulomb_friction", carts=1)
    y = np.column_stack([case.observed.y[:, 0], np.zeros(case.observed.t.size)])
    analysis = analyse(IdData(case.observed.t, np.zeros(case.observed.t.size), y))
    assert analysis.diagnosis_y is not None and analysis.diagnosis_y.shape[1] == 1
    assert analysis.diagnosis is not None and "never moves" not in analysis.diagnosis.validation
