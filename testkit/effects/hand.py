"""What students' hands do: hold a cart still, flick it, hold the other cart loosely.

- `hold(x)`: the cart held at x (m), still.
- `flick(t0, t1, x1, v1)`: from rest at 0 at t0, the hand takes the cart to x1 (m) with
  velocity v1 (m/s) at t1, where it lets go: a cubic in time (C¹ at both ends), as in the ECP
  records where the cart goes from rest to 3–5 cm in ≈ 0.15 s and is let go near the extreme.
- `wander(rng, amplitude)`: where a loosely holding hand is, w(t) = Σ a_k (sin(2π f_k t + φ_k)
  - sin φ_k), three components at 0.1–0.6 Hz with a total peak-to-peak of about `amplitude`
  (m); w(0) = 0.
"""

from __future__ import annotations

import numpy as np

from testkit.effects.rig import Trajectory


def hold(x: float) -> Trajectory:
    def trajectory(_t: float) -> tuple[float, float]:
        return x, 0.0

    return trajectory


def flick(t0: float, t1: float, x1: float, v1: float) -> Trajectory:
    duration = t1 - t0

    def trajectory(t: float) -> tuple[float, float]:
        s = min(max((t - t0) / duration, 0.0), 1.0)
        # Hermite basis: h01 = 3s² - 2s³ carries x1, h11 = s³ - s² carries v1·duration
        x = (3 * s * s - 2 * s ** 3) * x1 + (s ** 3 - s * s) * v1 * duration
        v = ((6 * s - 6 * s * s) * x1 + (3 * s * s - 2 * s) * v1 * duration) / duration
        return float(x), float(v)

    return trajectory


def wander(rng: np.random.Generator, amplitude: float) -> Trajectory:
    freq = rng.uniform(0.1, 0.6, 3)
    phase = rng.uniform(0.0, 2 * np.pi, 3)
    weight = rng.dirichlet(np.ones(3))
    amp = 0.5 * amplitude * weight
    omega, start = 2 * np.pi * freq, np.sin(phase)
    speed = amp * 2 * np.pi * freq

    def trajectory(t: float) -> tuple[float, float]:    # at every integrator stage: few array calls
        arg = omega * t + phase
        return float((amp * (np.sin(arg) - start)).sum()), float((speed * np.cos(arg)).sum())

    return trajectory
