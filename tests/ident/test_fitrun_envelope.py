"""The peak envelope and its laws against closed-form rings (`ident.fitrun.envelope`).

Generators written from the physics, not from the code: a cart released from `rest - A0`
- with dry (Coulomb) friction only rings in half-cycles of cosines about `rest ∓ Fc/k`,
  each peak `2 Fc/k` lower than the one before, until it sticks;
- with viscous damping only rings as `e^{-ζ wn t}` times a sinusoid (peaks one half-cycle
  apart keep the ratio `exp(-π ζ / √(1 - ζ²))`);
- with both, a damped half-cycle about `rest ∓ Fc/k` each time (piecewise exact).
Parameters are drawn, seeded, from the lab's ranges: wn 5–20 rad/s, pull 3–15 cm,
Fc/k 0.3–3 mm, ζ 0.01–0.08, 100–1000 Hz, noise 5–50 µm.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ident.fitrun.envelope import coulomb_line, fit_envelope, half_cycle_peaks, rest_from_extremes, viscous_curve
from schemas.fit import EnvelopeRec


def _damped_half_cycles(wn: float, zeta: float, fc_over_k: float, a0: float, rest: float,
                        t: np.ndarray, t_release: float) -> np.ndarray:
    """Piecewise-exact ring: each half-cycle a damped cosine about rest -+ Fc/k (sticks when
    the next swing would not leave the friction band)."""
    wd = wn * math.sqrt(1.0 - zeta ** 2)
    half = math.pi / wd
    x = np.full(t.size, rest - a0)
    start, x_start, direction = t_release, rest - a0, +1.0
    while start <= t[-1]:
        centre = rest - direction * fc_over_k
        amplitude = x_start - centre
        if abs(x_start - rest) <= fc_over_k or direction * amplitude > 0:
            x[t >= start] = x_start                       # stuck inside the friction band
            return x
        mask = (t >= start) & (t < start + half)
        tau = t[mask] - start
        decay = np.exp(-zeta * wn * tau)
        x[mask] = centre + amplitude * decay * (np.cos(wd * tau) + zeta * wn / wd * np.sin(wd * tau))
        x_start = centre - amplitude * math.exp(-zeta * wn * half)
        start, direction = start + half, -direction
    return x


def _draw(seed: int) -> dict[str, float]:
    rng = np.random.default_rng(seed)
    return {"wn": rng.uniform(5, 20), "a0": rng.uniform(0.03, 0.15), "fs": rng.uniform(100, 1000),
            "noise": rng.uniform(5e-6, 50e-6), "rest": rng.uniform(-0.02, 0.2),
            "fc_over_k": rng.uniform(0.3e-3, 3e-3), "zeta": rng.uniform(0.01, 0.08)}


def _ring(p: dict[str, float], zeta: float, fc_over_k: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(0.0, 0.5 + 40 * math.pi / p["wn"], 1.0 / p["fs"])
    x = _damped_half_cycles(p["wn"], zeta, fc_over_k, p["a0"], p["rest"], t, 0.5)
    return t, x + np.random.default_rng(seed + 1000).normal(0.0, p["noise"], t.size)


@pytest.mark.parametrize("seed", range(6))
def test_dry_friction_alone_is_a_straight_line_losing_4_fc_over_k_per_cycle(seed: int) -> None:
    p = _draw(seed)
    t, x = _ring(p, 0.0, p["fc_over_k"], seed)
    env = fit_envelope(t, x, p["rest"] + 0.003, 0.5, p["noise"])    # a guess 3 mm off
    assert env is not None and env.better_law == "coulomb"
    assert env.rest_m == pytest.approx(p["rest"], abs=3 * p["noise"] + 1e-5)
    assert env.coulomb_loss_per_cycle_m == pytest.approx(4 * p["fc_over_k"], rel=0.03)
    assert env.mixed_loss_m_per_half == pytest.approx(2 * p["fc_over_k"], rel=0.05)
    assert env.mixed_ratio_per_half == pytest.approx(1.0, abs=0.02)


@pytest.mark.parametrize("seed", range(6))
def test_viscous_damping_alone_is_an_exponential_keeping_a_constant_ratio(seed: int) -> None:
    p = _draw(seed)
    t, x = _ring(p, p["zeta"], 0.0, seed)
    env = fit_envelope(t, x, p["rest"] - 0.003, 0.5, p["noise"])
    assert env is not None and env.better_law == "viscous"
    assert env.viscous_rate_1_s == pytest.approx(p["zeta"] * p["wn"], rel=0.03)
    q_half = math.exp(-math.pi * p["zeta"] / math.sqrt(1 - p["zeta"] ** 2))
    assert env.mixed_ratio_per_half == pytest.approx(q_half, abs=0.01)
    assert abs(env.mixed_loss_m_per_half) < 0.2e-3


@pytest.mark.parametrize("seed", range(4))
def test_both_at_once_are_separated_by_the_peak_to_peak_regression(seed: int) -> None:
    p = _draw(seed)
    t, x = _ring(p, p["zeta"], p["fc_over_k"], seed)
    env = fit_envelope(t, x, p["rest"], 0.5, p["noise"])
    assert env is not None
    q_half = math.exp(-math.pi * p["zeta"] / math.sqrt(1 - p["zeta"] ** 2))
    # a damped half-cycle about rest -+ d: A(k+1) = q A(k) - d (1 + q)
    assert env.mixed_ratio_per_half == pytest.approx(q_half, abs=0.01)
    assert env.mixed_loss_m_per_half == pytest.approx(p["fc_over_k"] * (1 + q_half), rel=0.1)


def test_rest_from_extremes_cancels_the_alternation_of_either_law() -> None:
    rest, d = 0.1, 0.002
    coulomb = [rest + (-1) ** k * (0.05 - d * k) for k in range(8)]
    viscous = [rest + (-1) ** k * 0.05 * 0.95 ** k for k in range(8)]
    assert rest_from_extremes(np.array(coulomb)) == pytest.approx(rest, abs=1e-12)
    assert rest_from_extremes(np.array(viscous)) == pytest.approx(rest, abs=0.05 * 0.05 ** 2)


def test_too_few_peaks_give_no_envelope() -> None:
    t = np.arange(0.0, 3.0, 0.01)
    x = np.where(t < 0.5, -0.05, 0.0)          # one jump to rest: no ring
    assert fit_envelope(t, x, 0.0, 0.5, 1e-5) is None


def test_the_envelope_is_the_reports_record_and_its_laws_pass_through_the_peaks() -> None:
    # one definition: fit_envelope returns schemas.fit.EnvelopeRec; it survives JSON, and the
    # fitted laws evaluated at the peaks' times stay within their own RMS misfit on average
    p = _draw(2)
    t, x = _ring(p, 0.0, p["fc_over_k"], 2)
    env = fit_envelope(t, x, p["rest"], 0.5, p["noise"], output=2)
    assert isinstance(env, EnvelopeRec) and env.output == 2
    assert EnvelopeRec.model_validate_json(env.model_dump_json()) == env
    times, peaks = np.asarray(env.t_s), np.asarray(env.peak_m)
    assert np.sqrt(np.mean((coulomb_line(env, times) - peaks) ** 2)) == pytest.approx(env.coulomb_rms_m, rel=1e-6)
    assert np.sqrt(np.mean((viscous_curve(env, times) - peaks) ** 2)) == pytest.approx(env.viscous_rms_m, rel=1e-6)
    assert env.viscous_ratio_per_cycle == pytest.approx(math.exp(-env.viscous_rate_1_s * env.period_s))


@pytest.mark.parametrize("seed", range(4))
def test_a_touch_long_after_the_cart_stuck_is_not_a_peak_of_the_ring(seed: int) -> None:
    # a dry-friction ring sticks; seconds later a hand nudges the cart by a few noise levels
    # more than the floor: that extreme is not a half-cycle of the ring (its gap breaks the
    # rhythm), so the straight line and the period stay those of the ring
    p = _draw(seed)
    t, x = _ring(p, 0.0, p["fc_over_k"], seed)
    stuck_at = 0.5 + (math.pi / p["wn"]) * math.floor(p["a0"] / (2 * p["fc_over_k"]))
    late = stuck_at + 2.0 + 20 * math.pi / p["wn"]
    t = np.concatenate([t, t[-1] + np.arange(1, int(3 * late * p["fs"])) / p["fs"]])
    x = np.concatenate([x, np.full(t.size - x.size, x[-1])])
    bump = np.exp(-0.5 * ((t - late) / 0.05) ** 2)
    x = x + (20 * p["noise"] + 2 * p["fc_over_k"]) * bump * np.sign(p["rest"] - x[-1] + 1e-12)
    env = fit_envelope(t, x, p["rest"], 0.5, p["noise"])
    assert env is not None
    assert max(env.t_s) < stuck_at + 0.5
    assert env.period_s == pytest.approx(2 * math.pi / p["wn"], rel=0.02)
    assert env.coulomb_loss_per_cycle_m == pytest.approx(4 * p["fc_over_k"], rel=0.03)


def test_a_crossing_through_a_sample_exactly_at_the_rest_still_splits_the_half_cycles() -> None:
    # an encoder reads the rest itself: a crossing can pass through e = 0 exactly
    t = np.arange(0.0, 4.0, 0.01)
    e = 0.02 * np.cos(np.pi * t) * np.exp(-0.3 * t)
    e = np.round(e / 1e-4) * 1e-4                                   # a 0.1 mm lattice: zeros at crossings
    assert np.any(e == 0.0)
    times, peaks = half_cycle_peaks(t, e)
    # half-cycles 0-0.5, 0.5-1.5, 1.5-2.5, 2.5-3.5 and the cut one from 3.5 s, alternating;
    # extremes near k s (the decay moves them ~0.03 s early, the lattice's flat tops a little more)
    assert times.size == 5 and np.all(np.sign(peaks[1:]) != np.sign(peaks[:-1]))
    assert times[:4] == pytest.approx([0.0, 1.0, 2.0, 3.0], abs=0.08)
