"""Held or free from amplitudes: which carts of a run swung freely, and the run's lab case. Pure.

A cart other than the pulled one is held (pinned, or loosely held by a hand that wanders and
lets it follow the pulled cart a little through the spring) when its swing in the detector's
first `SPAN_S` after the release is below `PINNED_SPAN_M`, or below `HELD_RATIO` times the
pulled cart's span: held or free is told by the amplitude, not by whether it moved at all (nor
by a later touch).

A cart's swing is its second-largest swing between turning points (`Swings`), not its span: a
free cart swings back and forth, while the hand that holds a cart moves it one way at a time
(its wander, or a move of 3-12 mm a student makes just after a release) and makes one long
swing. Spanned, such a move made a held cart free (15 mm moved 0.5 s after a flick of 77 mm).
The pulled cart's span is the reference. The run's metadata states this verdict; the detector
settles a run on the spans alone (`moving_carts` without `swings_m`), since a free pair's
partner has swung only once or twice when its run starts.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

#: a cart whose swing is below this (m) is held whatever the pulled cart did
PINNED_SPAN_M = 0.002
#: a cart whose swing is below this fraction of the pulled cart's span is held
HELD_RATIO = 0.2
#: a turn of a cart's swings is a reversal by this much (m): half the pinned level
SWING_BAND_M = 0.5 * PINNED_SPAN_M


class Swings:
    """One cart's span and its swings between turning points (hysteresis `band_m`), fed one
    position at a time from where the swings start."""

    __slots__ = ("_direction", "_ext", "_largest", "_turn", "band_m", "high", "low")

    def __init__(self, x0: float, band_m: float = SWING_BAND_M) -> None:
        self.band_m = band_m
        self.low = self.high = x0
        self._turn = self._ext = x0     # the last turning point; the current swing's extreme
        self._direction = 0.0           # +1 rising, -1 falling, 0 not known yet
        self._largest = [0.0, 0.0]      # the two largest finished swings, largest first

    def push(self, x: float) -> None:
        self.low, self.high = min(self.low, x), max(self.high, x)
        d = self._direction
        if d == 0.0:
            if abs(x - self._turn) > abs(self._ext - self._turn):
                self._ext = x
            if abs(self._ext - self._turn) > self.band_m:
                self._direction = 1.0 if self._ext > self._turn else -1.0
            return
        if (x - self._ext) * d > 0.0:
            self._ext = x
        elif (self._ext - x) * d > self.band_m:   # reversed: the swing to the extreme is finished
            self._finish(abs(self._ext - self._turn))
            self._turn, self._ext, self._direction = self._ext, x, -d

    def _finish(self, swing: float) -> None:
        first, second = self._largest
        if swing > first:
            self._largest = [swing, first]
        elif swing > second:
            self._largest[1] = swing

    @property
    def span_m(self) -> float:
        return self.high - self.low

    @property
    def second_m(self) -> float:
        """The second-largest swing, the one going on counted as far as it went."""
        return sorted([*self._largest, abs(self._ext - self._turn)])[1]


def swings_of(columns: Iterable[Sequence[float]], band_m: float = SWING_BAND_M) -> list[Swings]:
    """Each column's `Swings` over its samples (a column: one cart's positions in time order)."""
    out = []
    for column in columns:
        swings = Swings(float(column[0]), band_m)
        for x in column[1:]:
            swings.push(float(x))
        out.append(swings)
    return out


def moving_carts(pulled_cart: int | None, spans_m: Sequence[float], held_ratio: float = HELD_RATIO,
                 swings_m: Sequence[float] | None = None) -> list[int] | None:
    """The carts (1-based) that swung freely, the pulled one first; `spans_m` is each cart's
    span (max - min, m) after the release, `swings_m` each cart's swing (`Swings.second_m`; the
    spans when not given), `held_ratio` the detector's setting (`HELD_RATIO` by default). None
    when the pulled cart is not one of them."""
    n = len(spans_m)
    if pulled_cart not in (1, 2) or pulled_cart > n:
        return None
    swung = spans_m if swings_m is None else swings_m
    free_above = max(PINNED_SPAN_M, held_ratio * spans_m[pulled_cart - 1])
    others = [c + 1 for c in range(n) if c + 1 != pulled_cart and swung[c] >= free_above]
    return [pulled_cart, *others]


def lab_case(pulled_cart: int | None, spans_m: Sequence[float], held_ratio: float = HELD_RATIO,
             swings_m: Sequence[float] | None = None) -> str | None:
    """The lab case of a two-encoder run: `cart1`/`cart2` (the other cart held), `both` (cart 1
    pulled, cart 2 free) or `both_cart2_pulled`; None for another number of encoders."""
    moving = moving_carts(pulled_cart, spans_m, held_ratio, swings_m) if len(spans_m) == 2 else None
    if moving is None:
        return None
    if len(moving) == 1:
        return f"cart{pulled_cart}"
    return "both" if pulled_cart == 1 else "both_cart2_pulled"
