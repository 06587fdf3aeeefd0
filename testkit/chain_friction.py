"""Two carts on springs with dry friction, by `testkit.effects`' event-located integration.

Written from the physics, not from `ident.physics` (`testkit.effects.integrate`: each cart
sliding, or stuck while |spring pull| ≤ its static level, stops and breakaways located as
events). `chain_with_dry_friction` takes the simulator's mass-normalised parameters;
`two_free_carts` draws a lab's two-cart release (both carts free and read).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from testkit.effects.integrate import Phase, simulate
from testkit.effects.rig import make_rig

FloatArray = NDArray[np.float64]


def chain_with_dry_friction(lin: FloatArray, z0: FloatArray, fk: FloatArray, fs: FloatArray,
                            tau: FloatArray) -> FloatArray:
    """Positions (N, 2) at `tau` (from `tau[0]`) of the chain x'' = -Kt x - Ct x' - friction,
    from `z0` = (x1, x2, v1, v2); `lin` = (k1/m1, k2/m1, k2/m2, k3/m2, c1/m1, c2/m2), friction
    per mass (m/s²)."""
    a1, b1, b2, a2, g1, g2 = (float(v) for v in lin)
    m1, m2 = 1.0, b1 / b2   # masses that give these ratios: k2 = b1 m1 = b2 m2
    rig = make_rig([m1, m2], [(0, None, a1 * m1), (0, 1, b1 * m1), (1, None, a2 * m2)], [g1 * m1, g2 * m2],
                   kinetic=[float(f) for f in fk], static=[float(f) for f in fs])
    z = np.asarray(z0, dtype=np.float64)
    return simulate(rig, [Phase(float(tau[0]), float(tau[-1]))], tau, z)[0]


def last_motion(t: FloatArray, x: FloatArray, after_s: float) -> float:
    """When noise-free positions `x` (N,) or (N, k) on `t` (N,) last move after `after_s` (s):
    the sample that ends the last step of more than 0.1 µm; `after_s` when none does."""
    steps = np.max(np.abs(np.diff(np.reshape(x, (t.size, -1)), axis=0)), axis=1)
    moving = np.flatnonzero((steps > 1e-7) & (t[1:] > after_s))
    return float(t[moving[-1] + 1]) if moving.size else after_s


@dataclass(frozen=True)
class TwoCartRun:
    """A record `y` (N, 2) m on `t` (N,) s, the let-go `release_s`, and when the carts last
    move (`stops_s`, from the noise-free motion)."""

    t: FloatArray
    y: FloatArray
    release_s: float
    stops_s: float


def two_free_carts(seed: int) -> TwoCartRun:
    """Cart 1 pulled 3-8 cm and held still for 1-2 s (cart 2 at rest where the springs put it),
    then let go; both carts free, each with dry friction (stopping it after 4-25 cycles, static
    1-1.5 x kinetic), masses 0.5-3 kg, springs 100-800 N/m, ζ 0.005-0.03; read at 50-1000 Hz
    (log-uniform) through encoders of 10 µm-1 mm (log-uniform) with noise before the lattice
    (0.05-0.5 of a count); 8 s after the let-go."""
    rng = np.random.default_rng([seed, 2062])
    m1, m2 = rng.uniform(0.5, 3.0, 2)
    k1, k2, k3 = rng.uniform(100.0, 800.0, 3)
    zeta = rng.uniform(0.005, 0.03, 2)
    pull = rng.uniform(0.03, 0.08)
    fk = np.array([(k1 + k2) * pull / (4 * rng.uniform(4.0, 25.0)) / m1,
                   k2 * pull / (4 * rng.uniform(4.0, 25.0)) / m2])
    fs = fk * rng.uniform(1.0, 1.5, 2)
    lin = np.array([k1 / m1, k2 / m1, k2 / m2, k3 / m2,
                    2 * zeta[0] * np.sqrt((k1 + k2) / m1), 2 * zeta[1] * np.sqrt((k2 + k3) / m2)])
    rate = float(np.exp(rng.uniform(np.log(50.0), np.log(1000.0))))
    hold = rng.uniform(1.0, 2.0)
    t = np.arange(0.0, hold + 8.0, 1.0 / rate, dtype=np.float64)
    release = hold + rng.uniform(0.0, 1.0 / rate)   # between samples
    x0 = np.array([-pull, -pull * k2 / (k2 + k3), 0.0, 0.0])
    after = t >= release
    x = np.empty((t.size, 2))
    x[~after] = x0[:2]
    x[after] = chain_with_dry_friction(lin, x0, fk, fs, np.concatenate([[release], t[after]]))[1:]
    q = float(np.exp(rng.uniform(np.log(1e-5), np.log(1e-3))))
    noisy = x + rng.normal(0.0, rng.uniform(0.05, 0.5) * q, x.shape)
    y = q * np.round(noisy / q)
    return TwoCartRun(t, y - y[0], release, last_motion(t, x, release))
