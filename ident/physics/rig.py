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
- every moving cart held: the positions are the paths, nothing to integrate;
- a hand that grips a cart (`Grip`) is a force, not a constraint: a stiff, damped spring
  (per unit mass) towards the hand's path, `a_hand = ω_g² (p - x) + 2 ζ_g ω_g (p' - v)`. Its
  linear part joins the cart's own (`ω_g²` to the spring to its wall, `2 ζ_g ω_g` to its
  damper) and `ω_g² p + 2 ζ_g ω_g p'` is an input (p' from centred differences on half
  steps). The cart keeps its friction and inertia, so the hand's force, not the cart's
  position, is what ends when the hand lets go (the real hand releases of the shared records
  show that force ending within ~10 ms). With a cubic spring (`cubic` ≠ 0) the grip's spring
  takes the cubic part of the cart's wall spring too (only while gripped).

A cart let go from a path leaves with the hand's speed (that backward difference); from a
grip with the speed it has.
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
class Grip:
    """A hand's grip on a cart: spring `omega` (rad/s) and damping ratio `zeta` per unit mass
    towards `path` (m): `a_hand = omega² (path(t) - x) + 2 zeta omega (path'(t) - v)` (m/s²)."""

    path: PositionPath
    omega: float
    zeta: float

    def __call__(self, t: float) -> float:
        return self.path(t)


Hand = PositionPath | Grip


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
            path1: Hand | None, path2: Hand | None) -> None:
    """Advance `s` in place by `steps` steps of `dt`; a cart with a path follows it, a cart
    with a `Grip` is pulled towards its path."""
    if p.carts == 1:
        path2 = None
    grips = tuple((c, h) for c, h in ((0, path1), (1, path2)) if isinstance(h, Grip))
    held = [(c, h) for c, h in ((0, path1), (1, path2)) if h is not None and not isinstance(h, Grip)]
    if p.carts == 1 and held:
        _follow(s, dt, steps, held[0][1], None)
    elif len(held) == 2:
        _follow(s, dt, steps, path1, path2)
    elif held:
        _driven(p, s, dt, steps, held[0], grips)
    elif grips:
        _driven(p, s, dt, steps, None, grips)
    else:
        _free(p, s, dt, steps)


@functools.lru_cache(maxsize=16)
def _maps(p: ChainParams, dt: float, held: int | None = None,
          grips: tuple[tuple[int, float, float], ...] = ()) -> StepMaps:
    """The carts' step maps (mass-normalised chain, friction, cubic springs) on `dt`; with
    `held` (0 or 1) that cart has infinite mass and takes its acceleration as input 0; each
    grip (cart, ω_g, ζ_g) adds its spring and damper to the cart and takes the next input."""
    n_in = (held is not None) + len(grips)
    gain = np.zeros((1, p.carts, n_in)) if n_in else None
    if p.carts == 1:   # cart 2 clamped at 0: k1 and k2 both tie cart 1 to the wall
        k, c = (p.k1 + p.k2) / p.m1, p.c1 / p.m1
        for _, omega, zeta in grips:
            k, c = k + omega ** 2, c + 2.0 * zeta * omega
        if gain is not None:
            gain[0, 0, 0] = 1.0
        lin = np.array([[np.sqrt(k), c / (2.0 * np.sqrt(k))]])
        friction = np.array([[p.fc1 / p.m1]])
        return step_maps(lin, dt, 1, NonlinearTerms(friction_m_s2=friction, cubic_per_m2=np.array([p.cubic]),
                                                    input_gain=gain), n_inputs=n_in)
    # per cart: (spring to its wall, coupling spring, damper, dry friction) per mass
    rows = np.array([[p.k1 / p.m1, p.k2 / p.m1, p.c1 / p.m1, p.fc1 / p.m1],
                     [p.k3 / p.m2, p.k2 / p.m2, p.c2 / p.m2, p.fc2 / p.m2]])
    if held is not None:
        rows[held] = 0.0                      # m → ∞: only the input moves the held cart
        assert gain is not None
        gain[0, held, 0] = 1.0
    for q, (cart, omega, zeta) in enumerate(grips, start=int(held is not None)):
        rows[cart, 0] += omega ** 2
        rows[cart, 2] += 2.0 * zeta * omega
        assert gain is not None
        gain[0, cart, q] = 1.0
    (a1, b1, g1, f1), (a2, b2, g2, f2) = rows
    lin = np.array([[a1, b1, b2, a2, g1, g2]])
    terms = NonlinearTerms(friction_m_s2=np.array([[f1, f2]]), cubic_per_m2=np.array([p.cubic]),
                           input_gain=gain)
    return step_maps(lin, dt, 2, terms, n_inputs=n_in)


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


def _path_velocity(q: FloatArray, dt: float) -> FloatArray:
    """p' (steps + 1,) at t0 + k·dt from the half-step samples `q` (2·steps + 1,): centred
    differences over ±dt/2; at the two ends second-order one-sided ones."""
    vel = np.empty((q.size + 1) // 2)
    vel[1:-1] = (q[3::2] - q[1:-2:2]) / dt
    vel[0] = (-3.0 * q[0] + 4.0 * q[1] - q[2]) / dt
    vel[-1] = (3.0 * q[-1] - 4.0 * q[-2] + q[-3]) / dt
    return vel


def _driven(p: ChainParams, s: ChainState, dt: float, steps: int, held: tuple[int, Hand] | None,
            grips: tuple[tuple[int, Grip], ...]) -> None:
    """Carts held on a path (`held`: cart 0 or 1 and its path) and/or gripped (module docstring)."""
    x, v = [s.x1, s.x2], [s.v1, s.v2]
    u = np.empty((steps + 1, (held is not None) + len(grips)))
    q_held = None
    if held is not None:
        q_held = _half_steps(held[1], s.t, dt, steps)
        x[held[0]], v[held[0]] = float(q_held[0]), float((-3.0 * q_held[0] + 4.0 * q_held[1] - q_held[2]) / dt)
        u[:, 0] = _path_acceleration(q_held, dt)
    for j, (_, grip) in enumerate(grips, start=int(held is not None)):
        q = _half_steps(grip.path, s.t, dt, steps)
        u[:, j] = grip.omega ** 2 * q[::2] + 2.0 * grip.zeta * grip.omega * _path_velocity(q, dt)
    key = tuple((c, g.omega, g.zeta) for c, g in grips)
    maps = _maps(p, dt, None if held is None else held[0], key)
    z0 = np.array([[x[0], v[0]]]) if p.carts == 1 else np.array([[x[0], x[1], v[0], v[1]]])
    _, end = run_maps(maps, z0, steps + 1, u)
    if p.carts == 1:
        s.x1, s.v1 = float(end[0, 0]), float(end[0, 1])
        s.t += steps * dt
        return
    x, v = [float(end[0, 0]), float(end[0, 1])], [float(end[0, 2]), float(end[0, 3])]
    if held is not None and q_held is not None:
        x[held[0]], v[held[0]] = float(q_held[-1]), _end_velocity(q_held, dt)
    s.x1, s.x2 = x
    s.v1, s.v2 = v
    s.t += steps * dt
