"""`daq.joined.date_release` against an independent ODE solve of a hand's force that
ends at the release (the truth is used only in the assertions).

A cart on a spring with viscous damping, `x'' = -wn² x - 2 ζ wn x' + h(t)`, with a hand force
per unit mass `h(t) = F_r + S (t_r - t)` before the release t_r and 0 after (the shape measured
on the real ECP-210 flicks: still 0.2-1.2 times the spring's pull when the hand lets go, ending
at once). Solved by `scipy.integrate.solve_ivp` (not `ident.physics`), sampled, quantized.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from daq.detector import ReleaseDetector
from daq.detector_events import Released
from daq.joined import date_release
from daq.ringing import fit_free, motion_sign

WN, ZETA = 11.0, 0.03


def _flick(t_r: float, x_r: float, v_r: float, ratio: float, slope: float, rate_hz: float, q_m: float,
           rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Samples (t, quantized x) of a flick: state (x_r, v_r) at the release, the hand's force at
    let-go `ratio` times the spring's pull (outward), growing by `slope` m/s³ going back in time."""
    f_r = ratio * WN ** 2 * x_r
    direction = math.copysign(1.0, x_r)

    def rhs(t: float, z: np.ndarray) -> list[float]:
        hand = f_r + direction * slope * (t_r - t) if t < t_r else 0.0
        return [z[1], -WN ** 2 * z[0] - 2 * ZETA * WN * z[1] + hand]

    t_start, t_end = t_r - 0.12, t_r + 1.2
    phase = rng.uniform(0.0, 1.0)
    t = t_start + (np.arange(int((t_end - t_start) * rate_hz)) + phase) / rate_hz
    back = t[t < t_r][::-1]
    ahead = t[t >= t_r]
    kw = dict(rtol=1e-10, atol=1e-12, max_step=1e-3)
    x_back = solve_ivp(rhs, (t_r, back[-1]), [x_r, v_r], t_eval=back, **kw).y[0][::-1]
    x_ahead = solve_ivp(rhs, (t_r, ahead[-1]), [x_r, v_r], t_eval=ahead, **kw).y[0]
    x = np.concatenate([x_back, x_ahead])
    return t, np.round(x / q_m) * q_m


@pytest.mark.parametrize("rate_hz", [50, 100, 200, 1000])
def test_a_hand_force_ending_at_the_release_is_dated_within_one_sample(rate_hz: int) -> None:
    rng = np.random.default_rng(rate_hz)
    half = math.pi / WN
    errors = []
    for _ in range(12):
        x_r = rng.uniform(0.03, 0.07) * rng.choice([-1.0, 1.0])
        v_r = math.copysign(rng.uniform(0.2, 0.6), x_r)                 # still moving outward
        ratio, slope = rng.uniform(0.3, 1.2), rng.uniform(0.0, 60.0)   # m/s² per s going back
        t_r = 1.0 + rng.uniform(0.0, 1.0 / rate_hz)
        t, y = _flick(t_r, x_r, v_r, ratio, slope, rate_hz, 5e-5, rng)
        vs = motion_sign(t, y)
        window = (t >= t_r + 0.3) & (t <= t_r + 0.3 + 1.5 * half)
        free = fit_free(t[window], y[window], 0.0 * vs[window], 0.0, WN)
        assert free is not None
        # the coarse start as the detector's slide-back leaves it: within a few samples
        t_coarse = t_r + rng.uniform(-3.0, 3.0) / rate_hz
        date = date_release(t, y, 0.0 * vs, free, t_coarse, half)
        assert date is not None
        errors.append(date.t0_s - t_r)
        # the spring's and damper's acceleration at the release, from the fitted free response
        print(rate_hz, (date.t0_s - t_r) * rate_hz, date.accel_m_s2 / abs(WN ** 2 * x_r + 2 * ZETA * WN * v_r))
    assert max(abs(e) for e in errors) <= 1.0 / rate_hz, errors


