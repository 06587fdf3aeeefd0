"""A nudge of a ringing cart is no release (issue 10: "handling makes no run: nudges").

Written from the physics, independently of the finder: one cart (ω_n ∈ [6, 20] rad/s,
ζ ∈ [0.005, 0.04]) pulled from rest to -d (d ∈ [5, 10] cm) in 0.5 s, held 0.5 s and let
go; while it still rings (from a period to 3 s later, where it is at least 2 cm off rest), a hand
takes it, moves it by 2–8 mm and back (sin², 0.2–0.5 s) and lets it go where it took it,
at rest; the record ends 3 s later. The nudge leaves the cart swinging by what its position
off rest was (centimetres, no more than before): the hand gave it no swing of its own.
Encoder of 1/56,000 m, 50–1000 Hz. Exactly the one release is found.
"""

from __future__ import annotations

import numpy as np
import pytest

from ident.releases import find_releases

RATES_HZ = (50.0, 100.0, 200.0, 1000.0)
QUANTUM_M = 1.0 / 56000.0
DRAWS = 8


def _free(x0: float, v0: float, tau: np.ndarray, wn: float, zeta: float) -> np.ndarray:
    """The damped oscillator about 0 from (x0, v0) at τ = 0."""
    wd = wn * np.sqrt(1.0 - zeta ** 2)
    s = zeta * wn
    return np.exp(-s * tau) * (x0 * np.cos(wd * tau) + (v0 + s * x0) / wd * np.sin(wd * tau))


def _record(seed: int, rate_hz: float) -> tuple[np.ndarray, np.ndarray, float]:
    rng = np.random.default_rng(seed)
    wn, zeta, d = rng.uniform(6.0, 20.0), rng.uniform(0.005, 0.04), rng.uniform(0.05, 0.10)
    start, release = 0.5, 1.5
    fine = np.arange(0.0, 12.0, 1e-4)
    x = np.zeros(fine.size)
    s = np.clip((fine - start) / 0.5, 0.0, 1.0)
    x[fine < release] = (-d * (10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5))[fine < release]
    ring = fine >= release
    x[ring] = _free(-d, 0.0, fine[ring] - release, wn, zeta)
    # the nudge: at any time from a period to 3 s into the ring where the cart is 2 cm off rest
    after = np.flatnonzero((fine >= release + 2 * np.pi / wn) & (fine <= release + 3.0) & (np.abs(x) >= 0.02))
    k = int(after[rng.integers(after.size)])
    grab = float(fine[k])
    took, duration, height = float(x[k]), rng.uniform(0.2, 0.5), rng.choice([-1, 1]) * rng.uniform(2e-3, 8e-3)
    inside = (fine >= grab) & (fine < grab + duration)
    x[inside] = took + height * np.sin(np.pi * (fine[inside] - grab) / duration) ** 2
    later = fine >= grab + duration
    x[later] = _free(took, 0.0, fine[later] - grab - duration, wn, zeta)
    end = grab + duration + 3.0
    t = np.arange(int(end * rate_hz) + 1) / rate_hz
    y = QUANTUM_M * np.round(np.interp(t, fine, x) / QUANTUM_M)
    return t, y[:, None], release


@pytest.mark.parametrize("rate_hz", RATES_HZ)
def test_a_nudge_of_a_ringing_cart_that_leaves_centimetres_of_swing_is_no_release(rate_hz: float) -> None:
    problems = []
    for seed in range(DRAWS):
        t, y, release = _record(seed, rate_hz)
        found = [round(r.release_time_s, 3) for r in find_releases(t, y)]
        if len(found) != 1 or abs(found[0] - release) > 0.05:
            problems.append((seed, found))
    assert problems == []
