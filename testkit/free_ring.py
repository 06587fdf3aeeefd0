"""Exact free responses of one spring cart, written from the physics (independent of `ident`).

x'' + 2ζ wn x' + wn² (x - rest) [+ f sign(x')] = 0 from x(0) = x0, x'(0) = v0: the damped
ring in closed form, and with dry friction (static = kinetic f, m/s²) its piecewise-exact
solution, each half-cycle a damped ring about the rest shifted by f/wn² against the motion,
the cart sticking at a stop where the spring's pull is at most f. τ (s), positions (m).
"""

from __future__ import annotations

import numpy as np

__all__ = ["coulomb_ring", "ring"]


def ring(tau: np.ndarray, x0: float, v0: float, rest: float, wn: float, zeta: float) -> np.ndarray:
    """x(τ) of x'' + 2ζwn x' + wn²(x - rest) = 0 from x(0) = x0, x'(0) = v0 (τ may be < 0)."""
    sigma, wd = zeta * wn, wn * np.sqrt(1.0 - zeta**2)
    a = x0 - rest
    b = (v0 + sigma * a) / wd
    return rest + np.exp(-sigma * tau) * (a * np.cos(wd * tau) + b * np.sin(wd * tau))


def coulomb_ring(tau: np.ndarray, x0: float, v0: float, rest: float, wn: float, zeta: float,
                 friction: float) -> np.ndarray:
    """x(τ ≥ 0) of x'' + 2ζwn x' + wn²(x - rest) + f sign(x') = 0 (static = kinetic f), exactly:
    between stops the cart rings about rest - sign(x') f/wn²; at a stop (x' = 0) it sticks when
    the spring's pull is at most f."""
    sigma, wd = zeta * wn, wn * np.sqrt(1.0 - zeta**2)
    x = np.empty(tau.size)
    start, position, velocity = 0.0, x0, v0
    direction = np.sign(v0) if v0 != 0.0 else np.sign(rest - x0)
    while True:
        centre = rest - direction * friction / wn**2
        a = position - centre
        b = (velocity + sigma * a) / wd
        p, q = wd * b - sigma * a, wd * a + sigma * b          # x' = e^{-στ}(p cos - q sin)
        theta = (np.pi / 2 - np.arctan2(q, p)) % np.pi
        theta = theta if theta > 1e-12 else np.pi
        end = start + theta / wd
        inside = (tau >= start) & (tau < end)
        s = tau[inside] - start
        x[inside] = centre + np.exp(-sigma * s) * (a * np.cos(wd * s) + b * np.sin(wd * s))
        position = centre + np.exp(-sigma * theta / wd) * (a * np.cos(theta) + b * np.sin(theta))
        velocity, start = 0.0, end
        if abs(wn**2 * (position - rest)) <= friction or start > tau[-1]:
            break
        direction = np.sign(rest - position)
    x[tau >= start] = position
    return x
