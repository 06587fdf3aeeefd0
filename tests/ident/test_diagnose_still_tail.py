"""The diagnosis window's still tail: a window whose carts stop early is decimated only as much as
its motion and a still tail as long need, and cut in the tail where the work samples run out
(`ident.diagnose.stretch.still_tail_cut`); and decimated less, and cut sooner, where its work grid
would not resolve the fitted modes (`resolving_decimation`).

The records are drawn from the physics of a dry-friction cart, independently of the code: a
Coulomb-damped ring loses the same amplitude every half cycle, 2F/wn², so its envelope falls
linearly and it stops dead off its rest; a viscous ring decays exponentially to the end of
the record. Readings are rounded to an encoder lattice after noise."""

from __future__ import annotations

import numpy as np
import pytest

from ident.diagnose import diagnose
from ident.diagnose.stretch import MIN_SAMPLES_PER_PERIOD, resolving_decimation, still_tail_cut
from ident.diagnose.window import MAX_WORK_SAMPLES
from testkit.effects import judge, make_case


def _coulomb_ring(rate_hz: float, duration_s: float, stop_s: float, noise_m: float, quantum_m: float,
                  seed: int) -> np.ndarray:
    """(N, 1) a 3.5 Hz ring from 40 mm whose amplitude falls linearly to 0 at `stop_s`, then at
    rest 0.4 mm off centre; noise then the lattice."""
    t = np.arange(int(duration_s * rate_hz)) / rate_hz
    amplitude = 0.04 * np.clip(1.0 - t / stop_s, 0.0, None)
    x = amplitude * np.cos(2 * np.pi * 3.5 * t) + 4e-4 * (t >= stop_s)
    x = x + np.random.default_rng(seed).normal(0.0, noise_m, t.size)
    return (np.round(x / quantum_m) * quantum_m)[:, None]


@pytest.mark.parametrize(("rate_hz", "noise_m", "quantum_m"), [(55.0, 1e-3, 1.6e-3), (1000.0, 5e-6, 1.8e-5)])
def test_a_cart_stopped_early_keeps_half_the_work_samples_for_its_motion(rate_hz: float, noise_m: float,
                                                                       quantum_m: float) -> None:
    # stopped 2 s into a 15 s window: at 55 Hz 825 samples (decimated by 2 whole), at 1 kHz 15000
    y = _coulomb_ring(rate_hz, 15.0, 2.0, noise_m, quantum_m, seed=3)
    kept, decimation = still_tail_cut(y)
    assert kept is not None
    moving = int(2.0 * rate_hz)
    work = kept // decimation
    assert work <= MAX_WORK_SAMPLES and kept <= y.shape[0]
    # the motion has at least half the work samples, and a still tail at least as long is kept
    # the motion and a still tail at least as long fit undecimated in the work samples, or
    # decimated only as much as they need; the tail is cut where the work samples run out
    assert kept >= 1.9 * moving and work >= MAX_WORK_SAMPLES - 1
    # and no coarser than the motion needs (1 at 55 Hz, where the whole window took every second)
    assert decimation <= int(np.ceil(2 * moving / MAX_WORK_SAMPLES))


def test_a_ring_to_the_end_and_a_short_window_are_kept_whole() -> None:
    t = np.arange(15 * 200) / 200.0
    ringing = (0.04 * np.exp(-0.3 * t) * np.cos(2 * np.pi * 3.5 * t))[:, None]
    assert still_tail_cut(ringing) == (None, int(np.ceil(t.size / MAX_WORK_SAMPLES)))
    short = _coulomb_ring(50.0, 8.0, 2.0, 1e-5, 1e-5, seed=1)   # 400 samples: never decimated
    assert still_tail_cut(short) == (None, 1)


def test_a_second_fitted_cart_that_moves_to_the_end_keeps_the_window_whole() -> None:
    # one cart stops at 2 s; the other fitted cart (second column) still moves 2 mm at the end
    # (a held cart's column is the input, not passed: `stretch._cut` gives the fitted columns)
    y = _coulomb_ring(200.0, 15.0, 2.0, 5e-6, 1.8e-5, seed=4)
    t = np.arange(y.shape[0]) / 200.0
    other = 2e-3 * np.sin(2 * np.pi * 0.15 * t)
    assert still_tail_cut(np.column_stack([y[:, 0], other]))[0] is None


def test_the_resolving_decimation_keeps_six_samples_a_period_and_no_more() -> None:
    for wn, rate in [(36.0, 222.0), (15.5, 890.0), (100.0, 1000.0), (5.0, 50.0), (60.0, 50.0)]:
        dt = 1.0 / rate
        d = resolving_decimation(wn, dt)
        per_period = 2.0 * np.pi / wn / dt
        assert d >= 1
        assert per_period / d >= MIN_SAMPLES_PER_PERIOD or d == 1
        assert per_period / (d + 1) < MIN_SAMPLES_PER_PERIOD


@pytest.mark.slow
def test_a_stiff_cart_dragged_to_the_end_of_a_long_record_is_fitted_on_a_grid_that_resolves_its_ring() -> None:
    # `testkit.effects` coulomb+held_cart (wide carts, 18 s at 222 Hz): a 5.8 Hz cart that dry
    # friction stops within 2 s and the wandering held cart drags in stick-slip to 15.7 s. Decimated
    # to 500 work samples (one in 8: four a period) the friction was 50 % off and the coupling
    # not found; the bench case of `tools/bench_diagnose.py --families coulomb+held_cart
    # --wide-carts --record-s 18` (case 22)
    case = make_case(451227722, "coulomb+held_cart", record_s=18.0, wide_carts=True)
    result = diagnose(case.observed.t, case.observed.y, carts=1)
    wn = result.report.corrected_linear["wn_rad_s"]
    assert 2.0 * np.pi / wn / float(np.median(np.diff(result.t))) >= MIN_SAMPLES_PER_PERIOD
    verdict = judge(case, result.report)
    assert verdict.all_found, verdict.found
    assert verdict.errors["coulomb_accel_m_s2"] < 0.05, verdict.errors
