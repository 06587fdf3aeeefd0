"""A cubic spring that changes the stiffness by up to a third at the swing is fitted within 5 %.

The issue asks for cubic stiffness, hardening and softening, over the physical range. The
fit started the cubic at the frequency drift's estimate κ₀ but kept the linear fit's
stiffness, which rings at the swings' average frequency: with the cubic added, every cycle was
then off by (3/4) κ Ā² and over tens of cycles the phase error held the fit in a local
minimum (red team cubic_softening seed 200: a 27 % softening fitted as -3841 for -6033 /m²s²,
fit 86 % against a noise floor of 99.2 %); its bound also allowed only a 17 % change at the
swing. Cases: `testkit.effects` one-cart cubic runs over the physical range (`CUBIC_R_MAX_FULL`: |γ| A² up
to 0.32), those that change the stiffness by more than 15 % at the release amplitude.

And a weak one on two carts whose beating modes the evidence read as a frequency drift: every
cubic start it gave fitted worse than no cubic at all.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from ident.diagnose import diagnose
from testkit.effects import judge, make_case
from testkit.effects.draw import CUBIC_R_MAX_FULL


def _strong(seed: int) -> bool:
    truth = make_case(seed, "cubic_stiffness", carts=1, record_s=1.0, cubic_r_max=CUBIC_R_MAX_FULL).truth
    gamma_a2 = truth.parameters["cubic_per_m2_s2"] / truth.details["wn_rad_s"] ** 2 * truth.details["amplitude_m"] ** 2
    return bool(abs(gamma_a2) > 0.15)


@pytest.mark.slow
def test_a_strong_cubic_spring_is_named_with_its_coefficient_within_5_percent() -> None:
    stream = (int(s) for s in np.random.default_rng(20261128).integers(0, 2**31, 100))
    seeds = list(itertools.islice((s for s in stream if _strong(s)), 5))
    assert len(seeds) == 5
    wrong = []
    for seed in seeds:
        case = make_case(seed, "cubic_stiffness", carts=1, cubic_r_max=CUBIC_R_MAX_FULL)
        report = diagnose(case.observed.t, case.observed.y, carts=1).report
        verdict = judge(case, report)
        if not verdict.right:
            wrong.append(f"seed {seed}: cause {report.cause}, errors {verdict.errors}, "
                         f"fit {report.extended.fit_percent:.2f} %")
    assert not wrong, "\n".join(wrong)


def test_a_cubic_on_a_beating_chain_is_screened_from_no_cubic_too() -> None:
    """`tools/bench_diagnose.py --seed 49`, cubic case 7 (two carts held and released, 304 Hz,
    +425 /m²s², 6 % harder at the swing): the starts from the evidence's frequency drift (the
    chain's two modes beating) ended their screening fits far worse than the linear model
    (n ln ratio -3516) and the hardening was named a 0.8 Hz mode (98.44 %). Screened from no
    cubic as well when that costs less, it is found within 0.2 % (99.73 %)."""
    case = make_case(1400203828, "cubic_stiffness", cubic_r_max=CUBIC_R_MAX_FULL)
    report = diagnose(case.observed.t, case.observed.y, carts=case.observed.carts).report
    verdict = judge(case, report)
    assert verdict.headline_right and verdict.errors["cubic_per_m2_s2"] < 0.05, (report.cause, verdict.errors)
