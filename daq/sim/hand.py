"""The scripted hand: which cart is held, where, and when it lets go. Pure, seeded.

A case runs: `rest` (hands off, `rest_s`) -> `pull` (the hand grabs the pulled cart where
it is and moves it along a minimum-jerk path to `-pull_m` in `pull_s`; the other cart is
pinned at its rest, or for `both` held there by the other hand) -> `hold` (`hold_s`
scaled by `1 + U(-hold_jitter, hold_jitter)`; the student zeroes here) -> `release`
(the hand lets go: the cart leaves with the hand's velocity, tremor included; for
`both` both carts are let go at the same instant; a pin stays) -> `ring` (until every
free cart moves slower than `settle_mps` for `settle_hold_s`, or `ring_max_s`) -> next
case (a pin stays on until the next grab). An `idle` case removes pins and is hands off
for `idle_s`. A `handle` case is slow handling that must not look like a release: the
hand pulls cart 1 (cart 2 free) over `2 pull_s`, holds, brings it back to rest over
`2 pull_s` and lets go there (`letgo` event, no `release`).

A flick (`flick_mps` != 0): after the hold the hand accelerates the pulled cart uniformly
for `flick_s` and lets go while it moves at `flick_mps` (towards rest when positive), as
students often do; the `release` event is the instant the hand lets go.

Hand tremor: a sum of three sines (7-11 Hz, random phases) with RMS `tremor_m`, faded in
over 0.3 s after the grab. A pin has no tremor.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ident.physics.rig import PositionPath


@dataclass(frozen=True, slots=True)
class HandPath:
    """Minimum-jerk move from `x0` at `t0` to `x1` at `t0 + duration`, plus tremor."""

    t0: float
    x0: float
    x1: float
    duration: float
    tremor: tuple[tuple[float, float, float], ...] = ()   # (amplitude m, omega rad/s, phase)
    tremor_t0: float | None = None      # when the tremor started (a later move keeps it)

    def __call__(self, t: float) -> float:
        u = (t - self.t0) / self.duration
        if u <= 0.0:
            x = self.x0
        elif u >= 1.0:
            x = self.x1
        else:
            x = self.x0 + (self.x1 - self.x0) * u * u * u * (10.0 - 15.0 * u + 6.0 * u * u)
        return x + tremor_at(self.tremor, self.t0 if self.tremor_t0 is None else self.tremor_t0, t)


@dataclass(frozen=True, slots=True)
class FlickPath:
    """Constant acceleration from rest at `x0`, `t0`: `x = x0 + accel (t - t0)^2 / 2`, plus tremor."""

    t0: float
    x0: float
    accel: float
    tremor: tuple[tuple[float, float, float], ...] = ()
    tremor_t0: float = 0.0

    def __call__(self, t: float) -> float:
        tau = max(0.0, t - self.t0)
        x = self.x0 + 0.5 * self.accel * tau * tau
        return x + tremor_at(self.tremor, self.tremor_t0, t)


def tremor_at(tremor: tuple[tuple[float, float, float], ...], t0: float, t: float) -> float:
    """The hand's tremor (m) at `t`: its sines, faded in over 0.3 s from `t0`."""
    if not tremor:
        return 0.0
    fade = min(1.0, max(0.0, (t - t0) / 0.3))
    return fade * sum(a * math.sin(w * (t - t0) + ph) for a, w, ph in tremor)


def tremor_terms(rng: np.random.Generator, rms_m: float) -> tuple[tuple[float, float, float], ...]:
    """Three sines of 7-11 Hz whose sum has RMS `rms_m` (each amplitude rms * sqrt(2/3))."""
    if rms_m == 0.0:
        return ()
    amplitude = rms_m * math.sqrt(2.0 / 3.0)
    freqs = rng.uniform(7.0, 11.0, 3)
    phases = rng.uniform(0.0, 2.0 * math.pi, 3)
    return tuple((amplitude, 2.0 * math.pi * float(f), float(ph)) for f, ph in zip(freqs, phases))


@dataclass(frozen=True, slots=True)
class ScriptEvent:
    """Ground truth for tests: `kind` is case_start, grab, flick, release, letgo, settled."""

    kind: str
    case: str
    t_s: float
    case_index: int


@dataclass(frozen=True, slots=True)
class CaseTiming:
    rest_s: float
    pull_s: float
    hold_s: float
    hold_jitter: float
    pull_m: float
    tremor_m: float
    idle_s: float
    flick_mps: float = 0.0
    flick_s: float = 0.1