def _flick_along_a_path(wn: float, zeta: float, amp: float, dur: float, t0: float, t_r: float,
                        rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Samples (t, x quantized to 50 µm) of a flick as a hand's path: the cart follows the hand
    from rest to `amp` along a quintic over `dur` from `t0`, is let go at `t_r` (near the path's
    end, still moving a little) and is free from then on. Before the let-go the hand's force is
    what keeps the cart on the path: curved in time over the last tenth of a second."""
    def path(tt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        u = np.clip((tt - t0) / dur, 0.0, 1.0)
        return amp * (10 * u ** 3 - 15 * u ** 4 + 6 * u ** 5), amp * (30 * u ** 2 - 60 * u ** 3 + 30 * u ** 4) / dur

    t = np.arange(int(3.0 * rate_hz)) / rate_hz
    x = path(t)[0]
    x_r, v_r = (float(v[0]) for v in path(np.array([t_r])))
    after = t >= t_r
    x[after] = solve_ivp(lambda _, z: [z[1], -wn ** 2 * z[0] - 2 * zeta * wn * z[1]], (t_r, t[-1]), [x_r, v_r],
                         t_eval=t[after], rtol=1e-10, atol=1e-12, max_step=1e-3).y[0]
    return t, np.round(x / 5e-5) * 5e-5


def _flicks_dated(rng: np.random.Generator, n: int, rate_hz: float) -> list[float]:
    """`n` flicks along a hand's path drawn from `rng` (ω 8-25 rad/s, ζ 0.005-0.05, 3-5 cm in
    0.10-0.20 s, let go at 0.8-1.0 of the path), each dated from a coarse instant up to three
    samples off: the errors in samples."""
    errors = []
    for _ in range(n):
        wn, zeta = rng.uniform(8.0, 25.0), rng.uniform(0.005, 0.05)
        amp, dur = rng.uniform(0.03, 0.05) * rng.choice([-1.0, 1.0]), rng.uniform(0.10, 0.20)
        t0 = 1.0 + rng.uniform(0.0, 1.0 / rate_hz)
        t_r = t0 + rng.uniform(0.8, 1.0) * dur
        t, y = _flick_along_a_path(wn, zeta, amp, dur, t0, t_r, rate_hz)
        half = math.pi / wn
        vs = motion_sign(t, y)
        window = (t >= t_r + 0.3) & (t <= t_r + 0.3 + 1.5 * half)
        free = fit_free(t[window], y[window], 0.0 * vs[window], 0.0, wn)
        assert free is not None
        date = date_release(t, y, 0.0 * vs, free, t_r + rng.uniform(-3.0, 3.0) / rate_hz, half)
        assert date is not None
        errors.append((date.t0_s - t_r) * rate_hz)
    return errors


@pytest.mark.parametrize("rate_hz", [50, 100, 1000])
def test_a_flick_along_a_hands_path_is_dated_within_a_sample(rate_hz: int) -> None:
    # a straight hand force (the model before) dated these 1.0 and 1.0 samples RMS off at 50 and
    # 100 Hz, and 2.5 samples early at the median at 1 kHz (where no let-go of these moves the
    # cart by more than the 50 µm lattice within a sample: the median, not each). Not at 200 Hz:
    # there the curve's evidence through this lattice (F 3-6) stays under `daq.joined.CURVE_F`,
    # and those flicks are dated as by the line, 1.2 samples RMS (a known limit)
    errors = _flicks_dated(np.random.default_rng(100 + rate_hz), 12, rate_hz)
    if rate_hz < 1000:
        assert float(np.sqrt(np.mean(np.square(errors)))) <= 0.75, errors
    else:
        assert float(np.median(np.abs(errors))) <= 1.0, errors


def _pull_hold_release(wn: float, x0: float, mu_m_s2: float, tremor_m: float, t_r: float, rate_hz: float,
                       rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Samples (t, (N, 2) m) of a cart pulled from rest to `x0` by a hand (a smooth 0.6 s path),
    held there trembling (`tremor_m` at 7-11 Hz) and let go at `t_r`: from then on
    `x'' = -wn² x - 2 ζ wn x' - mu sign(x')` solved by `solve_ivp` turn by turn (stuck when the
    spring's pull no longer beats friction). The other cart sits still. Quantized to the
    ECP-210's 1/56000 m with 0.1 count of noise before it."""
    zeta, w_tr = 0.02, 2 * math.pi * rng.uniform(7.0, 11.0)
    t_pull = t_r - rng.uniform(0.5, 1.5) - 0.6

    def hand(t: np.ndarray) -> np.ndarray:
        s = np.clip((t - t_pull) / 0.6, 0.0, 1.0)
        held = x0 * (10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5)
        ramp = np.clip((t - t_pull - 0.6) / 0.2, 0.0, 1.0)
        return held + ramp * tremor_m * np.sin(w_tr * (t - t_pull - 0.6))

    t = (np.arange(int((t_r + 1.0) * rate_hz)) + rng.uniform(0.0, 1.0)) / rate_hz
    x = hand(t)
    around = hand(np.array([t_r - 1e-6, t_r, t_r + 1e-6]))
    state = [float(around[1]), float(around[2] - around[0]) / 2e-6]
    t_now = t_r
    while t_now < t[-1] and abs(wn ** 2 * state[0]) > mu_m_s2:
        sign = -math.copysign(1.0, state[0])     # it moves towards rest until the next turn

        def rhs(_: float, z: np.ndarray, sign: float = sign) -> list[float]:
            return [z[1], -wn ** 2 * z[0] - 2 * zeta * wn * z[1] - mu_m_s2 * sign]

        def turn(_: float, z: np.ndarray) -> float:
            return float(z[1])
        turn.terminal, turn.direction = True, sign * -1.0   # type: ignore[attr-defined]
        sol = solve_ivp(rhs, (t_now, t[-1]), state, events=turn, dense_output=True, rtol=1e-10, atol=1e-12,
                        max_step=1e-3)
        t_end = float(sol.t[-1])
        span = (t >= t_now) & (t <= t_end)
        x[span] = sol.sol(t[span])[0]
        state, t_now = [float(sol.y[0, -1]), 0.0], t_end + 1e-9
    x[t >= t_now] = state[0]
    counts = np.stack([x, np.zeros_like(x)], axis=1) * 56000.0 + rng.normal(0.0, 0.1, (t.size, 2))
    return t, np.round(counts) / 56000.0


