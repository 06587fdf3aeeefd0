"""Stillness and rest for `daq.detector.ReleaseDetector`: whether the carts kept still
together (every channel, or the channels given, within ±band of one anchor for a while) or each
on its own (each cart within ±still_band_m of its own anchor for still_s), the mean position
over a still window, and the carts' rest, which a released cart moves toward: where the carts
settled after the last run, where each was first still (at start-up), or the centre of a free
ringing.

It only tells stillness and keeps the rest; what a hold arms, and when a run settles, is the
detector's. Pure: time comes with the samples, and the detector's kept samples are passed in.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

#: Each cart's rest (m), None before any is known.
Rest = tuple[float, ...] | None


class Stillness:
    """The carts' common anchor (`anchor` m, since `anchor_t` s) and each cart's own (`alone`)."""

    def __init__(self, band_m: float, still_s: float) -> None:
        self._band_m = band_m
        self._still_s = still_s
        self.anchor: tuple[float, ...] | None = None
        self.anchor_t = 0.0
        self.alone: list[tuple[float, float]] = []   # each cart's own still anchor (x m, since s)

    def still(self, t_s: float, sample: tuple[float, ...], band: float, duration_s: float,
              channels: Sequence[int] | None = None) -> bool:
        """True once every channel (of `channels`) stayed within ±band of the anchor for `duration_s`."""
        anchor = self.anchor
        if anchor is None or len(anchor) != len(sample):
            self.restart(t_s, sample)
            return False
        for c in channels if channels is not None else range(len(sample)):
            if abs(sample[c] - anchor[c]) > band:
                self.restart(t_s, sample)
                return False
        return t_s - self.anchor_t >= duration_s

    def restart(self, t_s: float, sample: tuple[float, ...]) -> None:
        """Anchor the carts together at `sample`, from `t_s` on."""
        self.anchor = sample
        self.anchor_t = t_s

    def still_alone(self, t_s: float, sample: tuple[float, ...]) -> list[int]:
        """The channels each still within ±still_band_m of its own anchor for still_s."""
        if len(self.alone) != len(sample):
            self.alone = [(x, t_s) for x in sample]
        band, still = self._band_m, []
        for c, x in enumerate(sample):
            if abs(x - self.alone[c][0]) > band:
                self.alone[c] = (x, t_s)
            elif t_s - self.alone[c][1] >= self._still_s:
                still.append(c)
        return still


def mean_since(history: Iterable[tuple[float, tuple[float, ...]]], t0_s: float) -> tuple[float, ...]:
    """Mean position of the samples of the history from `t0_s` on (the still window)."""
    window = [h[1] for h in history if h[0] >= t0_s]
    return tuple(sum(column) / len(window) for column in zip(*window))


def first_rest(rest: Rest, hold: tuple[float, ...], channels: Sequence[int]) -> tuple[float, ...]:
    """A cart's rest, until it settles after a run, is where it was first still: `rest` with
    each cart of `channels` that has none yet at its `hold`."""
    n = len(hold)
    out = list(rest) if rest is not None and len(rest) == n else [math.nan] * n
    for c in channels:
        if math.isnan(out[c]):
            out[c] = hold[c]
    return tuple(out)


def ringing_rest(rest: Rest, hold: tuple[float, ...], channel: int, centre_m: float) -> tuple[float, ...]:
    """A free ringing swings about the cart's rest (`centre_m`, `daq.ringing.centre_of` its
    three turning points). It replaces the rest taken at start-up where the carts were first
    still, which may have been a cart held pulled (a later release from a hold near the true rest
    was then taken for a release "toward the rest"; a hand's swing from there was dated at its
    start)."""
    out = list(rest if rest is not None and len(rest) == len(hold) else hold)
    out[channel] = centre_m
    return tuple(out)


def pulled_from_rest(rest: Rest, hold: tuple[float, ...], channel: int, direction: float, margin_m: float) -> str:
    """Why a fast departure of `channel` from `hold` in `direction` (±1) cannot be a release,
    judged against the rest position, or ''.

    A released cart moves toward its rest; a cart that leaves its rest (within `margin_m`), or
    moves away from it, is pulled by a hand, however fast.
    """
    if rest is None or len(rest) != len(hold):
        return ""
    offset = rest[channel] - hold[channel]
    if abs(offset) <= margin_m:
        return "pulled from rest"
    if offset * direction < 0:
        return "pulled away from rest"
    return ""


__all__ = ["Rest", "Stillness", "first_rest", "mean_since", "pulled_from_rest", "ringing_rest"]
