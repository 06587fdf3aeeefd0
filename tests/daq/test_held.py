"""Held or free from amplitudes (`daq.held`), on spans and swings given directly or measured on
analytic motions."""

from __future__ import annotations

import numpy as np
import pytest

from daq.held import HELD_RATIO, PINNED_SPAN_M, SWING_BAND_M, Swings, lab_case, moving_carts, swings_of


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


def _swings(x: np.ndarray) -> Swings:
    return swings_of([x])[0]


def test_a_damped_ring_swings_by_its_second_half_period() -> None:
    # x = A e^{-σt} cos ωt: x' = 0 where tan ωt = -σ/ω, at t_k = (kπ - φ)/ω with φ = atan(σ/ω),
    # where |x| = A e^{-σ t_k} cos φ; each swing is the sum of two consecutive extremes
    t = np.linspace(0.0, 1.5, 30001)
    a, sigma, w = 0.04, 0.8, 2 * np.pi * 2.0
    swings = _swings(a * np.exp(-sigma * t) * np.cos(w * t))
    phi = np.arctan(sigma / w)
    ext = a * np.exp(-sigma * (np.arange(4) * np.pi - phi) / w) * np.cos(phi)
    assert swings.span_m == pytest.approx(a + ext[1], rel=1e-6)
    assert swings.second_m == pytest.approx(ext[1] + ext[2], rel=1e-6)


def test_one_move_of_a_hand_is_one_swing() -> None:
    # a held cart that follows 3 % of a 2 Hz ring and is moved 12 mm in 0.3 s by a hand: its span
    # is the move, its second swing the following
    t = np.linspace(0.0, 1.5, 1501)
    u = np.clip((t - 0.5) / 0.3, 0.0, 1.0)
    x = 0.03 * 0.04 * np.cos(2 * np.pi * 2.0 * t) + 0.012 * u * u * u * (10 - 15 * u + 6 * u * u)
    swings = _swings(x)
    assert swings.span_m > 0.012
    assert swings.second_m < 2 * 0.03 * 0.04 + 1e-9
    pulled = 0.04 * (1 + np.exp(-0.4))
    assert moving_carts(1, [pulled, swings.span_m]) == [1, 2]       # spanned: free
    assert moving_carts(1, [pulled, swings.span_m], swings_m=[pulled, swings.second_m]) == [1]


def test_wiggles_inside_the_band_are_no_turns() -> None:
    t = np.linspace(0.0, 1.0, 1001)
    x = 0.4 * SWING_BAND_M * np.sin(2 * np.pi * 7 * t) + 0.01 * t     # a ramp with small wiggles
    swings = _swings(x)
    assert swings.second_m == 0.0
    assert swings.span_m == pytest.approx(float(np.ptp(x)))
