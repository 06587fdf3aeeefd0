"""Unwrapping of the device clock and sequence counter: pure, no I/O, no host clock.

The `cartlab` firmware stamps each line with `t_us`, a u32 microsecond clock that wraps
every 2**32 us (~71.6 min), and `seq`, a u32 line counter. `Timeline.push(seq, t_us)`
turns them into a continuous int64 device time in nanoseconds and counts what went wrong:

- clock: `dt = (t_us - t_prev) mod 2**32`; a forward step (`dt < 2**31`) is accepted,
  crossing zero counts a wrap. A backward step (`dt >= 2**31`: device reset, garbage
  that passed the checksum) counts `clock_backwards` and the time base is re-anchored so
  the output stays increasing (the sample is placed one typical period after the last).
- seq: `ds = (seq - seq_prev) mod 2**32`; `ds == 1` is normal, `ds == 0` a duplicate,
  `1 < ds < 2**31` a gap of `ds - 1` lost lines, else a counter reset (`seq_resets`).
- without a sequence counter (`csv`, `ecp`) and with `nominal_period_us` known, a clock
  step of more than 1.5 periods counts `round(dt / period) - 1` lost lines.
- with a sequence counter, a clock step outside [0.5, 1.5] x `ds` periods counts
  `clock_jumps` (anomaly "clock_jump"; the device time is kept as sent). The period is
  `nominal_period_us` when set (update it when an `$I` line gives a new rate), else the
  last step with `ds == 1` (a rate change then costs one flagged step).

For dialects whose time does not wrap pass `clock_bits=None`.
"""

from __future__ import annotations

from dataclasses import dataclass

_SEQ_MOD = 1 << 32


@dataclass(frozen=True, slots=True)
class TimelineStep:
    """One pushed sample: its unwrapped device time and what the step revealed."""

    t_ns: int
    lost: int = 0
    duplicate: bool = False
    anomaly: str | None = None   # "clock_backwards", "clock_jump", "seq_reset" or None


@dataclass(slots=True)
class TimelineCounters:
    samples: int = 0
    lost_lines: int = 0
    seq_gaps: int = 0
    duplicates: int = 0
    seq_wraps: int = 0
    seq_resets: int = 0
    clock_wraps: int = 0
    clock_backwards: int = 0
    clock_jumps: int = 0


class Timeline:
    """Stateful unwrapper; feed it every data frame in arrival order."""

    def __init__(self, clock_bits: int | None = 32, nominal_period_us: float | None = None) -> None:
        self.counters = TimelineCounters()
        self._clock_mod = None if clock_bits is None else 1 << clock_bits
        self.nominal_period_us = nominal_period_us
        self._last_raw_us: int | None = None
        self._last_us = 0            # last unwrapped time, us
        self._last_step_us = 0       # last accepted forward step, us
        self._last_seq: int | None = None
        self._learned_period_us: int | None = None

    def push(self, seq: int | None, t_us: int) -> TimelineStep:
        self.counters.samples += 1
        lost, duplicate, anomaly = self._seq_step(seq)
        if self._last_raw_us is None:
            self._last_raw_us = t_us
            self._last_us = t_us
            return TimelineStep(t_us * 1000, lost, duplicate, anomaly)
        step_us = self._clock_step(t_us)
        if step_us is None:
            anomaly = anomaly or "clock_backwards"
            step_us = self._typical_step_us()
        else:
            if seq is None and lost == 0:
                lost = self._lost_by_clock(step_us)
            elif seq is not None and anomaly is None and not duplicate:
                anomaly = self._check_jump(step_us, lost + 1)
            if step_us > 0:
                self._last_step_us = step_us
        self._last_raw_us = t_us
        self._last_us += step_us
        return TimelineStep(self._last_us * 1000, lost, duplicate, anomaly)

    def _seq_step(self, seq: int | None) -> tuple[int, bool, str | None]:
        if seq is None:
            return 0, False, None
        last, self._last_seq = self._last_seq, seq
        if last is None:
            return 0, False, None
        ds = (seq - last) % _SEQ_MOD
        if seq < last and ds < _SEQ_MOD // 2:
            self.counters.seq_wraps += 1
        if ds == 1:
            return 0, False, None
        if ds == 0:
            self.counters.duplicates += 1
            return 0, True, None
        if ds < _SEQ_MOD // 2:
            self.counters.seq_gaps += 1
            self.counters.lost_lines += ds - 1
            return ds - 1, False, None
        self.counters.seq_resets += 1
        return 0, False, "seq_reset"

    def _clock_step(self, t_us: int) -> int | None:
        """Forward step in us, or None for a backward jump."""
        assert self._last_raw_us is not None
        if self._clock_mod is None:
            step = t_us - self._last_raw_us
            if step < 0:
                self.counters.clock_backwards += 1
                return None
            return step
        step = (t_us - self._last_raw_us) % self._clock_mod
        if step >= self._clock_mod // 2:
            self.counters.clock_backwards += 1
            return None
        if t_us < self._last_raw_us:
            self.counters.clock_wraps += 1
        return step

    def _check_jump(self, step_us: int, seq_step: int) -> str | None:
        """A clock step far from `seq_step` periods (garbage that passed the checksum, a glitch)."""
        period = self.nominal_period_us or self._learned_period_us
        if seq_step == 1 and not self.nominal_period_us:
            self._learned_period_us = step_us
        if not period or 0.5 * seq_step * period <= step_us <= 1.5 * seq_step * period:
            return None
        self.counters.clock_jumps += 1
        return "clock_jump"

    def _typical_step_us(self) -> int:
        if self.nominal_period_us:
            return max(1, round(self.nominal_period_us))
        return max(1, self._last_step_us)

    def _lost_by_clock(self, step_us: int) -> int:
        period = self.nominal_period_us
        if not period or step_us <= 1.5 * period:
            return 0
        lost = round(step_us / period) - 1
        self.counters.seq_gaps += 1
        self.counters.lost_lines += lost
        return lost
