"""The seeded student of `sim://?student=...` against the release detector (a small seeded
version of `tools/bench_releases.py`; the full figures come from the script).

The truth is the simulator's own record of when the hand let go; it is used only in the
assertions. Every release recorded and no run from handling (the issue's targets); the instant
within one sample period for the median release. Not every release: a flick let go where the
hand's deceleration matches the spring's has no kink in its motion to date it by, so those
are only held to 0.15 s here; `tools/bench_releases.py` prints the share within one period.
"""

from __future__ import annotations

import numpy as np
import pytest

from daq.errors import DaqValueError
from daq.sim.options import parse_sim_url
from daq.sim.rig import Rig
from testkit.release_tally import Tally, detect, record, samples


def _events(url: str) -> list[tuple[str, float]]:
    rig = Rig(parse_sim_url(url))
    while not rig.finished:
        rig.produce_bytes(1 << 16)
        rig.take(1 << 16)
    return [(e.kind, e.t_s) for e in rig.events]


def test_a_student_record_draws_one_to_four_releases_and_its_handling_from_the_seed() -> None:
    kinds = [[k for k, _ in _events(f"sim://?realtime=0&rate_hz=100&student=releases&seed={s}")]
             for s in range(12)]
    releases = [k.count("release") for k in kinds]
    assert min(releases) >= 1 and max(releases) <= 4 and len(set(releases)) > 1
    flat = [k for record in kinds for k in record]
    assert {"grab", "release", "nudge", "touch"} <= set(flat)
    again = [k for k, _ in _events("sim://?realtime=0&rate_hz=100&student=releases&seed=3")]
    assert again == kinds[3]                                    # seeded


@pytest.mark.parametrize("seed", [3, 8])
def test_the_hand_force_at_each_let_go_is_the_jump_in_the_carts_acceleration(seed: int) -> None:
    # the truth `tools/bench_releases.py` splits its figures by, checked against the motion: a
    # noiseless 2 kHz twin read to the nanometre, the acceleration from second differences just
    # before and just after each let-go (the jerk over 3 samples is far below the jump)
    rec = record(f"sim://?realtime=0&rate_hz=2000&student=releases&seed={seed}&noise_counts=0&counts_per_m=1e9")
    data = list(rec.stream)
    t = np.array([d[0] for d in data])
    y = np.array([d[1] for d in data])
    assert len(rec.let_go_m_s2) == len(rec.releases) > 0
    for t_r, force in zip(rec.releases, rec.let_go_m_s2):
        i = int(np.searchsorted(t, t_r))
        x = y[:, int(np.argmax(np.ptp(y[i:i + 500], axis=0)))]
        dt = t[i + 1] - t[i]
        jump = ((x[i + 2] - 2 * x[i + 1] + x[i]) - (x[i - 1] - 2 * x[i - 2] + x[i - 3])) / dt ** 2
        assert jump == pytest.approx(-force, abs=0.05 * abs(force) + 0.2), (t_r, force, jump)


def test_handling_has_no_release() -> None:
    kinds = {k for k, _ in _events("sim://?realtime=0&rate_hz=50&student=handling&duration_s=60&seed=1")}
    assert "release" not in kinds and {"nudge", "letgo"} <= kinds


def test_student_options_are_checked() -> None:
    with pytest.raises(DaqValueError, match="student"):
        parse_sim_url("sim://?student=sometimes")
    with pytest.raises(DaqValueError, match="p_nudge"):
        parse_sim_url("sim://?p_nudge=2")


@pytest.mark.parametrize("rate_hz", [50, 200])   # at 1000 Hz the median is ~1.2 periods: see the bench
def test_simulated_students_every_release_recorded_near_the_truth(rate_hz: int) -> None:
    tally = Tally()
    for seed in range(6):
        stream, truth = samples(f"sim://?realtime=0&rate_hz={rate_hz}&student=releases&seed={500 + seed}")
        tally.add(truth, detect(stream), 0.25, f"seed={seed}")
    assert tally.releases >= 10
    assert tally.recorded == tally.releases, tally.misses
    assert tally.false_runs == 0
    errors = np.abs(np.array(tally.errors_s))
    assert np.median(errors) <= 1.0 / rate_hz
    assert np.max(errors) < 0.15