@pytest.mark.parametrize("rate_hz", [200, 1000])
def test_a_stiff_spring_let_go_from_a_hold_is_dated_within_one_sample(rate_hz: int) -> None:
    # a stiff spring turns over the onset fit's window (ωτ ≈ 2 at 40 rad/s and 50 ms), where
    # τ², τ³ after t0 dated it up to 1.2 ms late; ω from the pull and its start acceleration
    rng = np.random.default_rng(rate_hz + 7)
    errors = []
    for _ in range(6):
        wn, x0 = rng.uniform(20.0, 60.0), rng.uniform(0.03, 0.12) * rng.choice([-1.0, 1.0])
        mu = wn ** 2 * abs(x0) * rng.uniform(0.005, 0.05)   # dry friction 0.5-5 % of the spring's pull
        t_r = 2.0 + rng.uniform(0.0, 1.0)
        t, pos = _pull_hold_release(wn, x0, mu, rng.uniform(0.0, 5e-5), t_r, rate_hz, rng)
        detector = ReleaseDetector()
        found = [e.t_release_s for k in range(t.size) for e in detector.feed(float(t[k]), tuple(pos[k]))
                 if isinstance(e, Released)]
        assert len(found) == 1, (wn, x0, found)
        errors.append((found[0] - t_r) * rate_hz)
    assert max(abs(e) for e in errors) <= 1.0, errors


@pytest.mark.slow
def test_a_short_50_hz_flick_is_dated_on_the_samples_after_its_push_peak() -> None:
    """At 50 Hz the hand's window is set by its sample minimum (five samples), which a push of
    5-10 samples fills back across its peak, where no line or curve of the force fits: the
    three last samples are taken instead when dropping the others gains in an F test
    (`daq.joined.HAND_SHORT_SAMPLES`). Before: 80 of these 96 flicks within one sample, RMS
    0.87 samples; after: 87, 0.64."""
    errors = _flicks_dated(np.random.default_rng(3050), 96, 50.0)
    within = int(np.sum(np.abs(errors) <= 1.0))
    rms = float(np.sqrt(np.mean(np.square(errors))))
    assert within >= 84 and rms <= 0.8, (within, rms, np.round(errors, 2))
