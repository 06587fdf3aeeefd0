"""A student's last release cut by the record's end before its ringing's third turn, by a
student of another generator than the rig's own (`testkit.student_records`).

The detector confirms a ringing at its third turn; the hand's hold or push fills the first
half-period, so A-B (the hand's) never matches B-C (the free swing's) and the ringing waits for
its next turn, which the record's end cut off: those releases were lost. At the end of the
stream `ReleaseDetector.finish` judges the last turns on the swing B-C alone and dates them as
any ringing (its hand and driven checks included).
"""

from __future__ import annotations

import pytest

from daq.detector import Released, ReleaseDetector
from testkit.student_records import student_records


# 9537: a held cart's flick 0.9 s before the end; 9816: a held cart's flick 0.82 s before the
# end, whose free window after B the end cut to a third of a period (ω 9 % off, the slide-back
# stopped at B: dated 0.4 s late); 11333: a free pair's flick 1.3 s before the end (the curved
# hand force of a lone cart's joined model moved its first date where its driven response held
# across: turned down as driven by the other)
@pytest.mark.parametrize(("seed", "rate_hz"), [(9537, 50.0), (9816, 100.0), (11333, 50.0)])
def test_a_release_cut_before_its_third_turn_is_recorded_at_the_end(seed: int, rate_hz: float) -> None:
    rec = student_records(seed, (rate_hz,))[rate_hz]
    last = rec.releases[-1]
    assert last.cut
    detector = ReleaseDetector()
    during = [e for t, (a, b) in zip(rec.t.tolist(), rec.y.tolist(), strict=True)
              for e in detector.feed(t, (a, b)) if isinstance(e, Released)]
    assert not any(abs(e.t_release_s - last.time_s) < 0.25 for e in during)
    at_end = [e for e in detector.finish() if isinstance(e, Released)]
    assert len(at_end) == 1 and abs(at_end[0].t_release_s - last.time_s) <= 1.0 / rate_hz, (at_end, last)
    assert at_end[0].channel == last.pulled_cart - 1
    assert detector.finish() == []


# 9532, 9039: a free pair's hold let go 0.86 and 0.94 s before the end. The cart was held still
# while the other swung, so the carts were never still together: only the ringing could record
# it, and it was lost until `finish` judged the last turns; now the hold is armed on that cart
# alone and its let-go recorded as it happens (`ReleaseDetector`: a cart still while another moves)
@pytest.mark.parametrize(("seed", "rate_hz"), [(9532, 50.0), (9039, 100.0)])
def test_a_free_pair_hold_let_go_just_before_the_end_is_recorded_once(seed: int, rate_hz: float) -> None:
    rec = student_records(seed, (rate_hz,))[rate_hz]
    last = rec.releases[-1]
    assert last.cut and last.kind == "hold" and rec.both_free
    detector = ReleaseDetector()
    found = [e for t, (a, b) in zip(rec.t.tolist(), rec.y.tolist(), strict=True)
             for e in detector.feed(t, (a, b)) if isinstance(e, Released)]
    found += [e for e in detector.finish() if isinstance(e, Released)]
    near = [e for e in found if abs(e.t_release_s - last.time_s) < 0.25]
    assert len(near) == 1 and abs(near[0].t_release_s - last.time_s) <= 1.0 / rate_hz, (near, last)
    assert near[0].channel == last.pulled_cart - 1
