"""The ringing watched on every channel for `daq.detector.ReleaseDetector`: each channel's
turning points (`daq.ringing.Zigzag`), whether its ringing was judged already (muted), and the
pending dating of a confirmed ringing, due once enough of its free response is in.

Each ringing is judged once: a channel is muted when its ringing is taken for dating, and
unmuted by a hold, by stillness after a run, or when a hand takes the cart again (a swing that
grows, or a cart that stops moving as its free response). Ringing that waits behind another
channel's pending dating is judged at a later turn.

It says when a ringing is due; it does not date it (`daq.release_dating`, called by the
detector) and knows nothing of the detector's states. Pure: the detector's kept samples are
passed in.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Literal

from daq.detector_events import Samples
from daq.release_dating import free_span, hand_took
from daq.ringing import RingingLimits, Turn, Zigzag, is_broken, is_ringing

#: The detector's kept samples, oldest first: (t s, one position per channel m).
History = Sequence[tuple[float, tuple[float, ...]]]
#: A confirmed ringing waiting for its dating: (due time s, channel, its turns A, B, C).
Dating = tuple[float, int, Turn, Turn, Turn]
#: How a hand took a ringing cart (`RingingWatch.after_hand`).
Handled = Literal["grew", "taken"]

#: turns kept after a hand took a ringing cart: a swing that grew ends where the hand's push did,
#: and starts what comes next; a cart that stopped moving as its free response may still be in
#: the hand (caught and held: a ringing judged from there was fitted across the hand), and what
#: comes next starts at the turn where that was seen
_AFTER_HAND = {"grew": 2, "taken": 1}


class RingingWatch:
    """Every channel's turns and mute flag, and the pending dating (`dating`, or None)."""

    def __init__(self, limits: RingingLimits, band_m: float, held_ratio: float) -> None:
        self.limits = limits
        self._band_m = band_m
        self._held_ratio = held_ratio
        self.zigzags: list[Zigzag] = []
        self.muted: list[bool] = []        # ringing already judged (and turned down) on this channel
        self.dating: Dating | None = None

    def push(self, t_s: float, sample: tuple[float, ...]) -> list[int]:
        """Feed every channel's turning points; the channels that completed a turn."""
        if len(self.zigzags) != len(sample):
            self.zigzags = [Zigzag(self._band_m) for _ in sample]
            self.muted = [False] * len(sample)
        return [c for c, (zigzag, x) in enumerate(zip(self.zigzags, sample)) if zigzag.push(t_s, x)]

    def turns(self, channel: int) -> Sequence[Turn]:
        """The channel's last turning points, oldest first."""
        return self.zigzags[channel].turns

    def clear(self) -> None:
        """Forget every channel's turns."""
        for zigzag in self.zigzags:
            zigzag.clear()

    def after_hand(self, handled: Handled) -> None:
        """A hand took a ringing cart: keep only the turns that start what comes next."""
        for zigzag in self.zigzags:
            zigzag.keep_last(_AFTER_HAND[handled])

    def unmute(self, channels: Iterable[int] | None = None) -> None:
        """Let the ringing of `channels` (all: None) be judged again."""
        if channels is None:
            self.muted = [False] * len(self.muted)
            return
        for c in channels:
            self.muted[c] = False

    def taken(self, history: History, channels: list[int], turns: tuple[Turn, Turn, Turn]) -> bool:
        """Whether a hand took one of `channels` since turn A (`daq.release_dating.hand_took`)."""
        since = Samples.of([h for h in history if h[0] >= turns[0].t_s])
        return hand_took(since, channels, turns, self.limits.min_swing_m, self._held_ratio)

    def check(self, history: History, channels: list[int]) -> None:
        """A channel of `channels` (that just turned) that rings freely: its dating is due once
        enough of its free response is in (`dating`)."""
        for c in channels:
            turns = self.zigzags[c].turns
            if len(turns) < 3:
                continue
            a, b, t_c = turns[-3], turns[-2], turns[-1]
            if self.muted[c]:   # judged before: over when a hand took the cart
                grew = is_broken(a, b, t_c, self.limits)
                if grew or self.taken(history, [c], (a, b, t_c)):
                    self.muted[c] = False
                    self.zigzags[c].keep_last(_AFTER_HAND["grew" if grew else "taken"])
                continue
            if not is_ringing(a, b, t_c, self.limits):
                continue
            half = 0.5 * (t_c.t_s - a.t_s)
            # the free response is fitted from a quarter half-period after B (after any release
            # near B) over three quarters of a period (at least 16 samples: `free_span`)
            step = (history[-1][0] - history[0][0]) / max(len(history) - 1, 1)
            due = (b.t_s + 0.25 * half + free_span(half, step), c, a, b, t_c)
            if self.dating is None or due[0] < self.dating[0]:
                # judged once (stillness or a new handling unmutes); a ringing that waits behind
                # another channel's is judged at a later turn (muted unjudged, the pulled cart of
                # a free pair went unrecorded while the other cart's ringing was turned down)
                if self.dating is not None:
                    self.muted[self.dating[1]] = False
                self.muted[c] = True
                self.dating = due
            return

    def last_ringing(self, release_t: float) -> tuple[int, Turn, Turn, Turn] | None:
        """A release cut by the stream's end before its ringing's next turn: a channel's last
        turns A, B, C, unjudged and after `release_t` (the last run's release), that ring on the
        swing B-C alone, A taken as C a half-period B-C before B (A is where the hand held or
        pushed the cart: A-B carries the hold or the push, longer than B-C and smaller: testkit
        students' last releases 0.8-1.5 s before the end were lost), dated as a confirmed
        ringing is (`check`)."""
        for c, zigzag in enumerate(self.zigzags):
            turns = zigzag.turns
            if self.muted[c] or len(turns) < 3 or turns[-3].t_s < release_t:
                continue
            a, b, t_c = turns[-3], turns[-2], turns[-1]
            a = Turn(b.t_s - (t_c.t_s - b.t_s), t_c.x_m)
            if is_ringing(a, b, t_c, self.limits):
                return c, a, b, t_c
        return None


__all__ = ["Dating", "Handled", "History", "RingingWatch"]
