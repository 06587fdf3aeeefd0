"""`testkit.student_records`: one simulation read at several rates is the record each rate
would give alone (the releases test relies on it to simulate each seed once)."""

from __future__ import annotations

import numpy as np
import pytest

from testkit.student_records import RATES_HZ, handling_record, handling_records, student_record, student_records


@pytest.mark.parametrize("seed", [23, 25])
def test_records_at_several_rates_equal_the_records_generated_at_each_rate(seed: int) -> None:
    together = student_records(seed, RATES_HZ)
    for rate in RATES_HZ:
        alone, shared = student_record(seed, rate), together[rate]
        assert shared.rate_hz == rate
        np.testing.assert_array_equal(shared.t, alone.t)
        np.testing.assert_array_equal(shared.y, alone.y)
        assert (shared.releases, shared.events, shared.touches_s, shared.both_free) == \
            (alone.releases, alone.events, alone.touches_s, alone.both_free)


def test_handling_at_several_rates_equals_the_handling_generated_at_each_rate() -> None:
    together = handling_records(2, RATES_HZ, 8.0)
    for rate in RATES_HZ:
        alone = handling_record(2, rate, 8.0)
        np.testing.assert_array_equal(together[rate].t, alone.t)
        np.testing.assert_array_equal(together[rate].y, alone.y)
        assert np.ptp(alone.y) > 0.0    # the hand did move something
