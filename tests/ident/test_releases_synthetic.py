"""`ident.releases.find_releases` on seeded students' records generated from the physics
(`testkit.student_records`: its own stick/slip integrator, independent of the finder).

Flicks and pull-hold-releases, 1–4 per record, nudges, a loosely held cart that wanders and
is touched, records that start in motion, back-to-back releases, the last one cut, at 50,
100, 200 and 1000 Hz. At least 90 % of the true releases must be found once (at most 5 %
elsewhere), with the right pulled cart and the held cart not among the moving ones, at the
simulator's instant within two sample periods or 5 ms (the smoothing of a 50 Hz record spans
a tenth of a period); nothing may be found in records of handling only.
"""

from __future__ import annotations

import numpy as np
import pytest

from ident.releases import find_releases
from testkit.student_records import RATES_HZ, handling_record, student_record

SEEDS = range(20, 30)


def _tolerance(rate_hz: float) -> float:
    return max(2.0 / rate_hz, 0.005)


@pytest.mark.slow
@pytest.mark.parametrize("rate_hz", RATES_HZ)
def test_every_release_is_found_once_with_its_instant_and_cart(rate_hz: float) -> None:
    missed, extra, late, total = [], [], [], 0
    for seed in SEEDS:
        rec = student_record(seed, rate_hz)
        found = find_releases(rec.t, rec.y)
        total += len(rec.releases)
        for true in rec.releases:
            near = [r for r in found if abs(r.release_time_s - true.time_s) < 0.25]
            if len(near) != 1:
                missed.append((seed, true.time_s))
                continue
            (hit,) = near
            assert hit.pulled_cart == true.pulled_cart
            if not rec.both_free:
                assert hit.moving_carts == (true.pulled_cart,)
            if abs(hit.release_time_s - true.time_s) > _tolerance(rate_hz):
                late.append((seed, round(true.time_s, 3), round(hit.release_time_s - true.time_s, 4)))
            assert hit.release_time_s < hit.end_time_s
        extra += [(seed, r.release_time_s) for r in found
                  if all(abs(r.release_time_s - true.time_s) >= 0.25 for true in rec.releases)]
    print(f"{rate_hz:g} Hz: {total} releases, missed {missed}, extra {extra}, off {late}")
    # at least 90 % found and at most 5 % found elsewhere (measured on these seeds: 1-2 of 28
    # missed; a hold grabbed from a ringing cart and pulled slowly can be dated at the grab;
    # tools/bench_ident_releases.py prints the figures); instants within tolerance for 90 %
    assert len(missed) <= 0.1 * total and len(extra) <= 0.05 * total
    assert len(late) <= 0.1 * total


@pytest.mark.parametrize("rate_hz", RATES_HZ)
def test_free_responses_end_before_the_next_release(rate_hz: float) -> None:
    rec = student_record(7, rate_hz, 3, both_free=False)
    found = find_releases(rec.t, rec.y)
    assert len(found) == 3
    for before, true_next in zip(found, rec.releases[1:], strict=False):
        assert before.end_time_s < true_next.time_s - 0.1
    assert found[-1].end_time_s <= rec.t[-1]


@pytest.mark.slow
@pytest.mark.parametrize("rate_hz", RATES_HZ)
def test_handling_alone_is_no_release(rate_hz: float) -> None:
    for seed in (1, 2):
        rec = handling_record(seed, rate_hz, 40.0)
        assert find_releases(rec.t, rec.y) == []


def test_a_record_that_starts_in_motion_has_no_release_before_the_first_hand() -> None:
    rec = student_record(12, 200.0, 1, both_free=False, start_in_motion=True)
    found = find_releases(rec.t, rec.y)
    assert [round(r.release_time_s, 1) for r in found] == [round(rec.releases[0].time_s, 1)]
    assert abs(found[0].release_time_s - rec.releases[0].time_s) <= _tolerance(200.0)


def test_a_flat_record_has_no_release() -> None:
    t = np.arange(0.0, 5.0, 0.01)
    y = np.zeros((t.size, 2))
    assert find_releases(t, y) == []
