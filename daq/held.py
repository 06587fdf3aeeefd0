"""Held or free from amplitudes: which carts of a run swung freely, and the run's lab case. Pure.

A cart other than the pulled one is held (pinned, or loosely held by a hand that wanders and
lets it follow the pulled cart a little through the spring) when its span in the detector's
first `SPAN_S` after the release is below `PINNED_SPAN_M`, or below `HELD_RATIO` times the
pulled cart's span: held or free is told by the amplitude, not by whether it moved at all (nor
by a later touch).
"""

from __future__ import annotations

from collections.abc import Sequence

#: a cart whose span is below this (m) is held whatever the pulled cart did
PINNED_SPAN_M = 0.002
#: a cart whose span is below this fraction of the pulled cart's is held
HELD_RATIO = 0.2


def moving_carts(pulled_cart: int | None, spans_m: Sequence[float],
                 held_ratio: float = HELD_RATIO) -> list[int] | None:
    """The carts (1-based) that swung freely, the pulled one first; `spans_m` is each cart's
    span (max - min, m) after the release (`held_ratio`: the detector's setting, `HELD_RATIO`
    by default). None when the pulled cart is not one of them."""
    n = len(spans_m)
    if pulled_cart not in (1, 2) or pulled_cart > n:
        return None
    free_above = max(PINNED_SPAN_M, held_ratio * spans_m[pulled_cart - 1])
    others = [c + 1 for c in range(n) if c + 1 != pulled_cart and spans_m[c] >= free_above]
    return [pulled_cart, *others]


def lab_case(pulled_cart: int | None, spans_m: Sequence[float], held_ratio: float = HELD_RATIO) -> str | None:
    """The lab case of a two-encoder run: `cart1`/`cart2` (the other cart held), `both` (cart 1
    pulled, cart 2 free) or `both_cart2_pulled`; None for another number of encoders."""
    moving = moving_carts(pulled_cart, spans_m, held_ratio) if len(spans_m) == 2 else None
    if moving is None:
        return None
    if len(moving) == 1:
        return f"cart{pulled_cart}"
    return "both" if pulled_cart == 1 else "both_cart2_pulled"
