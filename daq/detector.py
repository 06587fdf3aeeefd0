"""The release detector: a pure state machine fed with (t_s, positions) samples.

    idle --(every cart within ±still_band_m of an anchor for still_s)--> armed
    idle --(one cart so, while another moves)--> armed on that cart alone (its hold is watched;
            a cart that comes to a hold later joins it, with another `Armed`)
    armed --(a cart leaves its hold by > fire_m)--> candidate (collecting the fit window, and
            waiting until the cart is confirm_m from its hold or came back: a nudge is not a release)
    candidate --(initial-parabola fit says: sudden acceleration ≥ min_accel)--> released
    candidate --(otherwise: slow hand motion, a glitch)--> idle
    released --(every cart still within ±settle_band_m for settle_s, or max_run_s)--> settled
    settled --> idle (on the next sample)

Holes in the data. A hole shorter than `max_hole_s` (a line lost to corruption) is only
missing samples: the still window and the onset fit use the samples' own times, so `hole()`
keeps the state. A longer hole (an unplugged port) may hide a release or a move of the
hand, so it forgets the hold (`reset()`); a run in progress is always left alone.

Release instant (`daq.release_dating`). The threshold crossing comes 10-40 ms late, so t0 is
back-dated by the onset fit of `daq.onset` on the samples around the crossing (only the
channel that moved most).
Settings and events live in `daq.detector_events`; stillness and the carts' rest are kept by
`daq.stillness`, every channel's turns and the pending dating of a ringing by `daq.ringing_watch`.

A release is told from slow hand motion by the fitted initial acceleration `a = 2 c_2`
(a spring released from 0.15 m starts at several m/s², a hand pulling over ≳ 1 s below
1 m/s²) and by the cart still being away from its hold at the end of the fit window; from
a fast pull (a yank) by its direction: a released cart moves toward its rest (where the
carts settled after the last run, or were first still after start-up), a pulled one leaves it.

Ringing (see `daq.ringing`). What the fast path turns down, or never sees, is caught by
its ringing: every channel's turning points are followed in every state, and a free swing
(half-periods that repeat, a swing of at least `ring_min_swing_m` that does not grow) is a
release. This catches flicks from rest (the cart is let go while it moves; the fast path
calls them "pulled from rest"), releases from a hold taken for the rest (daq started during
the hold), later releases of a record, and a new release while the previous run still
rings (a swing that grows ends that run: `Settled(reason="handled")`). It is confirmed about
one period after the release (at most `first_release_confirm_s`, so the pipeline's ring of
samples still holds the pre-trigger part) and dated from the data: from a still hold by the
onset fit above, unless a free response (fitted one period on) clearly begins later (a hand
that lets go gradually); otherwise where a hand's force ends and the free response begins.
Ringing that was going on when the stream began has no release in the data and is turned
down ("in motion since the stream started"); each ringing is judged once (a hold or a new
handling lets it be judged again). Springs slower than `ring_max_half_s` per half-period are
not confirmed by ringing.

A cart held still while the other swings (a free pair's partner rings on, or a loosely held
cart beats about its hold) arms alone: the carts were never still together, so only the ringing
could record such a hold's release, and a pair's beating often never rang as one swing. Its
rest, until it settles after a run, is where it was first still (`Armed.watched` tells the
pipeline to zero that cart alone).

Settling is judged on the moving carts only (`daq.held.moving_carts` on the carts' spans): a
held cart that wanders (its span below `held_ratio` times the pulled cart's, or below 2 mm)
does not keep a run open. The run's metadata states held or free by the same rule on the
carts' swings (`run_swings_m`), which a hand's move of the held cart does not make free.

Positions may be zeroed or not: only motion relative to the hold matters. Pure: no clocks,
no I/O; time comes with the samples (float seconds, continuous).
"""

from __future__ import annotations

import logging
import math
from collections import deque
from collections.abc import Sequence
from typing import Literal

from daq.detector_events import (
    Armed,
    DetectorSettings,
    Disarmed,
    Event,
    Rejected,
    Released,
    Samples,
    Settled,
)
from daq.held import Swings, moving_carts, swings_of
from daq.hold_dating import fit_onset_at, redate_hold, spring_of_pull
from daq.onset import OnsetFit, fit_onset
from daq.release_dating import date_ringing_release
from daq.ringing import RingingLimits, Turn, centre_of, is_broken
from daq.ringing_watch import RingingWatch
from daq.stillness import Stillness, first_rest, mean_since, pulled_from_rest, ringing_rest

