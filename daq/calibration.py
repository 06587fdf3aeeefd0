"""Counts → metres, per-channel sign and zeroing. Pure: no I/O, no clocks.

    pos_m[c] = sign[c] * (raw[c] - zero_offset_raw[c]) / counts_per_m

`raw` is what the decoder produced (encoder counts for `cartlab`/`ecp`, metres for `csv`,
where `counts_per_m` is 1). Zeroing stores the current raw values as offsets, so that every
cart reads 0 where it is now (the "held" frame of the lab).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

from daq.errors import DaqValueError


@dataclass(frozen=True, slots=True)
class Calibration:
    """Scale, signs and zero offsets of one stream (`n_channels` = len(signs))."""

    counts_per_m: float
    signs: tuple[int, ...] = (1, 1)
    zero_offsets_raw: tuple[float, ...] = (0.0, 0.0)

    def __post_init__(self) -> None:
        if not (math.isfinite(self.counts_per_m) and self.counts_per_m > 0):
            raise DaqValueError("counts_per_m", "a finite number > 0", self.counts_per_m)
        if any(s not in (1, -1) for s in self.signs):
            raise DaqValueError("signs", "each +1 or -1", self.signs)
        if len(self.zero_offsets_raw) != len(self.signs):
            raise DaqValueError("zero_offsets_raw", f"{len(self.signs)} values (one per channel)",
                                self.zero_offsets_raw)

    @property
    def n_channels(self) -> int:
        return len(self.signs)

    def with_channels(self, n_channels: int) -> Calibration:
        """The same calibration for `n_channels` (1 or 2) channels."""
        if n_channels not in (1, 2):
            raise DaqValueError("n_channels", "1 or 2", n_channels)
        signs = ((*self.signs, 1, 1))[:n_channels]
        offsets = ((*self.zero_offsets_raw, 0.0, 0.0))[:n_channels]
        return replace(self, signs=signs, zero_offsets_raw=offsets)

    def with_counts_per_m(self, counts_per_m: float) -> Calibration:
        return replace(self, counts_per_m=counts_per_m)

    def zeroed_at(self, raw: Sequence[float]) -> Calibration:
        """Zero at the raw values `raw` (one per channel): they will read 0 m."""
        if len(raw) != self.n_channels:
            raise DaqValueError("raw values to zero at", f"{self.n_channels} values", tuple(raw))
        return replace(self, zero_offsets_raw=tuple(float(r) for r in raw))

    def metres(self, raw: Sequence[float]) -> tuple[float, ...]:
        """Zeroed positions in metres of one sample."""
        scale = self.counts_per_m
        return tuple(s * (r - z) / scale for s, r, z in zip(self.signs, raw, self.zero_offsets_raw))

    def unzeroed_metres(self, raw: Sequence[float]) -> tuple[float, ...]:
        """Positions in metres without the zero offsets (what the detector watches)."""
        scale = self.counts_per_m
        return tuple(s * r / scale for s, r in zip(self.signs, raw))

    def linear_terms(self) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """(gains, offsets_m) with `unzeroed = raw * gain` and `pos_m = unzeroed - offset_m`."""
        gains = tuple(s / self.counts_per_m for s in self.signs)
        return gains, tuple(g * z for g, z in zip(gains, self.zero_offsets_raw))

    def raw_of_unzeroed(self, unzeroed_m: Sequence[float]) -> tuple[float, ...]:
        """Inverse of `unzeroed_metres`: raw values of positions in metres."""
        scale = self.counts_per_m
        return tuple(s * x * scale for s, x in zip(self.signs, unzeroed_m))
