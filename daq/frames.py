"""What the serial decoders produce: pure data, no I/O.

Every dialect decodes to `DataFrame`s (one per data line) and, for the `cartlab` dialect,
`InfoFrame`s. Positions stay in the dialect's raw unit (encoder counts for `cartlab` and
`ecp`, metres for `csv`): calibration and zeroing happen later, on the PC, in one place.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal, Protocol

Dialect = Literal["cartlab", "csv", "ecp"]
DIALECTS: tuple[Dialect, ...] = ("cartlab", "csv", "ecp")


@dataclass(frozen=True, slots=True)
class DataFrame:
    """One data line.

    `t_us` is the device clock as sent (for `cartlab` a u32 that wraps every ~71.6 min;
    for `csv`/`ecp` converted from seconds/milliseconds and not wrapping). `seq` is the
    device's u32 sequence counter when the dialect has one, else None. `drive` is the rig's
    drive command as sent, for a dialect that streams one (`ecp`: the line's `target` and
    `duty`; in open loop `target` is the duty's target, `4096·V/5`), else None.
    """

    seq: int | None
    t_us: int
    raw: tuple[float, ...]
    drive: tuple[float, float] | None = None


@dataclass(frozen=True, slots=True)
class InfoFrame:
    """`$I,<model>,<firmware>,<counts_per_m>,<rate_hz>*HH`."""

    model: str
    firmware: str
    counts_per_m: float
    rate_hz: float


Frame = DataFrame | InfoFrame


@dataclass(slots=True)
class DecodeCounters:
    """What the decoder saw and rejected. Never reset by the decoder itself."""

    lines: int = 0
    frames: int = 0
    info_frames: int = 0
    bad_checksum: int = 0
    torn: int = 0
    non_ascii: int = 0
    overlong: int = 0
    malformed: int = 0
    extra: dict[str, int] = field(default_factory=dict)

    @property
    def rejected(self) -> int:
        return self.bad_checksum + self.torn + self.non_ascii + self.overlong + self.malformed


class Decoder(Protocol):
    """Bytes in, frames out; keeps the unfinished tail between calls; never raises on data."""

    counters: DecodeCounters

    def feed(self, data: bytes) -> list[Frame]: ...