class Hand:
    """State machine over the case list; `update(t, x1, x2)` returns the current paths."""

    def __init__(self, cases: tuple[str, ...], timing: CaseTiming, rng: np.random.Generator,
                 carts: int) -> None:
        self.cases = cases
        self.timing = timing
        self.rng = rng
        self.carts = carts
        self.events: list[ScriptEvent] = []
        self.index = -1
        self.phase = "start"
        self.phase_end = 0.0
        self.path1: PositionPath | None = None
        self.path2: PositionPath | None = None

    @property
    def done(self) -> bool:
        return self.phase == "done"

    def update(self, t: float, x1: float, x2: float) -> None:
        """Advance phases whose end time has come (called at every substep boundary)."""
        while self.phase not in ("ring", "done") and t >= self.phase_end:
            self._next_phase(self.phase_end, t, x1, x2)

    def ring_over(self, t: float) -> None:
        """The rig says the ringing case has settled (or timed out): next case, pins stay on."""
        self.events.append(ScriptEvent("settled", self.cases[self.index], t, self.index))
        self._start_case(t)

    def _event(self, kind: str, t: float) -> None:
        self.events.append(ScriptEvent(kind, self.cases[self.index], t, self.index))

    def _start_case(self, t: float) -> None:
        self.index += 1
        if self.index >= len(self.cases):
            self.phase, self.phase_end = "done", math.inf
            return
        self._event("case_start", t)
        case = self.cases[self.index]
        if case == "idle":
            self.path1 = self.path2 = None
        self.phase = "idle" if case == "idle" else "rest"
        self.phase_end = t + (self.timing.idle_s if case == "idle" else self.timing.rest_s)

    def _next_phase(self, t: float, t_now: float, x1: float, x2: float) -> None:
        """Leave the phase that ended at `t`; `t_now` (>= t) is when the rig noticed."""
        tm = self.timing
        if self.phase == "start":
            self._start_case(t)
        elif self.phase == "idle":
            self.events.append(ScriptEvent("settled", "idle", t, self.index))
            self._start_case(t)
        elif self.phase == "rest":
            self._grab(t, x1, x2)
            self.phase, self.phase_end = "pull", t + self._move_s()
        elif self.phase == "pull":
            jitter = 1.0 + float(self.rng.uniform(-tm.hold_jitter, tm.hold_jitter))
            self.phase, self.phase_end = "hold", t + tm.hold_s * jitter
        elif self.phase == "hold" and self.cases[self.index] == "handle":
            held = self.path1
            assert isinstance(held, HandPath)
            self.path1 = HandPath(t, held.x1, 0.0, self._move_s(), held.tremor, held.t0)
            self.phase, self.phase_end = "return", t + self._move_s()
        elif self.phase == "return":
            self._event("letgo", t_now)
            self.path1 = None
            self.phase, self.phase_end = "ring", math.inf
        elif self.phase == "hold" and tm.flick_mps != 0.0:
            held = self.path1 if self.cases[self.index] in ("cart1", "both") else self.path2
            assert isinstance(held, HandPath)
            flick = FlickPath(t, held.x1, tm.flick_mps / tm.flick_s, held.tremor, held.t0)
            if self.cases[self.index] == "cart2":
                self.path2 = flick
            else:
                self.path1 = flick
            self._event("flick", t)
            self.phase, self.phase_end = "flick", t + tm.flick_s
        elif self.phase in ("hold", "flick"):
            self._event("release", t_now)
            case = self.cases[self.index]
            if case in ("cart1", "both"):
                self.path1 = None
            if case in ("cart2", "both"):
                self.path2 = None
            self.phase, self.phase_end = "ring", math.inf

    def _move_s(self) -> float:
        """A `handle` case moves twice as slowly as a pull."""
        return self.timing.pull_s * (2.0 if self.cases[self.index] == "handle" else 1.0)

    def _grab(self, t: float, x1: float, x2: float) -> None:
        tm, case = self.timing, self.cases[self.index]
        self._event("grab", t)

        def hand(x0: float, target: float) -> HandPath:
            return HandPath(t, x0, target, self._move_s(), tremor_terms(self.rng, tm.tremor_m))

        def pin(x0: float) -> HandPath:
            return HandPath(t, x0, 0.0, tm.pull_s)

        if case == "cart1":
            self.path1 = hand(x1, -tm.pull_m)
            self.path2 = pin(x2) if self.carts == 2 else None
        elif case == "cart2":
            self.path1, self.path2 = pin(x1), hand(x2, -tm.pull_m)
        elif case == "both":
            self.path1, self.path2 = hand(x1, -tm.pull_m), hand(x2, 0.0)
        elif case == "handle":
            self.path1, self.path2 = hand(x1, -tm.pull_m), None
