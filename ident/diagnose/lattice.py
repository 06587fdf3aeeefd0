"""Staircase structure of a measurement: are the positions on a lattice offset + q·k?

An encoder reports whole counts, so every sample is `offset + q·k` exactly (up to float
rounding of the count-to-metre scale). The quantum is the smallest gap between distinct
measured values (adjacent levels are visited where the cart is slow), accepted only when
at least 99 % of the samples lie within 1 % of q from the lattice it defines. Continuous
(noisy, unquantised) data has a vanishing smallest gap and fails the test. No I/O here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

ON_LATTICE_FRACTION = 0.99
MIN_LEVELS = 5


@dataclass(frozen=True)
class Lattice:
    """`quantum_m` q, `offset_m` in [0, q), `coherence` mean cos(2π (y - offset)/q) ∈ [-1, 1]."""

    quantum_m: float
    offset_m: float
    coherence: float
    levels: int


def lattice_coherence(y: FloatArray, q: float, offset: float) -> float:
    return float(np.mean(np.cos(2 * np.pi * (y - offset) / q)))


def find_lattice(y: FloatArray) -> tuple[Lattice | None, float]:
    """The measurement lattice of all samples `y` (any shape), or None; and the coherence."""
    values = np.asarray(y, dtype=np.float64).ravel()
    levels = np.unique(values)
    if levels.size < MIN_LEVELS:
        return None, 0.0
    scale = float(np.max(np.abs(levels))) or 1.0
    gaps = np.diff(levels)
    gaps = gaps[gaps > 1e-9 * scale]
    if gaps.size == 0:
        return None, 0.0
    q = float(np.min(gaps))
    offset = float(np.mod(levels[0], q))
    r = (values - offset) / q
    frac = np.abs(r - np.round(r))
    coherence = lattice_coherence(values, q, offset)
    used = np.unique(np.round(r)).size
    if np.mean(frac < 0.01) < ON_LATTICE_FRACTION or used < MIN_LEVELS or q < 1e-7 * scale:
        return None, coherence
    # the gaps are multiples of q: refine q as the least-squares lattice spacing
    k = np.round((levels - levels[0]) / q)
    if k[-1] > 0:
        q = float(np.dot(k, levels - levels[0]) / np.dot(k, k))
    return Lattice(q, float(np.mod(levels[0], q)), lattice_coherence(values, q, offset), used), coherence
