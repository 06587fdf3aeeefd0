"""A free cart that sticks for most of the window on a coarse encoder lattice, read with noise
after the encoder, beside a hand-held cart: the σ of the coupling β = k2/m2 and of the friction
must count the one reading error the stuck cart's level carries.

The record is written from the physics here (no code of `ident`): cart 2 pulled, held and let
go with dry friction that stops it within 2-5 cycles, so it sits stuck on one level of a
0.3-0.8 mm lattice for most of an 8-12 s window; cart 1 on its wall spring k1, the coupling k2
and a hand (a spring kh and a damper, ζ 0.5) whose grip wanders by a few millimetres at
0.05-0.5 Hz. Both carts read through the lattice (a different phase each) with white noise of
0.1-0.25 q after it. Integrated by RK4 at 0.2 ms, a stop where the velocity changes sign and
the spring cannot overcome the friction.

Red team `coulomb+held_cart` 3404 (a 0.52 mm lattice, the free cart stuck 10 of 12 s): β -28 %
reported ± 6.3 % (4.4σ); over 5700-5729 the rms of (estimate - truth)/σ of β was 1.7, of the
friction 2.3. While stuck, the reading's error is one number, not q²/12 a sample.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ident.diagnose import diagnose

SEEDS = range(1, 13)


def _record(seed: int) -> tuple[np.ndarray, np.ndarray, dict[str, float]]:
    rng = np.random.default_rng([seed, 3404])
    m1, m2 = rng.uniform(0.6, 2.5), rng.uniform(1.0, 2.5)
    k = rng.uniform(150.0, 500.0)
    share = rng.uniform(0.35, 0.65)
    k2, k3 = k * share, k * (1 - share)
    k1 = rng.uniform(300.0, 800.0)
    follow = rng.uniform(0.03, 0.06)
    kh = k2 / follow - k1 - k2
    ch = 2 * 0.5 * math.sqrt(kh * m1)
    zeta = rng.uniform(0.01, 0.03)
    c2 = 2 * zeta * math.sqrt(k * m2)
    d = rng.uniform(0.04, 0.09) * rng.choice([-1.0, 1.0])
    fk = k * abs(d) / (4 * rng.uniform(2.0, 5.0))
    f_h, a_h = rng.uniform(0.05, 0.5, 3), rng.uniform(0.3, 1.0, 3)
    a_h *= rng.uniform(3e-3, 6e-3) / (2 * a_h.sum())
    ph = rng.uniform(0, 2 * np.pi, 3)

    waves = [(float(a), 2 * math.pi * float(f), float(p)) for a, f, p in zip(a_h, f_h, ph)]

    def hand(t: float) -> float:
        return sum(a * math.sin(w * t + p) for a, w, p in waves)

    rate, t_r, end = rng.uniform(60.0, 150.0), rng.uniform(0.8, 1.2), rng.uniform(8.0, 12.0)
    h = 2e-4
    x1, v1, x2, v2 = 0.0, 0.0, -d, 0.0
    x1 = (k2 * x2 + kh * hand(0.0)) / (k1 + k2 + kh)
    stuck = True
    t_s = np.arange(0.0, end, 1.0 / rate)
    out = np.empty((t_s.size, 2))
    j, t = 0, 0.0

    def acc(t: float, x1: float, v1: float, x2: float, v2: float, slide: float) -> tuple[float, float]:
        a1 = (-k1 * x1 - k2 * (x1 - x2) - kh * (x1 - hand(t)) - ch * v1) / m1
        a2 = (-k3 * x2 - k2 * (x2 - x1) - c2 * v2 - fk * slide) / m2
        return a1, a2

    while j < t_s.size:
        while j < t_s.size and t_s[j] <= t + 1e-12:
            out[j] = x1, x2
            j += 1
        pull = -k3 * x2 - k2 * (x2 - x1)
        if stuck and t >= t_r and abs(pull) > fk:
            stuck = False
        slide = 0.0 if stuck else (math.copysign(1.0, v2) if v2 != 0 else math.copysign(1.0, pull))
        s = 0.0 if stuck else 1.0
        a1, a2 = acc(t, x1, v1, x2, v2, slide)
        b1, b2 = acc(t + h / 2, x1 + h / 2 * v1, v1 + h / 2 * a1, x2 + s * h / 2 * v2, s * (v2 + h / 2 * a2), slide)
        c1_, c2_ = acc(t + h / 2, x1 + h / 2 * (v1 + h / 2 * a1), v1 + h / 2 * b1,
                       x2 + s * h / 2 * (v2 + h / 2 * a2), s * (v2 + h / 2 * b2), slide)
        d1, d2 = acc(t + h, x1 + h * (v1 + h / 2 * b1), v1 + h * c1_, x2 + s * h * (v2 + h / 2 * b2),
                     s * (v2 + h * c2_), slide)
        nx1 = x1 + h * (v1 + h / 6 * (a1 + b1 + c1_))
        nv1 = v1 + h / 6 * (a1 + 2 * b1 + 2 * c1_ + d1)
        if not stuck:
            nx2 = x2 + h * (v2 + h / 6 * (a2 + b2 + c2_))
            nv2 = v2 + h / 6 * (a2 + 2 * b2 + 2 * c2_ + d2)
            if nv2 * v2 < 0 and abs(-k3 * nx2 - k2 * (nx2 - nx1)) <= fk:   # it stops here
                nv2, stuck = 0.0, True
            x2, v2 = nx2, nv2
        x1, v1 = nx1, nv1
        t += h
    q = rng.uniform(3e-4, 8e-4)
    offsets = rng.uniform(0.0, q, 2)
    read = q * np.round((out + offsets) / q) - offsets + rng.normal(0.0, rng.uniform(0.1, 0.25) * q, out.shape)
    truth = {"held_cart_gain_per_s2": k2 / m2, "coulomb_accel_m_s2": fk / m2}
    return t_s, read, truth


def z_scores(seed: int) -> dict[str, float] | None:
    """(estimate - truth)/σ of β and the friction for one record; None where the diagnosis did
    not take both effects (a different failure: the σ of a model that is not the physics')."""
    t, y, truth = _record(seed)
    report = diagnose(t, y, carts=1).report
    if not {"coulomb_friction", "held_cart_motion"} <= {e.effect for e in report.effects}:
        return None
    params, std = report.extended.parameters, report.extended.parameter_std
    assert all(0 < std[name] < 0.5 * true for name, true in truth.items()), (std, truth)   # no mere shrug
    return {name: (params[name] - true) / std[name] for name, true in truth.items()}


@pytest.mark.slow
def test_a_stuck_cart_on_a_coarse_lattice_reports_sigmas_its_errors_fit() -> None:
    # before: the friction's rms z 1.8 over the 7 records with both effects (3.4σ on seed 11)
    zs = [z for z in (z_scores(seed) for seed in SEEDS) if z is not None]
    assert len(zs) >= 6
    for name in ("held_cart_gain_per_s2", "coulomb_accel_m_s2"):
        z = np.array([s[name] for s in zs])
        assert float(np.sqrt(np.mean(z ** 2))) < 1.5, (name, np.round(z, 2))
