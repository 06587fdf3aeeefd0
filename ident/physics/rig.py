"""The simulated rig's stepper: the carts of `ident.physics.free`, free or held by a hand.

Chain `wall -k1- m1 -k2- m2 -k3- wall`, positions `x1`, `x2` measured from each cart's
static rest (m), viscous dampers `c1`, `c2` to ground, dry friction `fc1`, `fc2` (N):

    m1 x1'' = -k1 s(x1) + k2 s(x2 - x1) - c1 x1' + f1
    m2 x2'' = -k2 s(x2 - x1) - k3 s(x2)   - c2 x2' + f2,     s(e) = e + cubic e^3

`carts=1` is the same chain with cart 2 clamped at 0 (so `k2` goes to the wall).

Every step goes through the fitter's simulator (`ident.physics.free`: exact linear part,
mid-step cubic springs, Coulomb friction with stick located inside a step), so the sim rig
and the fitter share one physics:

- free carts: the chain as it is;
- a hand holding one of two carts is a position constraint: the held cart follows the
  hand's path p(t). It is simulated as a cart of infinite mass (its rows of the mass-
  normalised stiffness and damping are zero, no friction) driven by the path's
  acceleration p''(t) as an input, from p and p' at the start; the other cart feels it
  through the coupling spring, cubic part included, exactly as in the chain. p'' comes
  from second differences of the path on half steps (error O(dt²) times the path's fourth
  derivative), and the held cart's end state is set to the path's (its position, and a
  second-order backward difference for p'), so it cannot drift from the hand;
- every moving cart held: the positions are the paths, nothing to integrate.

A cart let go leaves with the hand's speed (that backward difference).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ident.physics.free import NonlinearTerms, StepMaps, run_maps, step_maps

PositionPath = Callable[[float], float]
FloatArray = NDArray[np.float64]


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


def advance(p: ChainParams, s: ChainState, dt: float, steps: int,
            path1: PositionPath | None, path2: PositionPath | None) -> None:
    """Advance `s` in place by `steps` steps of `dt`; a cart with a path follows it."""
    if p.carts == 1:
        path2 = None
    if path1 is None and path2 is None:
        _free(p, s, dt, steps)
    elif p.carts == 1 or (path1 is not None and path2 is not None):
        _follow(s, dt, steps, path1, path2)
    elif path1 is not None:
        _one_held(p, s, dt, steps, 0, path1)
    elif path2 is not None:
        _one_held(p, s, dt, steps, 1, path2)


@functools.lru_cache(maxsize=16)
def _maps(p: ChainParams, dt: float, held: int | None = None) -> StepMaps:
    """The carts' step maps (mass-normalised chain, friction, cubic springs) on `dt`; with
    `held` (0 or 1) that cart has infinite mass and takes its acceleration as input 0."""
    if p.carts == 1:   # cart 2 clamped at 0: k1 and k2 both tie cart 1 to the wall
        k = p.k1 + p.k2
        lin = np.array([[np.sqrt(k / p.m1), p.c1 / (2.0 * np.sqrt(k * p.m1))]])
        friction = np.array([[p.fc1 / p.m1]])
        return step_maps(lin, dt, 1, NonlinearTerms(friction_m_s2=friction, cubic_per_m2=np.array([p.cubic])))
    # per cart: (spring to its wall, coupling spring, damper, dry friction) per mass
    rows = np.array([[p.k1 / p.m1, p.k2 / p.m1, p.c1 / p.m1, p.fc1 / p.m1],
                     [p.k3 / p.m2, p.k2 / p.m2, p.c2 / p.m2, p.fc2 / p.m2]])
    gain = None
    if held is not None:
        rows[held] = 0.0                      # m → ∞: only the input moves the held cart
        gain = np.zeros((1, 2, 1))
        gain[0, held, 0] = 1.0
    (a1, b1, g1, f1), (a2, b2, g2, f2) = rows
    lin = np.array([[a1, b1, b2, a2, g1, g2]])
    terms = NonlinearTerms(friction_m_s2=np.array([[f1, f2]]), cubic_per_m2=np.array([p.cubic]),
                           input_gain=gain)
    return step_maps(lin, dt, 2, terms, n_inputs=0 if held is None else 1)


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


def _half_steps(path: PositionPath, t0: float, dt: float, steps: int) -> FloatArray:
    """The path at t0 + j·dt/2, j = 0 … 2·steps, shape (2·steps + 1,)."""
    return np.array([path(t0 + 0.5 * dt * j) for j in range(2 * steps + 1)], dtype=np.float64)


def _end_velocity(q: FloatArray, dt: float) -> float:
    """p' at the last half-step sample: second-order backward difference (spacing dt/2)."""
    return float((3.0 * q[-1] - 4.0 * q[-2] + q[-3]) / dt)


def _follow(s: ChainState, dt: float, steps: int, path1: PositionPath | None,
            path2: PositionPath | None) -> None:
    """Every moving cart is held: the state is the paths' (cart 2 of `carts=1` stays 0)."""
    last = s.t + (steps - 1) * dt
    if path1 is not None:
        q = _half_steps(path1, last, dt, 1)
        s.x1, s.v1 = float(q[-1]), _end_velocity(q, dt)
    if path2 is not None:
        q = _half_steps(path2, last, dt, 1)
        s.x2, s.v2 = float(q[-1]), _end_velocity(q, dt)
    s.t += steps * dt


def _path_acceleration(q: FloatArray, dt: float) -> FloatArray:
    """p'' (steps + 1,) at t0 + k·dt from the half-step samples `q` (2·steps + 1,): centred
    second differences; at the two ends the one-sided ones (half a step inside)."""
    h2 = (0.5 * dt) ** 2
    accel = np.empty((q.size + 1) // 2)
    accel[1:-1] = (q[3:-1:2] - 2.0 * q[2:-2:2] + q[1:-3:2]) / h2
    accel[0] = (q[2] - 2.0 * q[1] + q[0]) / h2
    accel[-1] = (q[-1] - 2.0 * q[-2] + q[-3]) / h2
    return accel


def _one_held(p: ChainParams, s: ChainState, dt: float, steps: int, held: int, path: PositionPath) -> None:
    """Two carts, cart `held` (0 or 1) on the hand's path, the other free (module docstring)."""
    q = _half_steps(path, s.t, dt, steps)
    x, v = [s.x1, s.x2], [s.v1, s.v2]
    x[held], v[held] = float(q[0]), float((-3.0 * q[0] + 4.0 * q[1] - q[2]) / dt)
    z0 = np.array([[x[0], x[1], v[0], v[1]]])
    _, end = run_maps(_maps(p, dt, held), z0, steps + 1, _path_acceleration(q, dt)[:, None])
    x, v = [float(end[0, 0]), float(end[0, 1])], [float(end[0, 2]), float(end[0, 3])]
    x[held], v[held] = float(q[-1]), _end_velocity(q, dt)
    s.x1, s.x2 = x
    s.v1, s.v2 = v
    s.t += steps * dt
