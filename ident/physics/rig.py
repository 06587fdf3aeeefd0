"""The simulated rig's stepper: the carts of `ident.physics.free` while they are free, and
prescribed paths while a hand holds one.

Chain `wall -k1- m1 -k2- m2 -k3- wall`, positions `x1`, `x2` measured from each cart's
static rest (m), viscous dampers `c1`, `c2` to ground, dry friction `fc1`, `fc2` (N):

    m1 x1'' = -k1 s(x1) + k2 s(x2 - x1) - c1 x1' + f1
    m2 x2'' = -k2 s(x2 - x1) - k3 s(x2)   - c2 x2' + f2,     s(e) = e + cubic e^3

`carts=1` is the same chain with cart 2 clamped at 0 (so `k2` goes to the wall).

Free carts (no path; with `carts=1` cart 2 is clamped) are stepped by the diagnosis' own
simulator (`ident.physics.free`: exact linear part, mid-step cubic springs, Coulomb friction
with stick located inside a step), so the sim rig and the fitter share one physics. While a
hand holds a cart, one of two steppers per step `dt` runs:

- without dry friction: classical RK4 on the free carts (4th order; at the default 2 kHz
  the free response matches the closed form to well under a micrometre);
- with dry friction (`fc1` or `fc2` > 0): symplectic Euler with the friction applied as a
  velocity projection (Moreau time stepping), which gives an exact stick condition:

      v* = v + dt (F_spring + F_viscous) / m
      v+ = 0                          if |v*| <= dt fc / m    (the static force suffices)
      v+ = v* - sign(v*) dt fc / m    otherwise               (kinetic friction)
      x+ = x + dt v+

  It is first order (positions lag the exact motion by about 0.7 dt), so the rig runs
  it with 10 times more steps (`FRICTION_REFINE`).

A cart held by a hand or pinned follows a prescribed path instead: its position is set
(at every RK4 stage time), its velocity is a backward difference of that path.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ident.physics.free import NonlinearTerms, StepMaps, run_maps, step_maps

PositionPath = Callable[[float], float]
FRICTION_REFINE = 10


@dataclass(frozen=True, slots=True)
class ChainParams:
    """Masses (kg), springs (N/m), dampers (N s/m), dry friction (N), cubic (1/m^2)."""

    carts: int
    m1: float
    m2: float
    k1: float
    k2: float
    k3: float
    c1: float
    c2: float
    fc1: float
    fc2: float
    cubic: float


@dataclass(slots=True)
class ChainState:
    """Positions (m) and velocities (m/s) of both carts, time (s)."""

    t: float = 0.0
    x1: float = 0.0
    v1: float = 0.0
    x2: float = 0.0
    v2: float = 0.0


def _spring(k: float, e: float, cubic: float) -> float:
    return k * (e + cubic * e * e * e)


def _project(v_star: float, impulse: float) -> float:
    """Dry friction as a velocity projection: stick when the impulse can stop the cart."""
    if impulse == 0.0:
        return v_star
    if -impulse <= v_star <= impulse:
        return 0.0
    return v_star - impulse if v_star > 0.0 else v_star + impulse


def advance(p: ChainParams, s: ChainState, dt: float, steps: int,
            path1: PositionPath | None, path2: PositionPath | None) -> None:
    """Advance `s` in place by `steps` steps of `dt`; a cart with a path follows it.

    Free carts go through `ident.physics.free`; with a held cart and dry friction each step
    is split in `FRICTION_REFINE` Moreau steps.
    """
    if path1 is None and (p.carts == 1 or path2 is None):
        _free(p, s, dt, steps)
    elif p.fc1 == 0.0 and p.fc2 == 0.0:
        for _ in range(steps):
            _rk4_step(p, s, dt, path1, path2)
    else:
        _moreau(p, s, dt / FRICTION_REFINE, steps * FRICTION_REFINE, path1, path2)


@functools.lru_cache(maxsize=8)
def _maps(p: ChainParams, dt: float) -> StepMaps:
    """The free carts' step maps (mass-normalised chain, friction, cubic springs) on `dt`."""
    if p.carts == 1:   # cart 2 clamped at 0: k1 and k2 both tie cart 1 to the wall
        k = p.k1 + p.k2
        lin = np.array([[np.sqrt(k / p.m1), p.c1 / (2.0 * np.sqrt(k * p.m1))]])
        friction = np.array([[p.fc1 / p.m1]])
    else:
        lin = np.array([[p.k1 / p.m1, p.k2 / p.m1, p.k2 / p.m2, p.k3 / p.m2, p.c1 / p.m1, p.c2 / p.m2]])
        friction = np.array([[p.fc1 / p.m1, p.fc2 / p.m2]])
    terms = NonlinearTerms(friction_m_s2=friction, cubic_per_m2=np.array([p.cubic]))
    return step_maps(lin, dt, p.carts, terms)