log = logging.getLogger(__name__)
#: What the numerical dating may raise on a record nobody foresaw: it turns the candidate down
#: (logged as a warning) instead of ending the stream, and every later release is still recorded.
DATING_ERRORS = (ValueError, ArithmeticError, IndexError)

__all__ = ["METHOD", "SPAN_S", "Armed", "DetectorSettings", "Disarmed", "Event", "OnsetFit", "Rejected",
           "ReleaseDetector", "Released", "Settled", "State", "fit_onset"]

State = Literal["idle", "armed", "released", "settled"]
METHOD = "piecewise-polynomial-onset-fit"
SPAN_S = 1.5    # held or free is judged on the carts' spans in the first 1.5 s after the release


class ReleaseDetector:
    """Feed samples in time order with `feed(t_s, positions)`; read events from its return."""

    def __init__(self, settings: DetectorSettings | None = None) -> None:
        self.settings = s = settings or DetectorSettings()
        self.state: State = "idle"
        self._keep_s = s.pre_trigger_s + s.first_release_confirm_s + 1.0
        self._history: deque[tuple[float, tuple[float, ...]]] = deque()
        self._stillness = Stillness(s.still_band_m, s.still_s)
        self._rest: tuple[float, ...] | None = None
        self._hold: tuple[float, ...] = ()
        self._watched: tuple[int, ...] = ()     # the channels an armed hold watches (its still carts)
        self._trigger_t: float | None = None
        self._trigger_channel = 0
        self._post_samples = 0
        self._release_t = -math.inf        # the last run's release instant
        self._first_t: float | None = None
        self._run_channel = 0
        self._run_turns = 0                 # turns of the run's channel since its release
        self._judge_from = 0.0              # a hand on the run's carts is looked for from here (s)
        self._run_swings: list[Swings] = []   # each cart's swings in the first SPAN_S of the run
        limits = RingingLimits(s.ring_min_swing_m, 0.03, s.ring_max_half_s, s.ring_half_ratio, s.ring_grow,
                               s.still_band_m)
        self._ringing = RingingWatch(limits, s.still_band_m, s.held_ratio)

    # --- public -----------------------------------------------------------------------------
    def feed(self, t_s: float, pos: Sequence[float]) -> list[Event]:
        """One sample: device time in seconds (continuous) and one position per channel (m)."""
        sample = pos if type(pos) is tuple else tuple(pos)
        history = self._history
        history.append((t_s, sample))
        horizon = t_s - self._keep_s
        while history[0][0] < horizon:
            history.popleft()
        if self._first_t is None:
            self._first_t = t_s
        turned = self._ringing.push(t_s, sample)
        if self.state == "released":
            return self._feed_released(t_s, sample, turned)
        if self.state == "settled":
            self.state = "idle"  # settled lasts one sample
            self._stillness.restart(t_s, sample)
            return []
        if turned:
            self._ringing.check(history, turned)
        if self._ringing.dating is not None:
            dated = self._due(t_s)
            if dated:
                return dated
        if self.state == "idle":
            return self._feed_idle(t_s, sample)
        return self._feed_armed(t_s, sample)

    def finish(self) -> list[Event]:
        """The stream ended: a ringing confirmed but not yet dated (the end cut its free window
        short) is dated on the samples there are, so a release cut by the record's end is still
        recorded (a student's last release often is). With none, a channel's last three turns
        are judged as a ringing on their last half-period alone (`RingingWatch.last_ringing`)."""
        if not self._history:
            return []
        t_s = self._history[-1][0]
        ringing = self._ringing
        if ringing.dating is None and self.state != "released":
            found = ringing.last_ringing(self._release_t)
            ringing.dating = (t_s, *found) if found is not None else None
        if ringing.dating is None:
            return []
        ringing.dating = (t_s, *ringing.dating[1:])
        return self._due(t_s)

    def arm_now(self, t_s: float, pos: Sequence[float]) -> list[Event]:
        """Arm at `pos` at once (a command), unless a run is in progress."""
        if self.state == "released":
            return []
        self.state = "armed"
        self._trigger_t = None
        self._hold = tuple(pos)
        self._watched = tuple(range(len(pos)))
        return [Armed(t_s, self._hold)]

    def drive_release(self, t_switch_s: float) -> list[Event]:
        """The rig's drive switched at `t_switch_s` (a motor pulse's edge, known from the stream):
        the carts' motion since is its step response, released there, on the channel that moved
        most since, whatever the hand's rules made of it (a 3 mm step that swings back toward
        its hold reads as a nudge that "came back"). Nothing while a run is open or before the
        switch is in the history."""
        if self.state == "released" or not self._history or self._history[0][0] > t_switch_s:
            return []
        before = [x for t, x in self._history if t < t_switch_s] or [self._history[0][1]]
        hold = before[-1]
        after = [x for t, x in self._history if t >= t_switch_s] or [hold]
        moved = [max(abs(x[c] - hold[c]) for x in after) for c in range(len(hold))]
        channel = max(range(len(moved)), key=moved.__getitem__)
        self._trigger_t = None
        t_s = self._history[-1][0]
        return [self._release(Released(t_switch_s, t_switch_s, t_s, channel, 0.0, hold))]

    def hole(self, span_s: float) -> list[Event]:
        """Samples are missing: `span_s` between the samples either side of the hole (s).

        Up to `max_hole_s` (a few lost lines) nothing changes; a longer hole resets.
        """
        if span_s <= self.settings.max_hole_s:
            return []
        return self.reset()

    def reset(self) -> list[Event]:
        """Forget the hold and the turns (e.g. after a gap in the data); a run in progress is left alone."""
        if self.state == "released":
            self.forget_turns()
            return []
        self._trigger_t = None
        self._ringing.dating = None
        self._stillness.alone = []
        self._ringing.clear()
        if self.state in ("armed", "settled"):
            self.state = "idle"
            self._stillness.anchor = None
            return [Disarmed(self._history[-1][0] if self._history else 0.0)]
        self._stillness.anchor = None
        return []

    def forget_turns(self) -> None:
        """Turning points either side of a hole are not one swing: judge the ringing afresh after it.

        The first turn after the hole is where the samples resumed, not an extreme, so it is not
        counted: three true turns are needed again before a swing can be judged.
        """
        self._ringing.clear()
        self._run_turns = -1

    # --- states -----------------------------------------------------------------------------
    def _feed_idle(self, t_s: float, sample: tuple[float, ...]) -> list[Event]:
        stillness = self._stillness
        still_alone = stillness.still_alone(t_s, sample)
        if stillness.still(t_s, sample, self.settings.still_band_m, self.settings.still_s):
            self._hold = mean_since(self._history, stillness.anchor_t)
            self._watched = tuple(range(len(sample)))
            stillness.alone = []
            self._rest = first_rest(self._rest, self._hold, self._watched)
            self._ringing.unmute()   # still: any ringing before is over
        elif still_alone:
            # a cart held still while the other swings (a free pair's partner rings on, or beats
            # about its hold by a few mm): its hold is armed alone, and only its own departure fires
            # (the carts were never still together: a free pair's holds were caught by their
            # ringing alone, and lost where the pair's beating never rang as one swing)
            self._hold = sample
            self._watched = ()
            self._watch(still_alone)
        else:
            return []
        self.state = "armed"
        return [self._armed(t_s)]

    def _armed(self, t_s: float) -> Armed:
        return Armed(t_s, self._hold, None if len(self._watched) == len(self._hold) else self._watched)

    def _watch(self, channels: list[int]) -> None:
        """Arm the hold of `channels` too, each still alone since its own anchor (`Stillness.still_alone`)."""
        hold = list(self._hold)
        for c in channels:
            hold[c] = mean_since(self._history, self._stillness.alone[c][1])[c]
        self._ringing.unmute(channels)
        self._hold = tuple(hold)
        self._watched = tuple(sorted({*self._watched, *channels}))
        self._rest = first_rest(self._rest, self._hold, channels)

    def _feed_armed(self, t_s: float, sample: tuple[float, ...]) -> list[Event]:
        if self._trigger_t is None:
            if len(self._watched) < len(sample):   # a cart that comes to a hold later is armed too
                newly = [c for c in self._stillness.still_alone(t_s, sample) if c not in self._watched]
                if newly:
                    self._watch(newly)
                    return [self._armed(t_s)]
            fire_m, hold = self.settings.fire_m, self._hold
            for c in self._watched:   # the common case, every sample of a hold: still
                if sample[c] - hold[c] > fire_m or hold[c] - sample[c] > fire_m:
                    break
            else:
                return []
            self._trigger_t = t_s
            self._stillness.alone = []    # each cart's stillness is judged afresh after the decision
            self._trigger_channel = self._channel_moved_most(sample)
            self._post_samples = 0
            return []
        self._post_samples += 1
        settings = self.settings
        if t_s - self._trigger_t < settings.fit_post_s or self._post_samples < settings.fit_min_post_samples:
            return []
        # a nudge by hand goes out a few mm and comes back: wait until the cart has gone confirm_m
        # from its hold (a released cart is at least rest_margin_m from its rest and goes there),
        # or came back, or the wait is as long as a slow spring's half-period
        moved = max(abs(sample[c] - self._hold[c]) for c in self._watched)
        if settings.fire_m < moved < settings.confirm_m and t_s - self._trigger_t < settings.ring_max_half_s:
            return []
        return [self._decide(t_s, sample)]

    def _decide(self, t_s: float, sample: tuple[float, ...]) -> Released | Rejected:
        trigger_t = self._trigger_t
        assert trigger_t is not None
        self._trigger_t = None
        channel = self._channel_moved_most(sample)
        hold, rest = self._hold, self._rest
        still_away = abs(sample[channel] - hold[channel]) > self.settings.fire_m
        samples = Samples.of(list(self._history))
        fit = fit_onset_at(samples, channel, hold, trigger_t, self.settings)
        direction = 1.0 if sample[channel] > hold[channel] else -1.0
        accel = fit.accel_m_s2 * direction if fit is not None else 0.0
        reason = ("fit failed" if fit is None else "came back" if not still_away
                  else "slow motion" if accel < self.settings.min_accel_m_s2
                  else pulled_from_rest(rest, hold, channel, direction, self.settings.rest_margin_m))
        if reason:
            # a flick or a release from a hold taken for the rest is still caught by its ringing
            self.state = "idle"
            self._stillness.restart(t_s, sample)
            return Rejected(t_s, accel, reason)
        assert fit is not None
        pull = hold[channel] - rest[channel] if rest is not None and len(rest) == len(hold) else 0.0
        fit, spring = spring_of_pull(samples, channel, hold, trigger_t, fit, pull, self.settings)
        t0 = redate_hold(samples, channel, hold, trigger_t, fit, self.settings, spring)
        return self._release(Released(t0, trigger_t, t_s, channel, abs(fit.accel_m_s2), hold))

    def _release(self, release: Released, judged_to: float = -math.inf) -> Released:
        """Enter the run of `release`; a hand that takes its cart again is looked for from the
        release on, or from `judged_to` when the dating judged the motion free up to there (a
        ringing's turn C: the swings before it may carry what its dating set aside, as the
        0.3-0.9 s after a real motor pulse on a free pair, whose cart misfit its driven free
        response by 0.7 % of its span there)."""
        self.state = "released"
        self._ringing.dating = None
        self._release_t = release.t_release_s
        self._stillness.anchor = None
        self._stillness.alone = []
        self._run_channel = release.channel
        # a ringing confirms its release a period or more after it: a hand may take the cart
        # again between its turns (testkit 9433: a free pair's cart flicked again 0.2 s after
        # the confirmation, never judged, its run rang on through the second release)
        self._judge_from = max(release.t_release_s, judged_to)
        self._run_turns = sum(turn.t_s >= self._judge_from for turn in self._ringing.turns(release.channel))
        # the spans from the release on: a ringing is confirmed about a period after it, and the
        # swings before are the largest (spanned from the confirmation, a pulled cart's 70 mm
        # swing counted 41 mm, and a held cart moved 6 mm by hand made the run two free carts)
        since = [x for t, x in self._history if t >= release.t_release_s] or [self._history[-1][1]]
        self._run_swings = swings_of(zip(*since))
        return release

    def _feed_released(self, t_s: float, sample: tuple[float, ...], turned: list[int]) -> list[Event]:
        settings = self.settings
        if t_s - self._release_t >= settings.max_run_s:
            self.state = "settled"
            return [Settled(t_s, "max_run")]
        if t_s - self._release_t <= SPAN_S:   # free carts swing most at first; later a hand may move one
            for swings, x in zip(self._run_swings, sample, strict=True):
                swings.push(x)
        handled = self._handled_again(turned) if turned else None
        if handled:
            self.state = "settled"
            self._ringing.unmute()
            self._ringing.after_hand(handled)
            return [Settled(t_s, "handled")]
        if self._stillness.still(t_s, sample, settings.settle_band_m, settings.settle_s, self._moving_channels()):
            self.state = "settled"
            self._rest = mean_since(self._history, self._stillness.anchor_t)
            self._ringing.clear()
            self._ringing.unmute()
            return [Settled(t_s, "still")]
        return []

    def run_spans_m(self) -> list[float] | None:
        """Each cart's span (m) from the last release to `SPAN_S` after it; None before the first
        release. The detector settles on the carts that spanned like the pulled one (a cart moved
        by hand after the release keeps the run open until it is still too); the run's metadata
        states held or free from these spans and `run_swings_m` (`daq.held.moving_carts`)."""
        return [s.span_m for s in self._run_swings] if self._run_swings else None

    def run_swings_m(self) -> list[float] | None:
        """Each cart's swing (m, `daq.held.Swings.second_m`) over the spans' samples; None before
        the first release."""
        return [s.second_m for s in self._run_swings] if self._run_swings else None

    def _moving_channels(self) -> list[int]:
        """The run's channel and every channel that spanned like it (not a held cart's wander;
        `daq.held.moving_carts` on the spans alone: a free pair's partner has swung once or twice
        when the run starts, too few swings to tell it from a hand's move)."""
        moving = moving_carts(self._run_channel + 1, self.run_spans_m() or [], self.settings.held_ratio)
        return [c - 1 for c in moving] if moving is not None else [self._run_channel]

    def _handled_again(self, turned: list[int]) -> Literal["grew", "taken"] | None:
        """A swing of the run's cart that grew or came after a half-period unlike the last
        ("grew"), or a moving cart that no longer moves as its free response ("taken"): a hand
        took it again (a new release may follow); None while the run rings freely. Judged at a
        turn of the run's cart, or of either cart of a free pair (a hand may hold the pulled
        cart still: no turns)."""
        moving = self._moving_channels()
        if self._run_channel in turned:
            self._run_turns += 1
            channel = self._run_channel
        else:
            channel = next((c for c in turned if c in moving), -1)
            if len(moving) < 2 or channel < 0:
                return None
        turns = self._ringing.turns(channel)
        if self._run_turns < 3 or len(turns) < 3 or turns[-3].t_s < self._judge_from:
            return None
        a, b, c = turns[-3], turns[-2], turns[-1]
        # (two free carts beat: their swings grow and shrink by themselves, and only a cart that
        # stops moving as its free response driven by the other's tells a hand)
        limits = self._ringing.limits
        if len(moving) < 2 and abs(c.x_m - b.x_m) >= limits.min_swing_m and is_broken(a, b, c, limits):
            return "grew"
        return "taken" if self._ringing.taken(self._history, moving, (a, b, c)) else None

    def _channel_moved_most(self, sample: tuple[float, ...]) -> int:
        """The watched channel furthest from its hold."""
        return max(self._watched, key=lambda c: abs(sample[c] - self._hold[c]))

    # --- ringing --------------------------------------------------------------------------------
    def _due(self, t_s: float) -> list[Event]:
        """The dating of a confirmed ringing, once its time has come."""
        dating = self._ringing.dating
        if dating is None or t_s < dating[0]:
            return []
        self._ringing.dating = None
        self._trigger_t = None
        _, channel, a, b, c = dating
        event = self._date(t_s, channel, a, b, c)
        if isinstance(event, Released):
            return [self._release(event, c.t_s)]
        return [event]

    def _date(self, t_s: float, channel: int, a: Turn, b: Turn, c: Turn) -> Released | Rejected:
        """Date a confirmed ringing (`daq.release_dating`)."""
        first_t = self._first_t if self._first_t is not None else self._history[0][0]
        try:
            event = date_ringing_release(Samples.of(list(self._history)), t_s, channel, (a, b, c), self.settings,
                                         first_t)
        except DATING_ERRORS as exc:
            log.warning("dating the ringing confirmed at %.3f s failed (%s: %s): no run for it; please report "
                        "this record", t_s, type(exc).__name__, exc)
            return Rejected(t_s, 0.0, f"ringing: dating failed ({type(exc).__name__})")
        if isinstance(event, Released) and event.t_release_s <= self._release_t + max(self.settings.fit_post_s,
                                                                                     0.5 * (c.t_s - a.t_s)):
            # the other cart of a free pair rings on after its partner's release was recorded (a
            # hand does not take a cart and let it go again within a half-period of letting it go)
            return Rejected(t_s, 0.0, "ringing: dated at the last run's release (recorded)")
        if isinstance(event, Released):
            self._hold = event.hold_pos
            self._rest = ringing_rest(self._rest, event.hold_pos, channel, centre_of((a, b, c)))
        return event
