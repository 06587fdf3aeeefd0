"""Display decimation of live samples: what the page plots, never what is recorded.

A bench streams `SampleBatch`es (e.g. 20 samples every 20 ms at 1 kHz). The page needs a
few hundred points per second to draw a smooth trace, so each bench keeps every k-th
sample, `k = max(1, round(rate_hz / display_hz))`, with a phase carried across batches so
the kept samples stay evenly spaced in time. A missing second channel is sent as null
(JSON has no NaN). The rate is read from the batch itself,
`rate_hz = (n - 1) / (t_ns[-1] - t_ns[0]) * 1e9`.

Pure: no clock, no I/O, no Zenoh. The recording (MCAP) never passes through here.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from schemas.daq import SampleBatch

#: Points per second per channel sent to the page by default.
DEFAULT_DISPLAY_HZ = 250.0


@dataclass
class DecimatedSamples:
    """Samples kept for display since the last `take()`: times in s, positions in m."""

    t_s: list[float] = field(default_factory=list)
    pos1_m: list[float] = field(default_factory=list)
    pos2_m: list[float | None] | None = None
    raw_count: int = 0

    def as_event(self, bench: str) -> dict[str, object]:
        return {"bench": bench, "t_s": self.t_s, "pos1_m": self.pos1_m,
                "pos2_m": self.pos2_m, "n_raw": self.raw_count}


class Decimator:
    """Keeps every k-th sample of one bench's stream for display (see module docstring)."""

    def __init__(self, display_hz: float = DEFAULT_DISPLAY_HZ) -> None:
        if not display_hz > 0:
            raise ValueError(f"display_hz: expected > 0, got {display_hz!r}")
        self.display_hz = display_hz
        self.stride = 1
        self._phase = 0
        self._pending = DecimatedSamples()
        self.total_raw = 0
        self.total_kept = 0

    def _update_stride(self, t_ns: list[int]) -> None:
        span_ns = t_ns[-1] - t_ns[0]
        if len(t_ns) < 2 or span_ns <= 0:
            return
        rate_hz = (len(t_ns) - 1) * 1e9 / span_ns
        self.stride = max(1, round(rate_hz / self.display_hz))

    def feed(self, batch: SampleBatch) -> None:
        """Add one batch; only every `stride`-th sample is kept."""
        n = len(batch.t_ns)
        if n == 0:
            return
        self._update_stride(batch.t_ns)
        pending = self._pending
        if batch.pos2_m is not None and pending.pos2_m is None:
            pending.pos2_m = [None] * len(pending.t_s)
        first = (-self._phase) % self.stride
        for i in range(first, n, self.stride):
            pending.t_s.append(batch.t_ns[i] * 1e-9)
            pending.pos1_m.append(batch.pos1_m[i])
            if pending.pos2_m is not None:
                pending.pos2_m.append(batch.pos2_m[i] if batch.pos2_m is not None else None)
        kept = len(range(first, n, self.stride))
        self._phase = (self._phase + n) % self.stride
        pending.raw_count += n
        self.total_raw += n
        self.total_kept += kept

    def take(self) -> DecimatedSamples | None:
        """The samples kept since the last call, or None when there are none."""
        pending = self._pending
        if pending.raw_count == 0:
            return None
        self._pending = DecimatedSamples()
        return pending
