"""A seeded student at the rig: what real students do, drawn at random. Pure.

`sim://?student=releases` replaces the case script by one record of a student, drawn from
`seed`; `student=handling` by handling only (no release, for false-run tests). The ranges
below were measured on the shared ECP-210 hand-release records (cart 2 flicked, cart 1
held by hand) and the 2023 hand steps; lengths in metres, times in seconds or in periods of
the pulled cart (with the other one held), so they hold on any rig:

- the hand is a force, not a path: it grips the cart (`ident.physics.rig.Grip`, a spring
  and damper per unit mass towards where the hand means the cart to be, ω_g U(30, 70) rad/s,
  ζ_g U(0.6, 1.0), drawn per record) and lets go at once (the force ends: on the real
  records the hand's force per unit mass goes from 3-9 m/s² to ~0 within ~10 ms);
- flick from rest: the hand takes the cart (catching it if it still rings), holds it a
  moment (0-0.4 s: often little or no quiet time), swings it out along a half cosine
  towards `flick_m` × U(0.6, 1.6) (3-8 cm at the default) in U(0.3, 0.45) periods (≈ 0.15 s
  on the ECP-210) and lets go at U(0.5, 0.9) of that time, while the cart still moves out
  and the hand still pushes it. Measured on the seven real flicks: at let-go the hand's
  force is 0.2-1.2 times the spring's pull (median 0.8), the cart 6-53° of phase before
  its first free extreme (median 42°), the force rose over 60-150 ms to a peak of 10-19 m/s²
  30-100 ms before (ω_n 15.5 rad/s); these draws give 0.1-1.0 (10-90 %, median 0.5) and
  12-62° (median 37°);
- otherwise (30 %) a pull-hold-release: a minimum-jerk pull to 0.05-0.15 m in 0.5-1.5 s, a
  hold of 0.3-2 s, let go still;
- 1 to `student_releases` releases, U(2.5, 7) s apart (measured 3.6-7.2 s), each new one
  while the last may still ring; the record ends U(1.5, 5) s after the last (cut ringing);
- the other cart held loosely by a hand (80 %, else pinned): the hand is a soft spring and
  damper (`Grip`, the student's ζ_g) towards a hold point that wanders by a few sines
  (0.2-1.5 Hz) of amplitude `wander_m` × U(0.25, 1) (100-400 counts measured); its stiffness
  makes the held cart follow the pulled one through the coupling spring by `follow` ×
  U(0.4, 1.6) at rest (0.8-3.2 % at the default; measured on the seven real hand releases
  with the other cart held, by least squares over their first 1.5 s: 1.2-2.2 %):
  k_hand = k_c (1/f - 1) - k_w per unit mass of the held cart (k_c the coupling spring, k_w
  its wall's; at least k_c, so f is at most k_c / (2 k_c + k_w)). A pinned cart is a position
  constraint (`ident.physics.rig.PositionPath`);
- with probability `p_nudge` a nudge 0.4-1.2 s before a release: the cart pushed 3-10 mm
  out and brought back by the hand in 0.2-0.5 s, let go at rest (measured: ~1 cm, 0.8 s
  before);
- with probability `p_touch` the other cart is moved by hand 1.5-5 s after a release: 3-10 mm
  in 0.2-0.8 s, and held there (measured: 5-10 mm, 4.8 and 9 s after);
- with probability `p_moving` the record starts in motion: the pulled cart swings already
  (1-5 cm, random phase) and is caught for the first release.

`handling`: for `duration_s` (default 600 s) the other cart held loosely throughout; every
U(2, 8) s a nudge of the free cart, a move of the held cart, or a slow pull of the free cart
(0.05-0.15 m over 1-2 s), held 0.5-2 s and brought back to rest over 1-2 s, let go there.

Truth is in `events` (`release` at the instant the hand lets go, `letgo` for handling).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from daq.sim.hand import ScriptEvent, tremor_terms
from ident.physics.rig import ChainState, Grip, Hand, PositionPath

Sines = tuple[tuple[float, float, float], ...]   # (amplitude m, omega rad/s, phase)
Moves = tuple[tuple[float, float, float], ...]   # (start s, displacement m, duration s)


def _min_jerk(u: float) -> float:
    u = min(1.0, max(0.0, u))
    return u * u * u * (10.0 - 15.0 * u + 6.0 * u * u)


def _sines(t: float, terms: Sines, t0: float) -> float:
    total = 0.0
    for a, w, ph in terms:
        total += a * math.sin(w * (t - t0) + ph)
    return total


@dataclass(frozen=True, slots=True)
class Swing:
    """Take the cart at `x0` (t0), bring it to `rest` in `catch_s`, hold `hold_s`, swing it to
    `rest + amp` along a half cosine in `dur` (and back past it), plus tremor."""

    t0: float
    x0: float
    rest: float
    catch_s: float
    hold_s: float
    amp: float
    dur: float
    tremor: Sines = ()

    @property
    def swing_t0(self) -> float:
        return self.t0 + self.catch_s + self.hold_s

    def __call__(self, t: float) -> float:
        if t < self.t0 + self.catch_s:
            x = self.x0 + (self.rest - self.x0) * _min_jerk((t - self.t0) / self.catch_s)
        else:
            tau = min(max(0.0, t - self.swing_t0), 2.0 * self.dur)
            x = self.rest + 0.5 * self.amp * (1.0 - math.cos(math.pi * tau / self.dur))
        fade = min(1.0, max(0.0, (t - self.t0) / 0.3))
        return x + fade * _sines(t, self.tremor, self.t0)


@dataclass(frozen=True, slots=True)
class Bump:
    """A nudge: taken at `x0` (t0), out by `dx` and back along `sin²` in `dur`, ending still at
    `rest` (a cart caught while it rings is brought to rest too), plus tremor."""

    t0: float
    x0: float
    rest: float
    dx: float
    dur: float
    tremor: Sines = ()

    def __call__(self, t: float) -> float:
        u = min(1.0, max(0.0, (t - self.t0) / self.dur))
        bump = math.sin(math.pi * u)
        x = self.x0 + (self.rest - self.x0) * _min_jerk(u)
        return x + self.dx * bump * bump + bump * _sines(t, self.tremor, self.t0)


@dataclass(frozen=True, slots=True)
class PullHold:
    """A minimum-jerk pull from `x0` to `x1` in `dur` from `t0`, then held, plus tremor."""

    t0: float
    x0: float
    x1: float
    dur: float
    tremor: Sines = ()

    def __call__(self, t: float) -> float:
        fade = min(1.0, max(0.0, (t - self.t0) / 0.3))
        return self.x0 + (self.x1 - self.x0) * _min_jerk((t - self.t0) / self.dur) + fade * _sines(
            t, self.tremor, self.t0)


@dataclass(frozen=True, slots=True)
class LooseHold:
    """Where a hand holding a cart means it to be: hold point, wander and moves."""

    x_hold: float
    wander: Sines
    moves: Moves = ()

    def __call__(self, t: float) -> float:
        x = self.x_hold + _sines(t, self.wander, 0.0)
        for t0, dx, dur in self.moves:
            x += dx * _min_jerk((t - t0) / dur)
        return x


@dataclass(frozen=True, slots=True)
class StudentKnobs:
    """The `sim://` options the student draws from (see the module docstring)."""

    mode: str                 # releases | handling
    max_releases: int
    flick_m: float
    wander_m: float
    follow: float
    p_nudge: float
    p_touch: float
    p_moving: float
    tremor_m: float
    carts: int
    duration_s: float
    period_s: tuple[float, float] = (0.56, 0.56)   # of cart 1 and cart 2 alone (the other held)
    #: per cart, (coupling spring, spring to its wall) per unit mass (1/s²): the held cart's grip
    springs: tuple[tuple[float, float], tuple[float, float]] = ((63.0, 63.0), (63.0, 63.0))


@dataclass(frozen=True, slots=True)
class _Act:
    t_s: float
    kind: str                 # grab | release | letgo | touch | end
    cart: int                 # 1 or 2
    path: PositionPath | None = None


class StudentHand:
    """Runs a drawn timeline of acts; the same interface as `daq.sim.hand.Hand` for the rig."""

    def __init__(self, knobs: StudentKnobs, rng: np.random.Generator, state: ChainState,
                 rest_of: Callable[[int], float]) -> None:
        self.knobs = knobs
        self.rest_of = rest_of      # where a cart is at rest now (the other cart where it is held)
        self.rng = rng
        self.state = state
        self.cases = ("student",)
        self.events: list[ScriptEvent] = []
        #: the hand's force per unit mass (m/s²) on the released cart as it lets go, one per
        #: `release` event: the jump in the cart's acceleration there (truth for benchmarks)
        self.let_go_m_s2: list[float] = []
        self.path1: Hand | None = None
        self.path2: Hand | None = None
        self.phase = "script"
        self.ring_max_s = math.inf
        self.pulled = 1 if knobs.carts == 1 else int(rng.integers(1, 3))
        self.grip = (float(rng.uniform(30.0, 70.0)), float(rng.uniform(0.6, 1.0)))   # ω_g rad/s, ζ_g
        self._acts: list[_Act] = []
        self._held: LooseHold | None = None
        self._held_grip: tuple[float, float] | None = None    # (ω_h rad/s, ζ_h) of a loose hold
        self._draw()
        self._next = 0

    @property
    def done(self) -> bool:
        return self.phase == "done"

    @property
    def phase_end(self) -> float:
        return self._acts[self._next].t_s if self._next < len(self._acts) else math.inf

    def update(self, t: float, x1: float, x2: float) -> None:
        """Apply every act whose time has come (called at every substep boundary)."""
        while self._next < len(self._acts) and t >= self._acts[self._next].t_s:
            act = self._acts[self._next]
            self._next += 1
            self._apply(act, t)

    def ring_over(self, t: float) -> None:
        """Never called: the student's script is timed, not waiting for the carts to settle."""

    # --- drawing the script -----------------------------------------------------------------
    def _u(self, lo: float, hi: float) -> float:
        return float(self.rng.uniform(lo, hi))

    def _draw(self) -> None:
        k, other = self.knobs, 3 - self.pulled
        if k.carts == 2:
            self._hold_other(other)
        if k.mode == "handling":
            self._draw_handling(other)
            return
        t = self._u(0.2, 1.8)
        if self.rng.random() < k.p_moving:
            amp, phase = self._u(0.01, 0.05), self._u(0.0, 2.0 * math.pi)
            self._start_moving(amp, phase)
            t = self._u(1.0, 3.0)
        n = int(self.rng.integers(1, k.max_releases + 1))
        for i in range(n):
            if self.rng.random() < k.p_nudge:
                dur = self._u(0.2, 0.5)
                t_nudge = t
                t += dur + self._u(0.4, 1.2)
                self._acts.append(_Act(t_nudge, "nudge", self.pulled, None))
            t_release = self._draw_release(t)
            gap = self._u(2.5, 7.0) if i < n - 1 else self._u(1.5, 5.0)
            if k.carts == 2 and self.rng.random() < k.p_touch and gap > 2.5:
                self._acts.append(_Act(t_release + self._u(1.5, min(5.0, gap - 0.8)), "touch", other))
            t = t_release + gap
        self._acts.append(_Act(t, "end", 0))
        self._acts.sort(key=lambda a: a.t_s)

    def _draw_release(self, t: float) -> float:
        """One grab at `t`, the release act after it; returns the release time."""
        if self.rng.random() < 0.7:
            amp = self.knobs.flick_m * self._u(0.6, 1.6) * (1.0 if self.rng.random() < 0.5 else -1.0)
            period = self.knobs.period_s[self.pulled - 1]
            catch, hold, dur = self._u(0.15, 0.4), self._u(0.0, 0.4), self._u(0.3, 0.45) * period
            t_release = t + catch + hold + self._u(0.5, 0.9) * dur
            self._acts.append(_Act(t, "flick", self.pulled, Swing(t, 0.0, 0.0, catch, hold, amp, dur)))
        else:
            pull = self._u(0.05, 0.15) * (1.0 if self.rng.random() < 0.5 else -1.0)
            dur = self._u(0.5, 1.5)
            t_release = t + dur + self._u(0.3, 2.0)
            self._acts.append(_Act(t, "pull", self.pulled, PullHold(t, 0.0, pull, dur)))
        self._acts.append(_Act(t_release, "release", self.pulled))
        return t_release

    def _draw_handling(self, other: int) -> None:
        t = self._u(0.5, 2.0)
        free = self.pulled
        while t < self.knobs.duration_s - 10.0:
            pick = self.rng.random()
            if pick < 0.4:
                self._acts.append(_Act(t, "nudge", free))
                t += 0.5
            elif pick < 0.7 and self.knobs.carts == 2:
                self._acts.append(_Act(t, "touch", other))
                t += 0.8
            else:
                pull, dur, hold, back = self._u(0.05, 0.15), self._u(1.0, 2.0), self._u(0.5, 2.0), self._u(1.0, 2.0)
                sign = 1.0 if self.rng.random() < 0.5 else -1.0
                self._acts.append(_Act(t, "slow", free, PullHold(t, 0.0, sign * pull, dur)))
                self._acts.append(_Act(t + dur + hold, "back", free, PullHold(t + dur + hold, sign * pull, 0.0, back)))
                self._acts.append(_Act(t + dur + hold + back, "letgo", free))
                t += dur + hold + back
            t += self._u(2.0, 8.0)
        self._acts.append(_Act(self.knobs.duration_s, "end", 0))

    def _hold_other(self, other: int) -> None:
        k = self.knobs
        if self.rng.random() < 0.8:
            amp = k.wander_m * self._u(0.25, 1.0)
            freqs = self.rng.uniform(0.2, 1.5, 3)
            phases = self.rng.uniform(0.0, 2.0 * math.pi, 3)
            wander = tuple((amp / math.sqrt(3.0), 2.0 * math.pi * float(f), float(p)) for f, p in zip(freqs, phases))
            follow = k.follow * self._u(0.4, 1.6)
            coupling, wall = k.springs[other - 1]
            if follow > 0.0:
                stiffness = max(coupling * (1.0 / follow - 1.0) - wall, coupling)
                self._held_grip = (math.sqrt(stiffness), self.grip[1])
        else:
            wander = ()
        # the hand holds the cart where it is (its rest): continuous at t=0
        self._held = LooseHold(-_sines(0.0, wander, 0.0), wander)
        self._hold(other)

    def _hold(self, cart: int) -> None:
        """The other cart on its hand: a soft grip towards `_held`, or pinned to it."""
        assert self._held is not None
        self._set_path(cart, self._held if self._held_grip is None else Grip(self._held, *self._held_grip))

    def _start_moving(self, amp: float, phase: float) -> None:
        """The record starts in the tail of an earlier release: the pulled cart already swings."""
        s = self.state
        x, v = amp * math.cos(phase), -amp * 10.0 * math.sin(phase)   # ~1.6 Hz: a plausible start
        if self.pulled == 1:
            s.x1, s.v1 = x, v
        else:
            s.x2, s.v2 = x, v

    # --- running it -------------------------------------------------------------------------
    def _set_path(self, cart: int, path: Hand | None) -> None:
        if cart == 1:
            self.path1 = path
        else:
            self.path2 = path

    def _grip(self, cart: int, path: PositionPath) -> None:
        """The hand takes the pulled cart: a force towards `path` (it ends when the hand lets go)."""
        self._set_path(cart, Grip(path, *self.grip))

    def _hand_force(self, cart: int, t: float) -> float:
        """The grip's force per unit mass on `cart` at `t` (0 when no hand grips it)."""
        hand = self.path1 if cart == 1 else self.path2
        if not isinstance(hand, Grip):
            return 0.0
        h = 1e-5
        speed = (hand.path(t + h) - hand.path(t - h)) / (2.0 * h)
        v = self.state.v1 if cart == 1 else self.state.v2
        return hand.omega ** 2 * (hand.path(t) - self._x(cart)) + 2.0 * hand.zeta * hand.omega * (speed - v)

    def _hand_x(self, cart: int, t: float) -> float:
        """Where a new move of the hand starts: where the hand is if it grips the cart (its grip
        does not slacken when it starts to move), else where the cart is (a new grab)."""
        hand = self.path1 if cart == 1 else self.path2
        return hand.path(t) if isinstance(hand, Grip) else self._x(cart)

    def _x(self, cart: int) -> float:
        return self.state.x1 if cart == 1 else self.state.x2

    def _event(self, kind: str, t: float) -> None:
        self.events.append(ScriptEvent(kind, "student", t, 0))

    def _apply(self, act: _Act, t: float) -> None:
        tremor = tremor_terms(self.rng, self.knobs.tremor_m)
        x = self._hand_x(act.cart, t) if act.cart else 0.0
        if act.kind == "flick":
            assert isinstance(act.path, Swing)
            p = act.path
            self._grip(act.cart, Swing(t, x, self.rest_of(act.cart), p.catch_s, p.hold_s, p.amp, p.dur, tremor))
            self._event("grab", t)
        elif act.kind in ("pull", "slow", "back"):
            assert isinstance(act.path, PullHold)
            target = self.rest_of(act.cart) + act.path.x1      # pulls are drawn from the rest
            self._grip(act.cart, PullHold(t, x, target, act.path.dur, tremor))
            if act.kind != "back":
                self._event("grab", t)
        elif act.kind == "nudge":
            dur = self._u(0.2, 0.5)
            dx = self._u(0.003, 0.010) * (1.0 if self.rng.random() < 0.5 else -1.0)
            self._grip(act.cart, Bump(t, x, self.rest_of(act.cart), dx, dur, tremor))
            self._acts.insert(self._next, _Act(t + dur, "letgo", act.cart))
            self._event("nudge", t)
        elif act.kind in ("release", "letgo"):
            if act.kind == "release":
                self.let_go_m_s2.append(self._hand_force(act.cart, t))
            self._set_path(act.cart, None)
            self._event(act.kind, t)
        elif act.kind == "touch":
            self._touch(t)
        elif act.kind == "end":
            self.phase = "done"

    def _touch(self, t: float) -> None:
        """The other cart moved by hand and held at its new place (pinned or loosely held)."""
        dx = self._u(0.003, 0.010) * (1.0 if self.rng.random() < 0.5 else -1.0)
        held = self._held
        if held is None:
            return
        self._held = LooseHold(held.x_hold, held.wander, (*held.moves, (t, dx, self._u(0.2, 0.8))))
        self._hold(3 - self.pulled)
        self._event("touch", t)
