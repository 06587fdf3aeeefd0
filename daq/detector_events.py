"""The release detector's settings, the events it emits (`daq.detector`) and its kept samples."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt

from daq.errors import DaqValueError


@dataclass(frozen=True, slots=True)
class DetectorSettings:
    """Thresholds of the release detector (recorded in every run's metadata)."""

    still_band_m: float = 0.0015
    still_s: float = 0.3
    fire_m: float = 0.003
    fit_post_s: float = 0.04
    fit_min_post_samples: int = 4
    fit_lookback_s: float = 0.12
    fit_min_lookback_samples: int = 5
    fit_powers: tuple[int, ...] = (2, 3)
    min_accel_m_s2: float = 2.5
    rest_margin_m: float = 0.02
    confirm_m: float = 0.015
    settle_band_m: float = 0.002
    settle_s: float = 1.0
    max_run_s: float = 60.0
    pre_trigger_s: float = 0.5
    max_hole_s: float = 0.05
    first_release_confirm_s: float = 2.5
    ring_min_swing_m: float = 0.02
    ring_max_half_s: float = 0.8
    ring_half_ratio: float = 1.5
    ring_grow: float = 1.15
    ring_fit_max_rel: float = 0.05
    held_ratio: float = 0.2

    def __post_init__(self) -> None:
        for name in ("still_band_m", "still_s", "fire_m", "confirm_m", "fit_post_s", "fit_lookback_s", "rest_margin_m",
                     "min_accel_m_s2", "settle_band_m", "settle_s", "max_run_s", "max_hole_s",
                     "first_release_confirm_s", "ring_min_swing_m", "ring_max_half_s", "ring_half_ratio",
                     "ring_grow", "ring_fit_max_rel", "held_ratio"):
            if not getattr(self, name) > 0:
                raise DaqValueError(f"detector {name}", "> 0", getattr(self, name))
        if self.pre_trigger_s < 0.5:
            raise DaqValueError("detector pre_trigger_s", ">= 0.5 s", self.pre_trigger_s)
        if self.confirm_m <= self.fire_m:
            raise DaqValueError("detector confirm_m", f"> fire_m ({self.fire_m})", self.confirm_m)
        if self.fire_m <= self.still_band_m:
            raise DaqValueError("detector fire_m", f"> still_band_m ({self.still_band_m})", self.fire_m)
        if 2 not in self.fit_powers or any(p < 1 for p in self.fit_powers):
            raise DaqValueError("detector fit_powers", "powers >= 1 including 2", self.fit_powers)

    def as_metadata(self) -> dict[str, float | int | str]:
        out: dict[str, float | int | str] = {}
        for key, value in asdict(self).items():
            out[key] = ",".join(str(v) for v in value) if isinstance(value, tuple) else value
        return out


@dataclass(frozen=True, slots=True)
class Armed:
    t_s: float
    hold_pos: tuple[float, ...]
    #: the channels held still (a cart held while the other swings is armed alone); None: every one
    watched: tuple[int, ...] | None = None


@dataclass(frozen=True, slots=True)
class Released:
    """A release: `t_release_s` back-dated, `t_trigger_s` the threshold crossing."""

    t_release_s: float
    t_trigger_s: float
    t_confirmed_s: float
    channel: int
    accel_m_s2: float
    hold_pos: tuple[float, ...]


@dataclass(frozen=True, slots=True)
class Rejected:
    t_s: float
    accel_m_s2: float
    reason: str


@dataclass(frozen=True, slots=True)
class Settled:
    t_s: float
    reason: Literal["still", "max_run", "handled"]


@dataclass(frozen=True, slots=True)
class Disarmed:
    t_s: float


Event = Armed | Released | Rejected | Settled | Disarmed


@dataclass(frozen=True, slots=True)
class Samples:
    """The detector's kept samples: times `t` (N,) s and positions `pos` (N, C) m, oldest first."""

    t: npt.NDArray[np.float64]
    pos: npt.NDArray[np.float64]

    @classmethod
    def of(cls, history: list[tuple[float, tuple[float, ...]]]) -> Samples:
        t = np.fromiter((h[0] for h in history), dtype=np.float64, count=len(history))
        pos = np.array([h[1] for h in history], dtype=np.float64).reshape(len(history), -1)
        return cls(t, pos)
