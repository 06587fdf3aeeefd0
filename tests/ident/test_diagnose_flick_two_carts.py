"""A flick of one of two carts is dated on the cart the hand pushed.

The hand pushes one cart; only its acceleration jumps when the hand lets go. The other cart
is pulled through the spring by a force continuous at the release, so its record has no knot.
The window dated a flick on the cart that swung most; when that was the unpushed one it was
dated tens of samples early, and the window's first samples then held the hand's push, which a
fast-decaying "coupled mode" absorbed on a linear run (bench seeds 1036628920 and 974133204 of
`none`, `tools/bench_diagnose.py --seed 12`). Cases: `testkit.effects` two-cart flicks of the
linear carts over the family's whole range, those where the unpushed cart swings more than the
pushed one (the generator's hand pushes cart 1).
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from ident.diagnose import diagnose
from ident.diagnose.stretch import release_stretch
from ident.diagnose.window import _pushed, find_window, hold_level
from testkit.effects import make_case
from testkit.effects.draw import CUBIC_R_MAX_FULL


def _unpushed_swings_more(seed: int) -> bool:
    y = make_case(seed, "none", carts=2, release="flick").observed.y
    return bool(np.ptp(y[:, 1]) > np.ptp(y[:, 0]))


@pytest.mark.slow
def test_a_two_cart_flick_is_dated_on_the_pushed_cart_where_the_other_swings_more() -> None:
    # within one sample or 2 % of a period (the old dating on the other cart was 2.5-15 % off on these); one
    # sample, the aim, is not met everywhere yet: the pushed cart's join misses by 1.4
    # and 4.9 samples on two of these (seeds 824249125 at 182 Hz, 1510433379 at 884 Hz)
    stream = (int(s) for s in np.random.default_rng(20261126).integers(0, 2**31, 200))
    seeds = list(itertools.islice((s for s in stream if _unpushed_swings_more(s)), 6))
    assert len(seeds) == 6
    wrong = []
    for seed in seeds:
        case = make_case(seed, "none", carts=2, release="flick")
        t, y = case.observed.t, case.observed.y
        _, _, onset = hold_level(y)
        win = find_window(t, y, 2)
        period = 2 * np.pi / case.truth.details["wn_rad_s"]
        error = (win.release_time_s - case.truth.release_time_s) / period
        if _pushed(y, onset) != 0 or abs(error) > max(0.02, 1.0 / (case.truth.rate_hz * period)):
            wrong.append(f"seed {seed}: dated on cart {_pushed(y, onset) + 1}, off by {100 * error:+.2f} % of a period")
    assert not wrong, "\n".join(wrong)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1036628920, 974133204])
def test_the_bench_flicks_that_named_a_mode_on_linear_carts_name_none(seed: int) -> None:
    case = make_case(seed, "none")
    report = diagnose(case.observed.t, case.observed.y, carts=case.observed.carts).report
    assert report.cause == "none" and not any(e.material for e in report.effects), (
        f"seed {seed}: cause {report.cause}, effects {[(e.effect, e.gain_points) for e in report.effects]}")
    assert abs(report.release_time_s - case.truth.release_time_s) * case.truth.rate_hz <= 1.0


@pytest.mark.parametrize(("family", "seed", "encoders"), [
    ("coulomb_friction", 1877406440, 1),     # two carts through cart 1's encoder, 354 Hz: 89 samples late
    ("coulomb+held_cart", 1262728783, None),  # 106 samples late
    ("cubic_stiffness", 1957082756, None),    # 9 samples late
])
def test_a_flick_is_not_dated_after_the_cart_turned(family: str, seed: int, encoders: int | None) -> None:
    """A flick's hand lets go before the cart turns: a join of the hand's path to the free
    response found more than half the push after the first extreme (bench seeds 52, 51 and 45 of
    `tools/bench_diagnose.py`; the scan's window started a slow period late and the join was
    searched, across velocity reversals, up to a quarter period after it) is searched again up
    to that extreme."""
    case = (make_case(seed, family, carts=2, encoders=encoders) if encoders else
            make_case(seed, family, cubic_r_max=CUBIC_R_MAX_FULL))
    assert case.truth.release == "flick"
    stretch = release_stretch(case.observed.t, case.observed.y, None, case.observed.carts, None, None)
    error = (stretch.win.release_time_s - case.truth.release_time_s) * case.truth.rate_hz
    assert abs(error) <= 1.5, error
