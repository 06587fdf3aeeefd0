"""Display decimation of live samples: what the page plots, never what is recorded.

A bench streams `SampleBatch`es (e.g. 20 samples every 20 ms at 1 kHz). The page needs a
few hundred points per second to draw a smooth trace, so each bench keeps every k-th
sample, `k = max(1, round(rate_hz / display_hz))`, with a phase carried across batches so
the kept samples stay evenly spaced in time. A missing second channel is sent as null
(JSON has no NaN). The rate is read from the batch itself,
`rate_hz = (n - 1) / (t_ns[-1] - t_ns[0]) * 1e9`.

`History` keeps the last 30 s of what was sent, so that a page that opens shows the recent
past at once (in its snapshot) and then streams.

Pure: no clock, no I/O, no Zenoh. The recording (MCAP) never passes through here.
"""

from __future__ import annotations

import math
from collections import deque
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


#: Seconds of display samples a page gets when it opens (the widest plot window).
HISTORY_S = 30.0


class History:
    """The last `seconds` of display samples of one bench, bounded, for pages that open late.

    Holds at most ``ceil(display_hz * seconds) + 1`` points (a 30 s window at 250 points/s:
    7501 points per cart, about 0.2 MB of JSON) and drops points older than `seconds`
    before the newest; a clock that jumps back by more than 1 s (a restarted daq) starts
    it afresh, as the page does.
    """

    def __init__(self, display_hz: float = DEFAULT_DISPLAY_HZ, seconds: float = HISTORY_S) -> None:
        if not (display_hz > 0 and seconds > 0):
            raise ValueError(f"history: expected display_hz > 0 and seconds > 0, got "
                             f"{display_hz!r} and {seconds!r}")
        self.seconds = seconds
        self.capacity = math.ceil(display_hz * seconds) + 1
        self.t_s: deque[float] = deque(maxlen=self.capacity)
        self.pos1_m: deque[float] = deque(maxlen=self.capacity)
        self.pos2_m: deque[float | None] = deque(maxlen=self.capacity)
        self.has_pos2 = False

    def extend(self, kept: DecimatedSamples) -> None:
        if not kept.t_s:
            return
        if self.t_s and kept.t_s[0] < self.t_s[-1] - 1.0:
            for column in (self.t_s, self.pos1_m, self.pos2_m):    # a restarted daq
                column.clear()
        pos2 = kept.pos2_m if kept.pos2_m is not None else [None] * len(kept.t_s)
        self.has_pos2 = self.has_pos2 or kept.pos2_m is not None
        self.t_s.extend(kept.t_s)
        self.pos1_m.extend(kept.pos1_m)
        self.pos2_m.extend(pos2)
        oldest = self.t_s[-1] - self.seconds
        while self.t_s and self.t_s[0] < oldest:
            self.t_s.popleft()
            self.pos1_m.popleft()
            self.pos2_m.popleft()

    def as_event(self, bench: str) -> dict[str, object]:
        """The same shape as a `samples` event (`n_raw` 0: these samples were counted)."""
        return {"bench": bench, "t_s": list(self.t_s), "pos1_m": list(self.pos1_m),
                "pos2_m": list(self.pos2_m) if self.has_pos2 else None, "n_raw": 0}
