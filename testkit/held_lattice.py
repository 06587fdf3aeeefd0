"""A free cart with dry friction beside a cart held by a hand, both read through a coarse encoder
lattice: the records of `tests/ident/test_diagnose_held_lattice.py` and
`tests/ident/test_diagnose_stuck_lattice.py`, written from the physics (no code of `ident`).

Cart 2 pulled, held and let go with dry friction; cart 1 on its wall spring k1, the coupling k2
and a hand (a spring kh and a damper, ζ 0.5) whose grip wanders by a few millimetres at
0.05-0.5 Hz, so cart 1 follows cart 2 by k2/(k1 + k2 + kh) (3-6 %) and wanders. Integrated by
RK4 at 0.2 ms, a stop where the velocity changes sign and the spring cannot overcome the
friction; both carts read through the lattice (a different phase each) with noise after it.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]


def held_lattice_record(rng: np.random.Generator, pull_m: tuple[float, float], stop_cycles: tuple[float, float],
                        rate_hz: tuple[float, float], q_m: tuple[float, float], noise_q: float | tuple[float, float]
                        ) -> tuple[FloatArray, FloatArray, dict[str, float]]:
    """(t (N,) s, readings (N, 2) m, truth): cart 2 pulled by `pull_m` (either sign), held and let
    go at 0.8-1.2 s with dry friction that stops it within `stop_cycles` cycles; cart 1 held by a
    hand beside it; both read through a lattice of `q_m` at `rate_hz` with white noise of
    `noise_q` (a value, or a range drawn from) lattice steps after it. The truth: β = k2/m2 and
    the friction (m/s²)."""
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
    d = rng.uniform(*pull_m) * rng.choice([-1.0, 1.0])
    fk = k * abs(d) / (4 * rng.uniform(*stop_cycles))
    f_h, a_h = rng.uniform(0.05, 0.5, 3), rng.uniform(0.3, 1.0, 3)
    a_h *= rng.uniform(3e-3, 6e-3) / (2 * a_h.sum())
    ph = rng.uniform(0, 2 * np.pi, 3)

    waves = [(float(a), 2 * math.pi * float(f), float(p)) for a, f, p in zip(a_h, f_h, ph)]

    def hand(t: float) -> float:
        return sum(a * math.sin(w * t + p) for a, w, p in waves)

    rate, t_r, end = rng.uniform(*rate_hz), rng.uniform(0.8, 1.2), rng.uniform(8.0, 12.0)
    h = 2e-4
    x1, v1, x2, v2 = 0.0, 0.0, -d, 0.0
    x1 = (k2 * x2 + kh * hand(0.0)) / (k1 + k2 + kh)
    stuck = True
    t_s: FloatArray = np.arange(0.0, end, 1.0 / rate, dtype=np.float64)
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
    q = rng.uniform(*q_m)
    offsets = rng.uniform(0.0, q, 2)
    noise = noise_q if isinstance(noise_q, float) else rng.uniform(*noise_q)
    read = q * np.round((out + offsets) / q) - offsets + rng.normal(0.0, noise * q, out.shape)
    truth = {"held_cart_gain_per_s2": k2 / m2, "coulomb_accel_m_s2": float(fk / m2)}
    return t_s, read, truth
