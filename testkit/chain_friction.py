"""Two carts on springs with dry friction, integrated event by event (tests' reference physics).

Written from the physics, not from `ident.physics`: the chain's ODE integrated by
`scipy.integrate.solve_ivp` (DOP853, tight tolerances) from one friction event to the next,
each cart sliding (kinetic friction against its velocity) or stuck (held while |spring pull| ≤
its static level), a stop located where a cart's velocity passes zero and a breakaway where a
stuck cart's pull reaches its static level. `two_free_carts` draws a lab's two-cart release
from it (both carts free and read).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.integrate import solve_ivp

FloatArray = NDArray[np.float64]


#: Friction events one integration locates at most (a two-cart release has tens).
MAX_EVENTS = 2000


class EventStorm(RuntimeError):
    """A stuck cart chattered in and out of sticking faster than events can be located (its
    pull hovering at the static level while the other cart moves): no motion to compare."""


def chain_with_dry_friction(lin: FloatArray, z0: FloatArray, fk: FloatArray, fs: FloatArray,
                            tau: FloatArray) -> FloatArray:
    """Positions (N, 2) at `tau` of the chain x'' = -Kt x - Ct x' - friction, from `z0` = (x1,
    x2, v1, v2); `lin` = (k1/m1, k2/m1, k2/m2, k3/m2, c1/m1, c2/m2), friction per mass."""
    a1, b1, b2, a2, g1, g2 = lin
    kt = np.array([[a1 + b1, -b1], [-b2, b2 + a2]])
    damp = np.array([g1, g2])

    def pull(x: FloatArray) -> FloatArray:
        return -(kt @ x)

    def direction(i: int, z: FloatArray) -> float:
        """+1/-1 sliding, 0 stuck, for a cart whose velocity is zero at state z."""
        p = pull(z[:2])[i]
        return 0.0 if abs(p) <= fs[i] else float(np.sign(p))

    z = np.asarray(z0, dtype=float).copy()
    mode = np.array([np.sign(z[2 + i]) if z[2 + i] != 0.0 else direction(i, z) for i in range(2)])
    out = np.empty((tau.size, 2))
    t, k = float(tau[0]), 0
    for _ in range(MAX_EVENTS):   # a two-cart flick has tens
        def rhs(_t: float, s: FloatArray, mode: FloatArray = mode) -> FloatArray:
            acc = pull(s[:2]) - damp * s[2:] - fk * mode
            acc[mode == 0] = 0.0
            vel = s[2:].copy()
            vel[mode == 0] = 0.0
            return np.concatenate([vel, acc])

        events: list[Callable[..., float]] = []
        for i in range(2):
            if mode[i] != 0:
                def stops(_t: float, s: FloatArray, i: int = i, m: float = mode[i]) -> float:
                    return float(m * s[2 + i])
                stops.terminal, stops.direction = True, -1   # type: ignore[attr-defined]
                events.append(stops)
            else:
                def breaks(_t: float, s: FloatArray, i: int = i) -> float:
                    return float(abs(pull(s[:2])[i]) - fs[i])
                breaks.terminal, breaks.direction = True, 1   # type: ignore[attr-defined]
                events.append(breaks)
        sol = solve_ivp(rhs, (t, float(tau[-1])), z, method="DOP853", rtol=1e-11, atol=1e-13,
                        events=events, dense_output=True)
        end = float(sol.t[-1])
        upto = int(np.searchsorted(tau, end, side="right")) if sol.status == 1 else tau.size
        if upto > k:
            out[k:upto] = sol.sol(tau[k:upto])[:2].T
        k, t, z = upto, end, sol.y[:, -1].copy()
        if sol.status != 1:
            return out
        for i in range(2):
            hit = sol.t_events[i].size > 0
            if hit and mode[i] != 0:   # a stop: stuck, or on the other way
                z[2 + i] = 0.0
                mode[i] = direction(i, z)
            elif hit:                  # a breakaway
                mode[i] = np.sign(pull(z[:2])[i])
    raise EventStorm(f"more than {MAX_EVENTS} friction events by t = {t:.6f} s")


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
    (0.05-0.5 of a count); 8 s after the let-go. Raises `EventStorm` for the few draws whose
    stuck cart chatters at its breakaway level."""
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
    moved = np.flatnonzero(np.max(np.abs(np.diff(x, axis=0)), axis=1) > 1e-7)
    return TwoCartRun(t, y - y[0], release, float(t[moved[-1] + 1]) if moved.size else release)
