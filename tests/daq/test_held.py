"""Held or free from amplitudes (`daq.held`), on spans given directly."""

from __future__ import annotations

import pytest

from daq.held import HELD_RATIO, PINNED_SPAN_M, lab_case, moving_carts


@pytest.mark.parametrize(("pulled", "spans", "moving", "case"), [
    (2, [0.0004, 0.06], [2], "cart2"),                       # pinned other cart
    (2, [0.15 * 0.06, 0.06], [2], "cart2"),                  # a hand's wander: 15 % of the swing
    (1, [0.06, 0.5 * 0.06], [1, 2], "both"),                 # free, following through the spring
    (2, [0.5 * 0.06, 0.06], [2, 1], "both_cart2_pulled"),
    (1, [0.004, 0.5 * PINNED_SPAN_M], [1], "cart1"),         # small pull: the pin level decides
])
def test_a_cart_is_held_by_its_amplitude_against_the_pulled_one(pulled: int, spans: list[float],
                                                                  moving: list[int], case: str) -> None:
    assert moving_carts(pulled, spans) == moving
    assert lab_case(pulled, spans) == case


def test_the_held_ratio_is_the_boundary() -> None:
    assert moving_carts(1, [0.1, HELD_RATIO * 0.1]) == [1, 2]
    assert moving_carts(1, [0.1, 0.999 * HELD_RATIO * 0.1]) == [1]


def test_no_pulled_cart_or_one_encoder() -> None:
    assert moving_carts(None, [0.1, 0.1]) is None
    assert moving_carts(2, [0.1]) is None
    assert moving_carts(1, [0.1]) == [1]
    assert lab_case(1, [0.1]) is None


def test_a_configured_held_ratio_moves_the_boundary() -> None:
    # the detector settles a run on the carts this rule calls moving, with its `held_ratio`
    # setting, and the pipeline states the same carts in the run's metadata
    assert moving_carts(1, [0.1, 0.3 * 0.1], held_ratio=0.5) == [1]
    assert lab_case(1, [0.1, 0.3 * 0.1], held_ratio=0.5) == "cart1"
    assert moving_carts(1, [0.1, 0.3 * 0.1]) == [1, 2]