@pytest.mark.parametrize("rate_hz", [50, 1000])
def test_two_minutes_of_handling_make_no_run(rate_hz: int) -> None:
    stream, truth = samples(f"sim://?realtime=0&rate_hz={rate_hz}&student=handling&duration_s=120&seed={rate_hz}")
    assert truth == []
    assert detect(stream) == []


def _every_release_once(rate_hz: int, seed: int, releases: int) -> None:
    """A student record's `releases` releases each recorded once, and nothing else."""
    stream, truth = samples(f"sim://?realtime=0&rate_hz={rate_hz}&student=releases&seed={seed}")
    tally = Tally()
    tally.add(truth, detect(stream), 0.25, f"seed={seed}")
    assert tally.releases == releases
    assert tally.recorded == releases and tally.false_runs == 0, (tally.misses, tally.false)


def test_a_record_that_starts_in_motion_makes_no_run_before_its_first_release() -> None:
    # seed 50137 at 50 Hz starts in a swing whose joined fit lands just inside the first
    # half-period (its slid-back start just outside): it was taken for a release, and the run it
    # opened hid the record's two real releases
    _every_release_once(50, 50137, 2)


def test_a_touch_of_the_held_cart_that_swings_the_ringing_one_makes_no_second_run() -> None:
    # seed 100152 at 100 Hz: 1.9 s after cart 2's flick the hand moves the held cart 1 by 13 mm
    # while cart 2 still rings by 20 mm; cart 2's swing grows (the run ends, "handled"), and its
    # ringing was dated as a release at the touch: the driven model's spring, taken from the
    # ringing a period on, left 7-12 times its residual (the bench's one false run)
    _every_release_once(100, 100152, 1)


def test_a_loosely_held_cart_is_a_cart_on_the_hands_spring() -> None:
    """With no wander, nudges or touches (clean encoder, 200 Hz): the held cart's acceleration
    is continuous through the other cart's let-go (a spring's force: its third difference stays
    small against its second; the old position path lagged the pulled cart by a sample and
    jumped at each let-go, 0.73-1.52 there), and during a still hold it sits at the drawn
    fraction of the pulled cart's displacement (`follow` × U(0.4, 1.6))."""
    follow, jerks, ratios = 0.08, [], []
    for seed in range(12):
        rec = record(f"sim://?realtime=0&rate_hz=200&student=releases&seed={seed}&wander_m=0&p_touch=0"
                     f"&p_nudge=0&follow={follow}&noise_counts=0&counts_per_m=1e8")
        stream = list(rec.stream)
        t = np.array([tk for tk, _ in stream])
        y = np.array([pos for _, pos in stream])
        pulled = int(np.argmax(np.ptp(y, axis=0)))
        held = y[:, 1 - pulled]
        if np.ptp(held) == 0.0:                                  # pinned (a fifth of the records)
            continue
        for t_r in rec.releases:
            k = int(np.searchsorted(t, t_r))
            w = held[k - 6:k + 6]
            jerks.append(float(np.abs(np.diff(w, 3)).max() / np.abs(np.diff(w, 2)).max()))
            speed = abs(y[k - 1, pulled] - y[k - 2, pulled]) * 200.0
            if speed < 0.01:                                     # a hold let go still
                ratios.append(float(held[k - 1] / y[k - 1, pulled]))
    assert len(jerks) >= 10 and max(jerks) < 0.6, jerks
    assert ratios and all(0.4 * follow * 0.95 <= r <= 1.6 * follow * 1.05 for r in ratios), ratios
