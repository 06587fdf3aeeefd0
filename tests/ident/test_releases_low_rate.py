"""Releases of a stiff rig read at 50 Hz: 5.5-8 samples a period (issue 10 asks 50 Hz).

The records come from the red team's simulator (`tools/redteam/physics.py`, independent of
the package), drawn from the physical description: one cart of 0.5-1.5 kg ringing at 6-9 Hz
(the rig's springs on a light cart), ζ 0.005-0.05, kinetic dry friction that stops it after
4-25 cycles (static 1-1.5 ×), read at 50 Hz with noise of 1e-5-5e-5 m. The student flicks it
from rest (3-5 cm in 0.10-0.20 s, let go at 80-100 % of the path), lets it ring out, then
pulls it 3-15 cm, holds it and lets go. The free model's fit on one stretch of free motion
had fewer samples than five per coefficient at this rate and was never tried: the fit of the
whole record (a long hold in it) left a residual scale of several m/s², above a flick's force.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from ident.releases import find_releases

REDTEAM = Path(__file__).resolve().parents[2] / "tools" / "redteam"
SEEDS = range(8)
NEAR_S = 0.3
RATE_HZ = 50.0


def _record(seed: int) -> tuple[np.ndarray, np.ndarray, list[float]]:
    sys.path.insert(0, str(REDTEAM))
    try:
        import physics  # the red team's simulator: independent of the package
    finally:
        sys.path.remove(str(REDTEAM))
    rng = np.random.default_rng([5050, seed])
    m = rng.uniform(0.5, 1.5)
    k = m * (2.0 * np.pi * rng.uniform(6.0, 9.0)) ** 2
    flick, pull = rng.uniform(0.03, 0.05) * rng.choice([-1.0, 1.0]), rng.uniform(0.03, 0.15)
    fk = k * 0.04 / (4.0 * rng.uniform(4.0, 25.0))
    cart = physics.Cart(m=m, c=2 * rng.uniform(0.005, 0.05) * np.sqrt(k * m), fk=fk, fs=fk * rng.uniform(1.0, 1.5))
    chain = physics.Chain([cart], k1=k)
    t = np.arange(0.0, 9.0, 1.0 / RATE_HZ)
    t0, dur = rng.uniform(0.3, 1.0), rng.uniform(0.10, 0.20)
    t1 = t0 + rng.uniform(0.8, 1.0) * dur
    sim = physics.Simulator(chain, np.zeros(1), np.zeros(1), 0.0)
    chain.held = {0: physics.quintic(t0, t0 + dur, (0, 0, 0), (flick, 0, 0))}
    out = sim.run(t1, t)
    chain.held = {}
    grab = t1 + rng.uniform(3.0, 4.0)
    free = sim.run(grab, t)
    x_grab = float(sim.x[0])
    t2 = grab + rng.uniform(1.0, 2.0)
    chain.held = {0: physics.quintic(grab, grab + 0.6, (x_grab, 0, 0), (-pull, 0, 0))}
    held = sim.run(t2, t)
    chain.held = {}
    last = sim.run(float(t[-1]) + 1e-9, t)
    x = out
    for part in (free, held, last):
        x = np.where(np.isnan(x), part, x)
    y = x[:, 0] + rng.normal(0.0, np.exp(rng.uniform(np.log(1e-5), np.log(5e-5))), len(t))
    return t, y, [t1, t2]


def test_flicks_and_holds_of_a_stiff_rig_at_50_hz_are_found() -> None:
    missed = []
    for seed in SEEDS:
        t, y, truth = _record(seed)
        times = [r.release_time_s for r in find_releases(t, y)]
        for when in truth:
            if not any(abs(s - when) < NEAR_S for s in times):
                missed.append(f"seed {seed}: let go at {when:.3f} s, listed {times}")
    assert not missed, "\n".join(missed)
