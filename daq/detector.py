"""The release detector: a pure state machine fed with (t_s, positions) samples.

    idle --(every cart within ±still_band_m of an anchor for still_s)--> armed
    armed --(a cart leaves its hold by > fire_m)--> candidate (collecting the fit window)
    candidate --(initial-parabola fit says: sudden acceleration ≥ min_accel)--> released
    candidate --(otherwise: slow hand motion, a glitch)--> idle
    released --(every cart still within ±settle_band_m for settle_s, or max_run_s)--> settled
    settled --> idle (on the next sample)

Holes in the data. A hole shorter than `max_hole_s` (a line lost to corruption) is only
missing samples: the still window and the onset fit use the samples' own times, so `hole()`
keeps the state. A longer hole (an unplugged port) may hide a release or a move of the
hand, so it forgets the hold (`reset()`); a run in progress is always left alone.

Release instant. The hand lets go at t0; from rest, the cart's position is then
`x(t) = x0 + ½ a (t - t0)² + b (t - t0)³ + …` (spring force step; the cubic term carries
damping and the first change of the force). The threshold crossing comes 10–40 ms late,
so t0 is back-dated by least squares on the samples around the crossing with the piecewise
model `y(t) = x0 + Σ_k c_k max(t - t0, 0)^k`, `k ∈ fit_powers`: linear in (x0, c_k) for a
given t0, t0 found by a grid search (coarse at the sample period, then fine). The hold
samples before t0 pin x0; the samples after pin the curvature. Only the channel that moved
most is fitted.

A release is told from slow hand motion by the fitted initial acceleration `a = 2 c_2`
(a spring released from 0.15 m starts at several m/s², a hand pulling over ≳ 1 s below
1 m/s²) and by the cart still being away from its hold at the end of the fit window; from
a fast pull (a yank) by its direction: a released cart moves toward its rest (where the
carts settled after the last run, or were first still after start-up), a pulled one leaves it.

Start-up. Until the carts have settled once, the rest is only where they were first still,
which may be a hold: a daq started while a student holds the cart pulled. A fast departure
judged against that provisional rest is then rejected ("pulled from rest", "pulled away from
rest") but followed: a released
cart swings through its rest and comes back (it reverses by ≥ `confirm_reversal` of an
excursion ≥ `confirm_min_excursion_m`) without ever being still, a yanked cart is held
still at its new place. A reversal within `first_release_confirm_s` of the trigger turns
the departure into the release (back-dated as usual, `t_confirmed_s` later); being still
(arming) or the deadline forgets it. Releases whose half period exceeds that deadline
(springs softer than ~0.4 Hz) are still missed when daq starts during the hold.

Positions may be zeroed or not: only motion relative to the hold matters. Pure: no clocks,
no I/O; time comes with the samples (float seconds, continuous).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace
from typing import Literal

import numpy as np
import numpy.typing as npt

from daq.errors import DaqValueError

State = Literal["idle", "armed", "released", "settled"]
METHOD = "piecewise-polynomial-onset-fit"


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
    settle_band_m: float = 0.002
    settle_s: float = 1.0
    max_run_s: float = 60.0
    pre_trigger_s: float = 0.5
    max_hole_s: float = 0.05
    first_release_confirm_s: float = 1.2
    confirm_reversal: float = 0.25
    confirm_min_excursion_m: float = 0.02

    def __post_init__(self) -> None:
        for name in ("still_band_m", "still_s", "fire_m", "fit_post_s", "fit_lookback_s", "rest_margin_m",
                     "min_accel_m_s2", "settle_band_m", "settle_s", "max_run_s", "max_hole_s",
                     "first_release_confirm_s", "confirm_reversal", "confirm_min_excursion_m"):
            if not getattr(self, name) > 0:
                raise DaqValueError(f"detector {name}", "> 0", getattr(self, name))
        if self.pre_trigger_s < 0.5:
            raise DaqValueError("detector pre_trigger_s", ">= 0.5 s", self.pre_trigger_s)
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
    reason: Literal["still", "max_run"]


@dataclass(frozen=True, slots=True)
class Disarmed:
    t_s: float


Event = Armed | Released | Rejected | Settled | Disarmed


@dataclass(slots=True)
class _Pending:
    """A fast departure from the provisional rest, followed until it proves a release."""

    release: Released        # what it is if confirmed (t_confirmed_s set then)
    direction: float         # +1 or -1: the sign of the departure on `release.channel`
    hold_m: float            # the channel's position at the hold
    excursion_m: float = 0.0


@dataclass(frozen=True, slots=True)
class OnsetFit:
    t0_s: float
    accel_m_s2: float
    rms_m: float


class ReleaseDetector:
    """Feed samples in time order with `feed(t_s, positions)`; read events from its return."""

    def __init__(self, settings: DetectorSettings | None = None) -> None:
        self.settings = settings or DetectorSettings()
        self.state: State = "idle"
        keep_s = self.settings.fit_lookback_s + self.settings.fit_post_s + 1.0
        self._keep_s = keep_s
        self._history: deque[tuple[float, tuple[float, ...]]] = deque()
        self._anchor: tuple[float, ...] | None = None
        self._anchor_t = 0.0
        self._rest: tuple[float, ...] | None = None
        self._rest_settled = False     # the rest was seen settled (not only first still)
        self._pending: _Pending | None = None
        self._hold: tuple[float, ...] = ()
        self._trigger_t: float | None = None
        self._trigger_channel = 0
        self._post_samples = 0
        self._release_t = 0.0

    # --- public -----------------------------------------------------------------------------
    def feed(self, t_s: float, pos: Sequence[float]) -> list[Event]:
        """One sample: device time in seconds (continuous) and one position per channel (m)."""
        sample = pos if type(pos) is tuple else tuple(pos)
        history = self._history
        history.append((t_s, sample))
        horizon = t_s - self._keep_s
        while history[0][0] < horizon:
            history.popleft()
        if self.state == "idle":
            if self._pending is not None:
                confirmed = self._follow_pending(t_s, sample)
                if confirmed:
                    return confirmed
            return self._feed_idle(t_s, sample)
        if self.state == "armed":
            return self._feed_armed(t_s, sample)
        if self.state == "released":
            return self._feed_released(t_s, sample)
        self.state = "idle"  # settled lasts one sample
        self._restart_anchor(t_s, sample)
        return []

    def arm_now(self, t_s: float, pos: Sequence[float]) -> list[Event]:
        """Arm at `pos` at once (a command), unless a run is in progress."""
        if self.state == "released":
            return []
        self.state = "armed"
        self._trigger_t = None
        self._pending = None
        self._hold = tuple(pos)
        return [Armed(t_s, self._hold)]

    def hole(self, span_s: float) -> list[Event]:
        """Samples are missing: `span_s` between the samples either side of the hole (s).

        Up to `max_hole_s` (a few lost lines) nothing changes; a longer hole resets.
        """
        if span_s <= self.settings.max_hole_s:
            return []
        return self.reset()

    def reset(self) -> list[Event]:
        """Forget the hold (e.g. after a gap in the data); a run in progress is left alone."""
        if self.state == "released":
            return []
        self._trigger_t = None
        self._pending = None
        if self.state in ("armed", "settled"):
            self.state = "idle"
            self._anchor = None
            return [Disarmed(self._history[-1][0] if self._history else 0.0)]
        self._anchor = None
        return []

    # --- states -----------------------------------------------------------------------------
    def _still(self, t_s: float, sample: tuple[float, ...], band: float, duration_s: float) -> bool:
        """True once every channel stayed within ±band of the anchor for `duration_s`."""
        anchor = self._anchor
        if anchor is None or len(anchor) != len(sample):
            self._restart_anchor(t_s, sample)
            return False
        for x, a in zip(sample, anchor):
            if x - a > band or a - x > band:
                self._restart_anchor(t_s, sample)
                return False
        return t_s - self._anchor_t >= duration_s

    def _restart_anchor(self, t_s: float, sample: tuple[float, ...]) -> None:
        self._anchor = sample
        self._anchor_t = t_s

    def _feed_idle(self, t_s: float, sample: tuple[float, ...]) -> list[Event]:
        if not self._still(t_s, sample, self.settings.still_band_m, self.settings.still_s):
            return []
        self._hold = self._mean_since(self._anchor_t)
        if self._rest is None:
            self._rest = self._hold
        self._pending = None   # still: whatever left the provisional rest was held, not released
        self.state = "armed"
        return [Armed(t_s, self._hold)]

    def _mean_since(self, t0_s: float) -> tuple[float, ...]:
        """Mean position of the samples of the history from `t0_s` on (the still window)."""
        window = [h[1] for h in self._history if h[0] >= t0_s]
        return tuple(sum(column) / len(window) for column in zip(*window))

    def _feed_armed(self, t_s: float, sample: tuple[float, ...]) -> list[Event]:
        if self._trigger_t is None:
            fire_m = self.settings.fire_m
            for x, h in zip(sample, self._hold):   # the common case, every sample of a hold: still
                if x - h > fire_m or h - x > fire_m:
                    break
            else:
                return []
            self._trigger_t = t_s
            self._trigger_channel = self._channel_moved_most(sample)
            self._post_samples = 0
            return []
        self._post_samples += 1
        if (t_s - self._trigger_t < self.settings.fit_post_s
                or self._post_samples < self.settings.fit_min_post_samples):
            return []
        return [self._decide(t_s, sample)]

    def _decide(self, t_s: float, sample: tuple[float, ...]) -> Released | Rejected:
        trigger_t = self._trigger_t
        assert trigger_t is not None
        self._trigger_t = None
        channel = self._channel_moved_most(sample)
        hold = self._hold
        still_away = abs(sample[channel] - hold[channel]) > self.settings.fire_m
        fit = self._fit_onset(channel, trigger_t)
        direction = 1.0 if sample[channel] > hold[channel] else -1.0
        accel = fit.accel_m_s2 * direction if fit is not None else 0.0
        reason = ("fit failed" if fit is None else "came back" if not still_away
                  else "slow motion" if accel < self.settings.min_accel_m_s2
                  else self._away_from_rest(channel, direction))
        if reason:
            self.state = "idle"
            self._restart_anchor(t_s, sample)
            if reason.startswith("pulled") and not self._rest_settled and fit is not None:
                release = Released(fit.t0_s, trigger_t, t_s, channel, abs(fit.accel_m_s2), hold)
                self._pending = _Pending(release, direction, hold[channel])
            return Rejected(t_s, accel, reason)
        assert fit is not None
        return self._release(Released(fit.t0_s, trigger_t, t_s, channel, abs(fit.accel_m_s2), hold))

    def _release(self, release: Released) -> Released:
        self.state = "released"
        self._release_t = release.t_release_s
        self._anchor = None
        return release

    def _follow_pending(self, t_s: float, sample: tuple[float, ...]) -> list[Event]:
        """Confirm a departure from the provisional rest once the cart swings back (see module)."""
        pending = self._pending
        assert pending is not None
        settings = self.settings
        if t_s - pending.release.t_trigger_s > settings.first_release_confirm_s:
            self._pending = None
            return []
        moved = pending.direction * (sample[pending.release.channel] - pending.hold_m)
        if moved > pending.excursion_m:
            pending.excursion_m = moved
            return []
        if (pending.excursion_m < settings.confirm_min_excursion_m
                or pending.excursion_m - moved < settings.confirm_reversal * pending.excursion_m):
            return []
        self._pending = None
        self._rest = None   # it was a hold: the rest is where this run settles
        return [self._release(replace(pending.release, t_confirmed_s=t_s))]

    def _away_from_rest(self, channel: int, direction: float) -> str:
        """Why a fast departure cannot be a release, judged against the rest position, or ''.

        A released cart moves toward its rest; a cart that leaves its rest, or moves away
        from it, is pulled by a hand, however fast. The rest is where the carts settled after
        the last run (at start-up: where they were first still).
        """
        rest = self._rest
        if rest is None or len(rest) != len(self._hold):
            return ""
        offset = rest[channel] - self._hold[channel]
        if abs(offset) <= self.settings.rest_margin_m:
            return "pulled from rest"
        if offset * direction < 0:
            return "pulled away from rest"
        return ""

    def _feed_released(self, t_s: float, sample: tuple[float, ...]) -> list[Event]:
        if t_s - self._release_t >= self.settings.max_run_s:
            self.state = "settled"
            return [Settled(t_s, "max_run")]
        if self._still(t_s, sample, self.settings.settle_band_m, self.settings.settle_s):
            self.state = "settled"
            self._rest = self._mean_since(self._anchor_t)
            self._rest_settled = True
            return [Settled(t_s, "still")]
        return []

    def _channel_moved_most(self, sample: tuple[float, ...]) -> int:
        moved = [abs(x - h) for x, h in zip(sample, self._hold)]
        return max(range(len(moved)), key=moved.__getitem__)

    # --- back-dating --------------------------------------------------------------------------
    def _fit_onset(self, channel: int, trigger_t: float) -> OnsetFit | None:
        settings = self.settings
        times = np.fromiter((h[0] for h in self._history), dtype=float, count=len(self._history))
        before = np.flatnonzero(times < trigger_t)
        if before.size < 2:
            return None
        n_back = max(settings.fit_min_lookback_samples,
                     int(np.count_nonzero(times[before] >= trigger_t - settings.fit_lookback_s)))
        first = int(before[max(0, before.size - n_back)])
        window = list(self._history)[first:]
        t = np.array([w[0] for w in window]) - trigger_t
        y = np.array([w[1][channel] for w in window]) - self._hold[channel]
        return fit_onset(t, y, settings.fit_powers, trigger_offset_s=trigger_t)


def fit_onset(t: npt.NDArray[np.float64], y: npt.NDArray[np.float64], powers: Sequence[int],
              trigger_offset_s: float = 0.0) -> OnsetFit | None:
    """Least-squares onset of `y = x0 + Σ c_k max(t - t0, 0)^k` (shapes (N,)).

    t0 is searched on [t[0], t[-1]] by a grid at the median sample spacing, then refined on a
    grid 50× finer around the best point. Returns t0 (+ `trigger_offset_s`), `a = 2 c_2` and
    the residual RMS, or None when there are too few samples.
    """
    if t.size < len(powers) + 3:
        return None
    step = float(np.median(np.diff(t)))
    if not step > 0:
        return None
    coarse = np.arange(t[0], t[-1], step)
    best = _best_onset(t, y, powers, coarse)
    fine = np.linspace(best - step, best + step, 101)
    best = _best_onset(t, y, powers, fine)
    coefs, rms = _solve_at(t, y, powers, np.array([best]))
    span = float(t[-1] - t[0])
    accel = 2.0 * float(coefs[0, 1 + list(powers).index(2)]) / span ** 2
    return OnsetFit(best + trigger_offset_s, accel, float(rms[0]))


def _best_onset(t: npt.NDArray[np.float64], y: npt.NDArray[np.float64], powers: Sequence[int],
                candidates: npt.NDArray[np.float64]) -> float:
    _, rms = _solve_at(t, y, powers, candidates)
    return float(candidates[int(np.argmin(rms))])


def _solve_at(t: npt.NDArray[np.float64], y: npt.NDArray[np.float64], powers: Sequence[int],
              candidates: npt.NDArray[np.float64]) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Batched linear least squares for every candidate t0: coefficients (G, 1+P) and RMS (G,).

    τ is scaled by the window span (τ/T) for conditioning: c_k(unscaled) = c_k / T^k.
    """
    span = float(t[-1] - t[0])
    tau = np.maximum(t[None, :] - candidates[:, None], 0.0) / span      # (G, N)
    columns = [np.ones_like(tau)] + [tau ** p for p in powers]
    design = np.stack(columns, axis=2)                                  # (G, N, 1+P)
    design_t = design.transpose(0, 2, 1)                                # (G, 1+P, N)
    normal = design_t @ design                                          # batched BLAS, not einsum
    rhs = design_t @ y                                                  # (G, 1+P)
    ridge = 1e-12 * np.eye(normal.shape[1])
    coefs = np.asarray(np.linalg.solve(normal + ridge, rhs[..., None])[..., 0], dtype=np.float64)   # (G, 1+P)
    residual = y[None, :] - (design @ coefs[..., None])[..., 0]
    rms: npt.NDArray[np.float64] = np.sqrt(np.mean(residual ** 2, axis=1))
    return coefs, rms
