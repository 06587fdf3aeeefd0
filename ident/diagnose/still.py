"""Outputs that never move, found before the diagnosis fits anything.

A column of positions that reads one value throughout (a cart pinned or unplugged, an
encoder that was never connected), one value but for a few glitches, or nothing at all
(NaN), carries no response to fit: its fit % would be 100 (1 - |e| / |y - mean(y)|) with a
zero denominator (-inf), and a glitch in it could even pass for the largest swing. Such a
column is dropped here, with the reason, and the diagnosis runs on the others; when none is
left, or fewer than the carts asked for, it refuses with what it found.

"Moves" is counted in samples, not in metres: an output moves when at least
`MIN_MOVING_SAMPLES` of its finite samples leave its median by more than `STILL_TOL_M`.
A held cart that wanders by a few encoder counts moves by this rule (its motion is an input
of the one-cart model); a constant with a spike or two does not. Pure numpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ident.errors import IdentValueError

FloatArray = NDArray[np.float64]

#: Fewest samples off the median for an output to count as moving (glitches are fewer).
MIN_MOVING_SAMPLES = 5
#: A sample this close to the median (m) is at it (far below any encoder's count).
STILL_TOL_M = 1e-12


@dataclass(frozen=True)
class Outputs:
    """The columns kept (`y` (N, k), their indices `kept` in the input) and, per dropped
    column index, why it was dropped."""

    y: FloatArray
    kept: tuple[int, ...]
    dropped: dict[int, str]

    def note(self) -> str:
        """One sentence for the report ('' when nothing was dropped); outputs numbered from 1."""
        return "; ".join(f"output {j + 1} {why}: not fitted" for j, why in sorted(self.dropped.items()))


def why_still(column: FloatArray) -> str | None:
    """Why `column` (N,) never moves, or None when it moves."""
    finite = column[np.isfinite(column)]
    if finite.size < MIN_MOVING_SAMPLES:
        return f"has no finite readings ({column.size - finite.size} of {column.size} samples NaN or inf)"
    level = float(np.median(finite))
    off = int(np.count_nonzero(np.abs(finite - level) > STILL_TOL_M))
    if off >= MIN_MOVING_SAMPLES:
        return None
    return (f"never moves (constant at {level:.6g} m"
            + (f" but for {off} sample{'s' if off > 1 else ''}" if off else "") + ")")


def moving_outputs(y: FloatArray, carts: int | None) -> Outputs:
    """Drop the columns of `y` (N, n_out) that never move (`why_still`).

    Refuses (`IdentValueError`) when no column moves, and when `carts` names more carts than
    the columns left while `y` had a column per cart (a pinned second cart makes no chain).
    """
    dropped = {j: why for j in range(y.shape[1]) if (why := why_still(y[:, j])) is not None}
    kept = tuple(j for j in range(y.shape[1]) if j not in dropped)
    found = "; ".join(f"output {j + 1} {why}" for j, why in sorted(dropped.items()))
    if not kept:
        raise IdentValueError("outputs", "motion in at least one output (a column that moves)", found)
    if carts is not None and y.shape[1] >= carts > len(kept):
        raise IdentValueError("carts", f"{carts} outputs that move (or carts={len(kept)})", found)
    return Outputs(y[:, list(kept)], kept, dropped)


__all__ = ["MIN_MOVING_SAMPLES", "STILL_TOL_M", "Outputs", "moving_outputs", "why_still"]