def _free(p: ChainParams, s: ChainState, dt: float, steps: int) -> None:
    """`steps` steps of `dt` of the free carts (positions from the static rest, so rest = 0)."""
    maps = _maps(p, dt)
    z0 = np.array([[s.x1, s.v1]]) if p.carts == 1 else np.array([[s.x1, s.x2, s.v1, s.v2]])
    _, end = run_maps(maps, z0, steps + 1)
    if p.carts == 1:
        s.x1, s.v1 = float(end[0, 0]), float(end[0, 1])
    else:
        s.x1, s.x2, s.v1, s.v2 = (float(v) for v in end[0])
    s.t += steps * dt


def _accel(p: ChainParams, x1: float, v1: float, x2: float, v2: float) -> tuple[float, float]:
    """Accelerations (m/s^2) from springs and viscous dampers (no dry friction)."""
    f12 = _spring(p.k2, x2 - x1, p.cubic)
    a1 = (-_spring(p.k1, x1, p.cubic) + f12 - p.c1 * v1) / p.m1
    a2 = (-f12 - _spring(p.k3, x2, p.cubic) - p.c2 * v2) / p.m2
    return a1, a2


def _rk4_step(p: ChainParams, s: ChainState, dt: float,
              path1: PositionPath | None, path2: PositionPath | None) -> None:
    """One RK4 step; held carts take their path's position at every stage time."""
    h, t = 0.5 * dt, s.t
    x1, v1, x2, v2 = s.x1, s.v1, s.x2, s.v2
    clamp2 = p.carts == 1
    held1 = (path1(t + h), path1(t + dt)) if path1 is not None else None
    held2 = (0.0, 0.0) if clamp2 else (path2(t + h), path2(t + dt)) if path2 is not None else None
    a1, a2 = _accel(p, x1, v1, x2, v2)
    y1 = held1[0] if held1 else x1 + h * v1
    y2 = held2[0] if held2 else x2 + h * v2
    w1, w2 = v1 + h * a1, v2 + h * a2
    b1, b2 = _accel(p, y1, w1, y2, w2)
    z1 = held1[0] if held1 else x1 + h * w1
    z2 = held2[0] if held2 else x2 + h * w2
    u1, u2 = v1 + h * b1, v2 + h * b2
    c1, c2 = _accel(p, z1, u1, z2, u2)
    e1 = held1[1] if held1 else x1 + dt * u1
    e2 = held2[1] if held2 else x2 + dt * u2
    r1, r2 = v1 + dt * c1, v2 + dt * c2
    d1, d2 = _accel(p, e1, r1, e2, r2)
    sixth = dt / 6.0
    # a held cart's velocity at t + dt: second-order backward difference of its path, so
    # a cart let go while moving leaves with the hand's speed
    if held1:
        s.x1, s.v1 = held1[1], (3.0 * held1[1] - 4.0 * held1[0] + x1) / dt
    else:
        s.x1, s.v1 = x1 + sixth * (v1 + 2 * w1 + 2 * u1 + r1), v1 + sixth * (a1 + 2 * b1 + 2 * c1 + d1)
    if held2:
        s.x2, s.v2 = held2[1], (3.0 * held2[1] - 4.0 * held2[0] + x2) / dt
    else:
        s.x2, s.v2 = x2 + sixth * (v2 + 2 * w2 + 2 * u2 + r2), v2 + sixth * (a2 + 2 * b2 + 2 * c2 + d2)
    s.t = t + dt


def _moreau(p: ChainParams, s: ChainState, dt: float, steps: int,
            path1: PositionPath | None, path2: PositionPath | None) -> None:
    """Symplectic Euler with dry friction as a velocity projection (module docstring)."""
    imp1 = dt * p.fc1 / p.m1
    imp2 = dt * p.fc2 / p.m2
    clamp2 = p.carts == 1
    for _ in range(steps):
        t = s.t + dt
        x1, x2 = s.x1, s.x2
        f12 = _spring(p.k2, x2 - x1, p.cubic)
        if path1 is None:
            a1 = (-_spring(p.k1, x1, p.cubic) + f12 - p.c1 * s.v1) / p.m1
            s.v1 = _project(s.v1 + dt * a1, imp1)
            s.x1 = x1 + dt * s.v1
        else:
            s.x1 = path1(t)
            s.v1 = (s.x1 - x1) / dt
        if clamp2:
            pass
        elif path2 is None:
            a2 = (-f12 - _spring(p.k3, x2, p.cubic) - p.c2 * s.v2) / p.m2
            s.v2 = _project(s.v2 + dt * a2, imp2)
            s.x2 = x2 + dt * s.v2
        else:
            s.x2 = path2(t)
            s.v2 = (s.x2 - x2) / dt
        s.t = t
