"""A coarse clock's stamps evened out (`ident.data.even_stamps`), and what it does downstream.

The ECP-210's Teensy stamps whole milliseconds on samples taken every ~1.128 ms. Generated
here from that description: samples on an even period (with a slow drift of the device's
rate), each stamped with the clock tick at or before it. Evened, the stamps must follow the
sample times to a small fraction of a tick (their constant offset, the stamps' own time base,
kept); any other clock must come back untouched. (A rate whose ratio to the tick drifts
through a simple fraction, 3/2 say, leaves the stamps' local mean offset drifting too:
nothing in the stamps tells it apart from a drifting clock, so those rates are not asked to
even out this far.) Downstream, a flick read through such a clock must be dated by
`ident.releases` as well as through its true sample times.
"""

from __future__ import annotations

import numpy as np
import pytest

from ident.data import EVENED_NOTE, IdData, even_stamps, make_uniform
from ident.releases import find_releases


def _coarse(n: int, period_s: float, tick_s: float, drift: float, phase: float) -> tuple[np.ndarray, np.ndarray]:
    """(true sample times, their stamps: the tick at or before each)."""
    k = np.arange(n, dtype=np.float64)
    true = phase + period_s * k * (1.0 + drift * k / n)
    return true, np.floor(true / tick_s) * tick_s


@pytest.mark.parametrize(("period_s", "tick_s", "drift"), [
    (1.1283e-3, 1e-3, 0.0), (1.1283e-3, 1e-3, 2e-4), (5.64e-3, 1e-3, 0.0),   # the ECP, and read at 1/5
    (8.85e-3, 1e-3, 1e-4), (2.5e-3, 1e-3, 0.0), (1.37e-3, 1e-3, -3e-4)])
def test_a_coarse_clock_is_evened_to_its_sample_times(period_s: float, tick_s: float, drift: float) -> None:
    true, stamps = _coarse(4000, period_s, tick_s, drift, phase=0.37e-3)
    raw_error = stamps - true
    evened = even_stamps(stamps)
    error = evened - true
    inner = slice(50, -50)
    # the stamps' own time base: their mean offset from the samples (about half a tick) stays
    assert abs(float(np.mean(error)) - float(np.mean(raw_error))) < 0.02 * tick_s
    # the scatter about it goes from ~tick/√12 to a small fraction of a tick
    assert float(np.std(raw_error[inner])) > 0.2 * tick_s
    assert float(np.std(error[inner])) < 0.05 * tick_s
    assert float(np.max(np.abs(error[inner] - np.mean(error)))) < 0.25 * tick_s
    assert np.all(np.diff(evened) >= 0.0) and evened[0] >= stamps[0] and evened[-1] <= stamps[-1]


@pytest.mark.parametrize("case", ["uniform", "jittered", "missing sample", "short"])
def test_any_other_clock_is_left_as_it_is(case: str) -> None:
    rng = np.random.default_rng(3)
    t = 0.005 * np.arange(2000, dtype=np.float64)
    if case == "jittered":
        t = t + rng.uniform(-4e-4, 4e-4, t.size)
    elif case == "missing sample":
        _, t = _coarse(2000, 1.1283e-3, 1e-3, 0.0, 0.0)
        t = np.delete(t, np.arange(700, 705))   # five samples lost: one step of 6-7 ms
    elif case == "short":
        _, t = _coarse(60, 1.1283e-3, 1e-3, 0.0, 0.0)
    assert even_stamps(t) is t


def test_make_uniform_takes_a_coarse_clock_at_its_own_rate() -> None:
    true, stamps = _coarse(3000, 1.1283e-3, 1e-3, 0.0, 0.0)
    y = np.sin(2 * np.pi * 2.5 * true)[:, None]
    data = make_uniform(IdData(stamps, np.zeros(stamps.size), y))
    # the grid is at the samples' period, not at the median stamp step (1 ms, an upsampling)
    assert data.t[1] - data.t[0] == pytest.approx(1.1283e-3, rel=1e-3)
    assert EVENED_NOTE in data.notes
    # the positions interpolated on the evened stamps, against the signal at those times
    offset = float(np.mean(even_stamps(stamps) - true))
    truth = np.sin(2 * np.pi * 2.5 * (data.t - offset))
    assert float(np.max(np.abs(data.y[50:-50, 0] - truth[50:-50]))) < 2e-3 * 2 * np.pi * 2.5


def _flick(t: np.ndarray, release_s: float) -> np.ndarray:
    """A cart (wn 15.5 rad/s, ζ 0.02) from rest, pushed for 0.15 s by a hand force that rises
    to 12 m/s² and is still 8.5 m/s² when it ends at `release_s`; RK4 at 0.1 ms."""
    wn, zeta = 15.5, 0.02

    def force(s: float) -> float:
        tau = s - (release_s - 0.15)
        return 0.0 if tau < 0.0 or s >= release_s else 12.0 * float(np.sin(np.pi * tau / 0.2))

    h = 1e-4
    steps = int(np.ceil(t[-1] / h)) + 1
    xs = np.empty(steps)
    x, v = 0.0, 0.0
    for i in range(steps):
        xs[i] = x
        s = i * h
        a1 = force(s) - wn ** 2 * x - 2 * zeta * wn * v
        a2 = force(s + h / 2) - wn ** 2 * (x + h / 2 * v) - 2 * zeta * wn * (v + h / 2 * a1)
        a3 = force(s + h / 2) - wn ** 2 * (x + h / 2 * (v + h / 2 * a1)) - 2 * zeta * wn * (v + h / 2 * a2)
        a4 = force(s + h) - wn ** 2 * (x + h * (v + h / 2 * a2)) - 2 * zeta * wn * (v + h * a3)
        x, v = x + h * (v + h / 6 * (a1 + a2 + a3)), v + h / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
    return np.interp(t, h * np.arange(steps), xs)


