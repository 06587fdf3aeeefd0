"""`ident.releases.find_releases` on short records of a slow pull, a hold and a release cut
by the end of the record (issue 10: "the last release may be cut by the end of the record").

Written from the physics, independently of the finder: one cart (ω_n ∈ [6, 20] rad/s,
ζ ∈ [0.005, 0.04]) at rest, pulled by hand to -d (d ∈ [3, 10] cm) along a minimum-jerk path
in 0.4–0.8 s, held still 0.3–1 s, let go; the free response is the damped oscillator's from
rest at -d, x(τ) = -d e^{-ζω_n τ} (cos ω_d τ + ζω_n/ω_d sin ω_d τ), and the record ends
0.8–1.5 s after the release (about one period of ringing: the pull is as long as the ring,
and its slow bump can outweigh the ringing in the velocity spectrum). Read through an
encoder of 1/56,000 m at 50–1000 Hz. The release must be found once, within two samples.
"""

from __future__ import annotations

import numpy as np
import pytest

from ident.releases import find_releases

RATES_HZ = (50.0, 100.0, 200.0, 1000.0)
QUANTUM_M = 1.0 / 56000.0
DRAWS = 12


def _record(seed: int, rate_hz: float) -> tuple[np.ndarray, np.ndarray, float]:
    rng = np.random.default_rng(seed)
    wn, zeta = rng.uniform(6.0, 20.0), rng.uniform(0.005, 0.04)
    d = rng.uniform(0.03, 0.10)
    start, pull, hold = rng.uniform(0.3, 1.0), rng.uniform(0.4, 0.8), rng.uniform(0.3, 1.0)
    release = start + pull + hold
    end = release + rng.uniform(0.8, 1.5)
    t = np.arange(int(end * rate_hz) + 1) / rate_hz
    s = np.clip((t - start) / pull, 0.0, 1.0)
    x = -d * (10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5)
    tau = t[t >= release] - release
    wd = wn * np.sqrt(1.0 - zeta ** 2)
    x[t >= release] = -d * np.exp(-zeta * wn * tau) * (np.cos(wd * tau) + zeta * wn / wd * np.sin(wd * tau))
    y = QUANTUM_M * np.round(x / QUANTUM_M)
    return t, y[:, None], release


@pytest.mark.parametrize("rate_hz", RATES_HZ)
def test_a_short_record_of_a_slow_pull_and_a_cut_release_gives_that_release(rate_hz: float) -> None:
    problems = []
    for seed in range(DRAWS):
        t, y, release = _record(seed, rate_hz)
        found = find_releases(t, y)
        if len(found) != 1 or abs(found[0].release_time_s - release) > 2.0 / rate_hz:
            problems.append((seed, round(release, 3), [round(r.release_time_s, 4) for r in found]))
    assert problems == []
