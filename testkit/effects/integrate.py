"""Event-driven integration of a `Rig`: smooth motion by DOP853, stick and slip by events.

Each mass is in one of four modes: prescribed (the hand moves it: its position and velocity
are given functions of time), free of dry friction, slipping (+1 or -1: friction -f sign v),
or stuck (v = 0 held by static friction). Between mode changes the equations of
`testkit.effects.rig` are smooth and solved by scipy's DOP853 at rtol 1e-10; the integration
stops exactly at

- a slipping mass's velocity reaching zero: it sticks if the rest of its force per mass is
  within the static level s, otherwise it slips back the other way;
- a stuck mass's force per mass leaving [-s, s]: it breaks away in the direction of the force.

Nothing here imports `ident`: this is the independent reference the diagnosis is judged by.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.integrate import solve_ivp

from testkit.effects.rig import FloatArray, Rig, Trajectory

RTOL, ATOL = 1e-10, 1e-13
MAX_EVENTS = 20000
FREE, STUCK, PRESCRIBED = 2, 0, 3
BoolArray = NDArray[np.bool_]
Derivative = Callable[[float, FloatArray], FloatArray]
Event = Callable[..., float]


@dataclass(frozen=True)
class Phase:
    """From `start` to `end` (s), the masses in `prescribed` follow the hand."""

    start: float
    end: float
    prescribed: Mapping[int, Trajectory] = field(default_factory=dict)


def simulate(rig: Rig, phases: list[Phase], t_out: FloatArray, z0: FloatArray) -> tuple[FloatArray, list[FloatArray]]:
    """Positions (N, n) at `t_out` (within the phases) and the state z = (x, v) at each phase's end.

    `z0` (2n,) is the state at the first phase's start; prescribed masses take their
    trajectory's value wherever prescribed.
    """
    out = np.full((t_out.size, rig.n), np.nan)
    state = np.asarray(z0, dtype=np.float64).copy()
    ends = []
    for k, phase in enumerate(phases):
        last = k == len(phases) - 1
        inside = (t_out >= phase.start) & ((t_out <= phase.end) if last else (t_out < phase.end))
        state = _phase(rig, phase, state, t_out, inside, out)
        ends.append(state.copy())
    return out, ends


def _apply(phase: Phase, t: float, z: FloatArray, n: int) -> FloatArray:
    z = z.copy()
    for i, trajectory in phase.prescribed.items():
        z[i], z[n + i] = trajectory(t)
    return z


def _initial_modes(rig: Rig, phase: Phase, z: FloatArray) -> FloatArray:
    n = rig.n
    a = rig.accel(phase.start, z[:n], z[n:])
    mode = np.empty(n)
    for i in range(n):
        if i in phase.prescribed:
            mode[i] = PRESCRIBED
        elif rig.static[i] == 0.0:
            mode[i] = FREE
        elif z[n + i] != 0.0:
            mode[i] = np.sign(z[n + i])
        else:
            mode[i] = STUCK if abs(a[i]) <= rig.static[i] else np.sign(a[i])
    return mode


def _rhs(rig: Rig, phase: Phase, mode: FloatArray) -> Derivative:
    n = rig.n
    slipping = np.abs(mode) == 1
    friction = rig.kinetic[slipping] * mode[slipping]
    still = (mode == STUCK) | (mode == PRESCRIBED)

    def rhs(t: float, s: FloatArray) -> FloatArray:
        z = _apply(phase, t, s, n)
        a = rig.accel(t, z[:n], z[n:])
        a[slipping] -= friction
        v = z[n:].copy()
        a[still] = 0.0
        v[still] = 0.0
        return np.concatenate([v, a])

    return rhs


def _events(rig: Rig, phase: Phase, mode: FloatArray) -> tuple[list[Event], list[tuple[int, float]]]:
    n = rig.n
    events: list[Event] = []
    owners: list[tuple[int, float]] = []
    for i in range(n):
        if abs(mode[i]) == 1:
            # fires just past the velocity zero (a zero at the segment's start is not a crossing)
            def stop(_t: float, s: FloatArray, i: int = i, m: float = float(mode[i])) -> float:
                return float(s[n + i] * m + 1e-12)

            stop.terminal, stop.direction = True, -1  # type: ignore[attr-defined]
            events.append(stop)
            owners.append((i, 0.0))
        elif mode[i] == STUCK:
            for sign in (1.0, -1.0):
                def breakaway(t: float, s: FloatArray, i: int = i, sign: float = sign) -> float:
                    z = _apply(phase, t, s, n)
                    return float(sign * rig.accel(t, z[:n], z[n:])[i] - rig.static[i])

                breakaway.terminal, breakaway.direction = True, 1  # type: ignore[attr-defined]
                events.append(breakaway)
                owners.append((i, sign))
    return events, owners


def _phase(rig: Rig, phase: Phase, state: FloatArray, t_out: FloatArray, inside: BoolArray,
           out: FloatArray) -> FloatArray:
    n = rig.n
    z = _apply(phase, phase.start, state, n)
    mode = _initial_modes(rig, phase, z)
    z[n:][mode == STUCK] = 0.0
    t0 = phase.start
    for _ in range(MAX_EVENTS):
        events, owners = _events(rig, phase, mode)
        todo = inside & (t_out >= t0)
        if t0 >= phase.end or (np.all((mode == STUCK) | (mode == PRESCRIBED)) and not _moving_hand(rig, phase)):
            _fill(phase, t_out, todo, _constant(z), out, n)
            return _apply(phase, phase.end, z, n)
        sol = solve_ivp(_rhs(rig, phase, mode), (t0, phase.end), z, method="DOP853", rtol=RTOL,
                        atol=ATOL, events=events or None, dense_output=True)
        if not sol.success:
            raise RuntimeError(f"integration failed at t = {t0:.6g} s: {sol.message}")
        t1 = float(sol.t[-1])
        seg = todo & (t_out <= t1)
        _fill(phase, t_out, seg, sol.sol, out, n)
        z = _apply(phase, t1, np.asarray(sol.y[:, -1]), n)
        if sol.status == 0:
            return z
        fired = [k for k, te in enumerate(sol.t_events) if te.size]
        i, sign = owners[fired[0]]
        if sign == 0.0:
            z[n + i] = 0.0
            a = rig.accel(t1, z[:n], z[n:])[i]
            mode[i] = STUCK if abs(a) <= rig.static[i] else np.sign(a)
        else:
            mode[i] = sign
        t0 = t1
    raise RuntimeError(f"more than {MAX_EVENTS} stick/slip events")


def _moving_hand(rig: Rig, phase: Phase) -> bool:
    """Whether something still drives the stuck masses: a hand spring or a prescribed motion."""
    return bool(rig.hands) or bool(phase.prescribed)


def _constant(z: FloatArray) -> Callable[[FloatArray], FloatArray]:
    """A dense output that stays at state z (every mass stuck or held still)."""
    return lambda tt: np.tile(z[:, None], (1, np.size(tt)))


def _fill(phase: Phase, t_out: FloatArray, rows: BoolArray, dense: Callable[[FloatArray], Any],
          out: FloatArray, n: int) -> None:
    """Positions at the sample times `t_out[rows]` from a dense output of the states (2n, m)."""
    if not np.any(rows):
        return
    tt = t_out[rows]
    x = np.asarray(dense(tt), dtype=np.float64)[:n].T.reshape(tt.size, n)
    for i, trajectory in phase.prescribed.items():
        x[:, i] = [trajectory(float(s))[0] for s in tt]
    out[rows] = x
