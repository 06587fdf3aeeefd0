"""The blocked cross-validation's held-out blocks reach into the motion: a dry-friction cart
that sticks early in a long record (a held cart wandering on) must not leave every held-out
block in the stuck tail, where an effect of the motion cannot show.

The records are built from their description: a Coulomb-damped ring (its amplitude falls by
4 F / wn² per cycle until it sticks) followed by a still tail read with white noise.
"""

from __future__ import annotations

import numpy as np
import pytest

from ident.diagnose.fitting import BLOCKS, block_edges, held_out_samples, motion_end


def coulomb_ring(rng: np.random.Generator, n: int, stop_share: float) -> tuple[np.ndarray, int]:
    """(n, 1) readings of a ring that sticks after `stop_share` of the record, and the sample
    where it sticks."""
    wn = rng.uniform(5.0, 20.0)
    stop = int(stop_share * n)
    cycles = rng.uniform(3.0, 20.0)
    t = np.arange(n) * (cycles * 2 * np.pi / wn) / stop
    a0 = rng.uniform(0.03, 0.15)
    amp = np.maximum(a0 * (1.0 - t / t[stop]), 0.0)
    rest = rng.uniform(-0.2, 0.2) * a0 / cycles   # where it sticks: within the last swing
    x = rest + amp * np.cos(wn * t)
    x[stop:] = x[stop]
    y = x + rng.normal(0.0, rng.uniform(5e-6, 2e-4), n)
    return y[:, None], stop


@pytest.mark.parametrize("seed", range(6))
def test_the_held_out_blocks_reach_into_the_motion_when_the_cart_sticks_early(seed: int) -> None:
    rng = np.random.default_rng([seed, 77])
    n = int(rng.integers(300, 2000))
    y, stop = coulomb_ring(rng, n, rng.uniform(0.04, 0.15))
    edges = block_edges(y)
    assert edges.size == BLOCKS + 1 and edges[-1] == n and np.all(np.diff(edges) > 0)
    # the anchor is the first sixth of the motion (of the record's first sixth at least): the
    # rest of the motion is held out, where equal sixths of the record held out only the tail
    moving = max(stop, n // 6)
    assert motion_end(y) <= moving + 1
    assert n // 36 - 1 <= edges[0] <= moving // 6 + 1
    assert edges[0] < stop
    # the still tail keeps blocks of equal length (a slow drift of the rest shows there)
    assert np.ptp(np.diff(edges)) <= 1
    assert held_out_samples(y).sum() == n - edges[0]


@pytest.mark.parametrize("seed", range(4))
def test_a_record_that_moves_to_its_end_keeps_sixths_of_equal_time(seed: int) -> None:
    rng = np.random.default_rng([seed, 78])
    n = int(rng.integers(300, 2000))
    t = np.linspace(0.0, 10.0, n)
    y = (0.05 * np.exp(-0.1 * t) * np.cos(rng.uniform(5.0, 20.0) * t) + rng.normal(0.0, 1e-5, n))[:, None]
    assert motion_end(y) >= n - n // 50
    assert np.all(np.abs(block_edges(y) - np.linspace(0, n, BLOCKS + 2)[1:]) <= n // 50 + 1)
