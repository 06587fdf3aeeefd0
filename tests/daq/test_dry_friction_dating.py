"""Flicks from rest of a cart with strong dry friction, dated by `daq.detector` from its ringing.

Generated here from the physics, not from `daq`: a cart on a spring (ω_n 10-30 rad/s, ζ
0.005-0.05) with Coulomb friction that stops a 4 cm swing within 4-25 cycles (static 1-1.5x
kinetic, sticking at a turn where the spring cannot break it away), pushed from rest by a hand
(a half sine) and let go while the hand still pushes (0.6-0.9 of the push: a flick near the
first extreme), integrated at 20 µs with the turns located, sampled and quantized to 1/56000 m.
The detector turns the flick down as "pulled from rest" and dates it from its ringing: within one
sample of the let-go. (Friction modelled as a centre that jumps at each turn had stopped the
slide-back a half-period late on such a cart: 5.3 samples at 200 Hz here, +126 ms on red-team
record 313.)
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from testkit.release_tally import detect

Q = 1.0 / 56000.0


def _student_flick(rng: np.random.Generator, rate_hz: float) -> tuple[np.ndarray, np.ndarray, float]:
    wn = rng.uniform(10.0, 30.0)
    zeta = rng.uniform(0.005, 0.05)
    cycles = rng.uniform(4.0, 25.0)               # a 4 cm swing dies in this many cycles
    fk = wn ** 2 * 0.04 / (4.0 * cycles)          # kinetic friction per unit mass
    fs = fk * rng.uniform(1.0, 1.5)
    dur = rng.uniform(0.5, 0.8) * math.pi / wn    # the push: a half sine of this length
    frac = rng.uniform(0.6, 0.9)                  # let go at this share of it, still pushing
    amp = rng.uniform(0.03, 0.05) * rng.choice([-1.0, 1.0])
    push = wn ** 2 * amp * 1.3                    # about the force that swings it out by amp
    t_s = 1.0 + rng.uniform(0.0, 1.0 / rate_hz)
    t_r = t_s + frac * dur
    h = 2e-5
    n = int(3.5 / h)
    x = v = 0.0
    stuck = True
    xs = np.empty(n)
    for i in range(n):
        now = i * h
        pushing = t_s <= now < t_r
        hand = push * math.sin(math.pi * (now - t_s) / dur) if pushing else 0.0
        spring = -wn ** 2 * x + hand
        if stuck:
            if abs(spring) <= fs:
                xs[i] = x
                continue
            stuck = False
            s = math.copysign(1.0, spring)
        else:
            s = math.copysign(1.0, v) if v != 0.0 else math.copysign(1.0, spring)
        a = spring - 2 * zeta * wn * v - fk * s
        v_new = v + h * a
        if v != 0.0 and v_new * v < 0.0:          # a turn: stop, then stick or reverse
            x += h * 0.5 * v
            v = 0.0
            stuck = abs(-wn ** 2 * x) <= fs and not pushing
        else:
            x += h * 0.5 * (v + v_new)
            v = v_new
        xs[i] = x
    t = np.arange(int(3.5 * rate_hz)) / rate_hz
    y = np.round(np.interp(t, h * np.arange(n), xs) / Q) * Q
    return t, y, t_r


@pytest.mark.parametrize("rate_hz", [50, 100, 200, 1000])
def test_flicks_of_a_cart_with_strong_dry_friction_are_dated_within_a_sample(rate_hz: int) -> None:
    rng = np.random.default_rng(100 + rate_hz)
    errors = []
    for _ in range(8):
        t, y, t_r = _student_flick(rng, rate_hz)
        found = detect((float(t[k]), (float(y[k]), 0.0)) for k in range(t.size))
        errors.append([round((f - t_r) * rate_hz, 2) for f in found])
    assert all(len(e) == 1 and abs(e[0]) <= 1.0 for e in errors), errors