def test_a_flick_stamped_by_a_coarse_clock_is_dated_as_through_its_sample_times() -> None:
    true, stamps = _coarse(8000, 1.1283e-3, 1e-3, 0.0, 0.0)
    release = 2.0 + 0.4e-3
    rng = np.random.default_rng(11)
    x = _flick(true, release)
    y = np.column_stack([np.round((x + rng.normal(0, 2e-6, x.size)) * 56000) / 56000,
                         np.round(rng.normal(0, 1e-5, x.size).cumsum() * 1e-2 * 56000) / 56000])
    offset = float(np.mean(stamps - true))   # the stamps' time base: the release is on it
    (found,) = find_releases(stamps, y)
    (reference,) = find_releases(true, y)
    assert found.pulled_cart == 1
    assert abs(found.release_time_s - (reference.release_time_s + offset)) < 2.3e-3
    assert abs(found.release_time_s - (release + offset)) < max(2.3e-3, 1.5 * abs(reference.release_time_s - release))


def test_a_record_built_on_a_coarse_clock_holds_its_sample_times_and_its_release() -> None:
    true, stamps = _coarse(1000, 1.1283e-3, 1e-3, 0.0, 0.6e-3)
    y = np.sin(2 * np.pi * 2.5 * true)
    data = IdData(stamps, np.zeros(stamps.size), y, release_time_s=float(stamps[0]))
    assert EVENED_NOTE in data.notes
    assert float(np.std(data.t[150:-150] - true[150:-150])) < 0.05e-3
    # a release given on the stamps' span (here their first) stays within the evened times
    assert data.t[0] <= data.release_time_s <= data.t[-1]
    # a slice of it is on the same times (nothing evened twice)
    part = IdData(data.t[100:700], data.u[100:700], data.y[100:700])
    assert np.array_equal(part.t, data.t[100:700]) and EVENED_NOTE not in part.notes


def _dropped_frames(n: int, tick_s: float, drop: float, seed: int) -> np.ndarray:
    """Sample times of a reader on a `tick_s` clock that loses a share `drop` of its frames,
    never two in a row: steps of one and two ticks, exactly as a coarse clock's stamps, but
    each stamp is its sample's time."""
    steps = np.where(np.random.default_rng(seed).random(n) < drop, 2, 1)
    return tick_s * np.concatenate([[0.0], np.cumsum(steps[:-1])]).astype(np.float64)


def test_stamps_that_are_the_sample_times_are_kept_when_the_samples_say_so() -> None:
    # a 1 kHz reader dropping 13 % of its frames: steps of 1 and 2 ms, like the ECP's stamps
    t = _dropped_frames(6000, 1e-3, 0.13, 5)
    y = np.column_stack([0.04 * np.sin(2 * np.pi * 2.5 * t) * np.exp(-0.2 * t), np.zeros(t.size)])
    assert even_stamps(t) is not t          # the steps alone cannot tell the two clocks apart
    assert even_stamps(t, y) is t            # the samples lie smoothly on their own stamps
    assert EVENED_NOTE not in IdData(t, np.zeros(t.size), y).notes
    # and the ECP's stamps, with the same motion sampled evenly, are still evened
    true, stamps = _coarse(6000, 1.1283e-3, 1e-3, 0.0, 0.0)
    moving = np.column_stack([0.04 * np.sin(2 * np.pi * 2.5 * true) * np.exp(-0.2 * true), np.zeros(true.size)])
    assert even_stamps(stamps, moving) is not stamps
    # a record at rest (only the encoder's noise) keeps the evening the device's clock implies
    still = np.round(np.random.default_rng(6).normal(0.0, 5e-6, (stamps.size, 2)) * 56000) / 56000
    assert even_stamps(stamps, still) is not stamps


def test_releases_read_through_dropped_frames_are_dated_on_their_stamps() -> None:
    # a simulated student's 1 kHz record (testkit: its own physics) that lost 13 % of its frames
    from testkit.student_records import student_record
    rec = student_record(21, 1000.0, releases=3)
    keep = np.isin(np.round(rec.t * 1e3), np.round(_dropped_frames(rec.t.size, 1e-3, 0.13, 7) * 1e3))
    assert even_stamps(rec.t[keep]) is not rec.t[keep]   # the steps are a coarse clock's
    found = find_releases(rec.t[keep], rec.y[keep])
    assert len(found) == len(rec.releases)
    for got, true in zip(found, rec.releases):
        assert abs(got.release_time_s - true.time_s) < 2.5e-3, (got, true)
