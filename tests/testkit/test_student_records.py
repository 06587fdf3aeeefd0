"""`testkit.student_records`: one simulation read at several rates is the record each rate
would give alone (the releases test relies on it to simulate each seed once); a nudge that
lets a ringing cart go away from its rest is a catch, and a run there is counted apart."""

from __future__ import annotations

import numpy as np
import pytest

from testkit.release_tally import Tally
from testkit.student_records import (
    CATCH_SWING_M,
    RATES_HZ,
    handling_record,
    handling_records,
    student_record,
    student_records,
)


@pytest.mark.parametrize("seed", [23, 25])
def test_records_at_several_rates_equal_the_records_generated_at_each_rate(seed: int) -> None:
    together = student_records(seed, RATES_HZ)
    for rate in RATES_HZ:
        alone, shared = student_record(seed, rate), together[rate]
        assert shared.rate_hz == rate
        np.testing.assert_array_equal(shared.t, alone.t)
        np.testing.assert_array_equal(shared.y, alone.y)
        assert (shared.releases, shared.events, shared.touches_s, shared.both_free, shared.catches_s) == \
            (alone.releases, alone.events, alone.touches_s, alone.both_free, alone.catches_s)


def test_handling_at_several_rates_equals_the_handling_generated_at_each_rate() -> None:
    together = handling_records(2, RATES_HZ, 8.0)
    for rate in RATES_HZ:
        alone = handling_record(2, rate, 8.0)
        np.testing.assert_array_equal(together[rate].t, alone.t)
        np.testing.assert_array_equal(together[rate].y, alone.y)
        assert np.ptp(alone.y) > 0.0    # the hand did move something


@pytest.mark.parametrize("seed", [6022, 9301, 9419, 9637, 9716])
def test_a_nudge_that_lets_a_ringing_cart_go_away_from_its_rest_is_a_catch(seed: int) -> None:
    """These nudges took a cart that still rang from the last release and let it go where they
    took it, away from its rest: it rang again (each was counted a false run of the detector;
    9716's at 3.717 s was dated within 0.1 ms of the nudge's let-go). A nudge of a cart at rest
    is none (6022, 9637 and 9716 nudge twice)."""
    rec = student_record(seed, 100.0)
    pulled = rec.releases[0].pulled_cart - 1
    assert 0 < len(rec.catches_s) <= rec.events.count("nudge")
    for t_c in rec.catches_s:
        after = (rec.t >= t_c) & (rec.t <= t_c + 1.0)
        assert np.ptp(rec.y[after, pulled]) >= CATCH_SWING_M, t_c
        assert all(abs(t_c - r.time_s) > 0.25 for r in rec.releases)
    if seed == 6022:
        assert len(rec.catches_s) == 1 < rec.events.count("nudge")


def test_a_run_at_a_catch_is_neither_a_release_nor_false() -> None:
    tally = Tally()
    tally.add([1.0], [1.01, 3.05, 5.0], 0.25, "r", catches=(3.0, 7.0))
    assert (tally.releases, tally.recorded, tally.false_runs, tally.catches) == (1, 1, 1, 2)
    assert tally.at_catches == ["r at 3.050 s"] and tally.false == ["r at 5.000 s"]
