"""Seeded synthetic bench traces for detector tests: lab-case releases and long idle handling.

Unzeroed frame: each cart's rest is 0 m; a pulled cart is held at -pull_m and released at
`release_t_s` (the truth, kept for assertions only). Linear two-cart chain with viscous
damping, solved exactly (eigen-decomposition), sampled at `rate_hz` with a random clock
phase, hand tremor while held, Gaussian noise, quantized to counts.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

LAB_CASES = ("cart1_cart2_pinned", "cart2_cart1_pinned", "both_cart1_pulled")
MASS_KG = (0.8, 0.8)
SPRINGS_N_M = (20.0, 20.0, 20.0)
DAMPING_N_S_M = (0.8, 0.8)


@dataclass(frozen=True)
class Trace:
    t_s: npt.NDArray[np.float64]        # (N,)
    counts: npt.NDArray[np.float64]     # (N, 2)
    counts_per_m: float
    release_t_s: float | None


def min_jerk(s: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """The minimum-jerk path from 0 to 1 over s in [0, 1] (0 before, 1 after)."""
    s = np.clip(s, 0.0, 1.0)
    return 10 * s**3 - 15 * s**4 + 6 * s**5


def _free_response(case: str, x0: npt.NDArray[np.float64], tau: npt.NDArray[np.float64],
                   v0: npt.NDArray[np.float64] | None = None) -> npt.NDArray[np.float64]:
    """Positions (len(tau), 2) after release at x0 with velocities `v0` (default at rest);
    pinned carts stay put."""
    m1, m2 = MASS_KG
    k1, k2, k3 = SPRINGS_N_M
    c1, c2 = DAMPING_N_S_M
    free = [0] if case == LAB_CASES[0] else [1] if case == LAB_CASES[1] else [0, 1]
    stiffness = np.array([[k1 + k2, -k2], [-k2, k2 + k3]])[np.ix_(free, free)]
    mass = np.diag([m1, m2])[np.ix_(free, free)]
    damping = np.diag([c1, c2])[np.ix_(free, free)]
    n = len(free)
    minv = np.linalg.inv(mass)
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-minv @ stiffness, -minv @ damping]])
    lam, vec = np.linalg.eig(a)
    z0 = np.concatenate([x0[free], np.zeros(n) if v0 is None else v0[free]])
    coef = np.linalg.solve(vec, z0)
    z = (vec[None, :, :] * (coef[None, :] * np.exp(lam[None, :] * tau[:, None]))[:, None, :]).sum(axis=2).real
    out = np.tile(x0, (len(tau), 1))
    out[:, free] = z[:, :n]
    return out


def lab_run(case: str, rate_hz: float, seed: int, counts_per_m: float = 20000.0,
            noise_m: float = 2e-5, pull_m: float = 0.15, after_s: float = 12.0) -> Trace:
    """Rest, slow pull, hold with tremor, release at a random instant, free response (from
    the position and velocity the tremor gave the cart at the release)."""
    rng = np.random.default_rng(seed)
    rest_s, pull_s, hold_s = rng.uniform(1.0, 2.0), rng.uniform(1.2, 2.5), rng.uniform(1.0, 2.0)
    release = rest_s + pull_s + hold_s + rng.uniform(0, 1 / rate_hz) + 0.3
    t = np.arange(0.0, release + after_s, 1 / rate_hz, dtype=np.float64) + rng.uniform(0, 1 / rate_hz)
    pulled = 1 if case == LAB_CASES[1] else 0
    held = np.zeros(2)
    held[pulled] = -pull_m
    x = np.zeros((len(t), 2))
    before = t < release
    shape = min_jerk((t[before] - rest_s) / pull_s)
    w, phase = 2 * np.pi * 9.0, rng.uniform(0, 6)
    tremor = 2e-4 * np.sin(w * t[before] + phase) * (shape > 0)
    x[before, pulled] = -pull_m * shape + tremor
    # the hand lets go wherever its tremor has the cart, at the tremor's velocity
    v0 = np.zeros(2)
    held[pulled] += 2e-4 * np.sin(w * release + phase)
    v0[pulled] = 2e-4 * w * np.cos(w * release + phase)
    x[~before] = _free_response(case, held, t[~before] - release, v0)
    return _sensor(t, x, rng, counts_per_m, noise_m, release)


def idle_handling(rate_hz: float, seed: int, duration_s: float = 600.0, counts_per_m: float = 20000.0,
                  noise_m: float = 2e-5) -> Trace:
    """Carts at rest, moved slowly by hand (1-3 s min-jerk moves up to 0.15 m), held, put back."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration_s, 1 / rate_hz, dtype=np.float64) + rng.uniform(0, 1 / rate_hz)
    x = np.zeros((len(t), 2))
    start, level = 0.0, np.zeros(2)
    while start < duration_s:
        cart = int(rng.integers(0, 2))
        move_s = rng.uniform(1.0, 3.0)
        target = level.copy()
        target[cart] = rng.uniform(-0.15, 0.15) if rng.random() < 0.7 else 0.0
        span = (t >= start) & (t < start + move_s + 0.5)
        shape = min_jerk((t[span] - start) / move_s)[:, None]
        x[span] = level + (target - level) * shape
        tail = t >= start + move_s + 0.5
        x[tail] = target
        hold = rng.uniform(0.2, 4.0)
        tremor_span = (t >= start) & (t < start + move_s + hold)
        x[tremor_span, cart] += 2e-4 * np.sin(2 * np.pi * rng.uniform(6, 11) * t[tremor_span])
        level = target
        start += move_s + hold
    return _sensor(t, x, rng, counts_per_m, noise_m, None)


def _sensor(t: npt.NDArray[np.float64], x: npt.NDArray[np.float64], rng: np.random.Generator,
            counts_per_m: float, noise_m: float, release: float | None) -> Trace:
    noisy = x + rng.normal(0.0, noise_m, x.shape)
    counts = np.round(noisy * counts_per_m)
    jitter = rng.random(counts.shape) < 0.01
    counts[jitter] += rng.choice([-1.0, 1.0], size=int(jitter.sum()))
    return Trace(t, counts, counts_per_m, release)
