"""The simulated encoder box: physics + hand + encoder + device clock + dialect + faults.

Pure core of `sim://`, driven by simulated time (no clock inside): the URL handler calls
`produce_until(t_s)` (real time) or `produce_bytes(n)` (as fast as read) and takes the
bytes from `pending`. Everything random comes from `seed` through separate streams
(noise, hand, faults), so enabling faults does not change the noise of the lines that
survive. `events` (hand script) and `faults` (what was done to which line) are the
ground truth for tests.

Device: sample `n` is taken at simulated time `t_n` (the rate can change with `$R`);
`counts_i = round(x_i counts_per_m + noise_counts N(0, 1))`;
`t_us = (clock0_us + round((t_n - t_boot) (1 + clock_ppm 1e-6) 1e6)) mod 2**32`;
`seq` counts every sample taken, sent or lost, modulo 2**32.

Disconnect (USB unplug) every `disconnect_every_s`: the lines of the next `disconnect_s`
are lost, reads on the old connection fail (in real time at once, the bytes not yet read
being lost too; as fast as read once the bytes made before the unplug are read). With real time the
device is back when that time has passed; as fast as read it is back after
`reopen_failures` failed `try_open` calls (time then jumps over the unplugged span).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import BinaryIO

import numpy as np

from daq.decode.cartlab import encode_data, encode_info, parse_host_command
from daq.decode.text import encode_csv, encode_csv_header, encode_ecp
from daq.sim.hand import CaseTiming, Hand, ScriptEvent
from daq.sim.options import SimOptionError, SimOptions
from daq.sim.student import StudentHand, StudentKnobs
from ident.physics.rig import ChainParams, ChainState, advance

_U32 = 1 << 32
_CORRUPTIONS = ("bitflip", "truncate", "nul", "non_ascii", "overlong")
_MIN_RATE_HZ, _MAX_RATE_HZ = 0.1, 20000.0


@dataclass
class RigStats:
    samples: int = 0
    lines_sent: int = 0
    bytes_sent: int = 0
    dropped: int = 0
    corrupted: int = 0
    garbage_bursts: int = 0
    lost_unplugged: int = 0
    disconnects: int = 0
    commands: int = 0
    bad_commands: int = 0
    faults: list[tuple[int, str]] = field(default_factory=list)   # (sample index, kind)


class _Blocks:
    """Draws from a generator in blocks (numpy per-scalar calls are slow)."""

    def __init__(self, rng: np.random.Generator, normal: bool, block: int = 4096) -> None:
        self.rng, self.normal, self.block = rng, normal, block
        self.values: list[float] = []
        self.pos = 0

    def next(self) -> float:
        if self.pos >= len(self.values):
            draw = self.rng.standard_normal(self.block) if self.normal else self.rng.random(self.block)
            self.values, self.pos = draw.tolist(), 0
        self.pos += 1
        return self.values[self.pos - 1]


class Rig:
    """One simulated encoder box with its carts; see the module docstring."""

    def __init__(self, options: SimOptions) -> None:
        o = self.options = options
        seeds = np.random.SeedSequence(o.seed).spawn(3)
        self._noise = _Blocks(np.random.default_rng(seeds[0]), normal=True)
        self._fault_rng = np.random.default_rng(seeds[2])
        self._fault_u = _Blocks(self._fault_rng, normal=False)
        self.params = ChainParams(o.carts, o.m1, o.m2, o.k1, o.k2, o.k3, o.c1, o.c2, o.fc1, o.fc2, o.cubic)
        self.state = ChainState()
        timing = CaseTiming(o.rest_s, o.pull_s, o.hold_s, o.hold_jitter, o.pull_m, o.tremor_m, o.idle_s,
                            o.flick_mps, o.flick_s)
        hand_rng = np.random.default_rng(seeds[1])
        self.hand: Hand | StudentHand
        if o.student == "off":
            self.hand = Hand(o.cases * o.repeat, timing, hand_rng, o.carts)
        else:
            periods = (2.0 * math.pi * math.sqrt(o.m1 / (o.k1 + o.k2)), 2.0 * math.pi * math.sqrt(o.m2 / (o.k2 + o.k3)))
            knobs = StudentKnobs(o.student, o.student_releases, o.flick_m, o.wander_m, o.follow, o.p_nudge,
                                 o.p_touch, o.p_moving, o.tremor_m, o.carts, o.duration_s or 600.0, periods,
                                 ((o.k2 / o.m1, o.k1 / o.m1), (o.k2 / o.m2, o.k3 / o.m2)))
            self.hand = StudentHand(knobs, hand_rng, self.state, self._rest_of)
        self.rate_hz = o.rate_hz
        self.next_sample_s = 0.0
        self._rate_t0 = 0.0          # sample times are _rate_t0 + k / rate_hz: no drift
        self._rate_k = 0
        self.sample_index = 0
        self.seq = o.seq0
        self.boot_s = 0.0
        self.end_s = o.duration_s if o.duration_s > 0 else math.inf
        self.ended = False
        self.pending = bytearray()
        self.stats = RigStats()
        self.plugged = True
        self.connection = 0
        self.plug_back_s = 0.0
        self.failed_opens = 0
        self.next_disconnect_s = o.disconnect_every_s if o.disconnect_every_s > 0 else math.inf
        self._ring_start_s: float | None = None
        self._settled_since: float | None = None
        self._command_buf = b""
        self.last_line_bytes = 30
        self.capture: BinaryIO | None = None
        if o.capture:
            try:
                self.capture = open(o.capture, "wb")  # noqa: SIM115  (closed by close())
            except OSError as exc:
                raise SimOptionError("sim option 'capture'", "a writable file path", o.capture) from exc
        self._boot()

    def _rest_of(self, cart: int) -> float:
        """Where `cart` comes to rest with the other cart held where it is now (linear springs)."""
        p, s = self.params, self.state
        if p.carts == 1:
            return 0.0
        if cart == 1:
            return p.k2 * s.x2 / (p.k1 + p.k2)
        return p.k2 * s.x1 / (p.k2 + p.k3)

    @property
    def events(self) -> list[ScriptEvent]:
        return self.hand.events

    def device_us(self, t_s: float) -> int:
        """The device clock (unwrapped, us) at simulated time `t_s` since the last boot."""
        o = self.options
        return o.clock0_us + round((t_s - self.boot_s) * (1.0 + o.clock_ppm * 1e-6) * 1e6)

    @property
    def finished(self) -> bool:
        """Ended and every byte delivered."""
        return self.ended and not self.pending

    # -- driving -------------------------------------------------------------------
    def produce_until(self, t_s: float) -> None:
        """Take every sample due at or before `t_s` (real-time pacing); plug back in time."""
        while not self.ended and self.next_sample_s <= t_s:
            if not self.plugged and self.next_sample_s >= self.plug_back_s:
                self._plug_back()
            self._sample()
        if not self.plugged and t_s >= self.plug_back_s:
            self._plug_back()

    def produce_bytes(self, n: int) -> None:
        """Take samples until `n` bytes are pending, the stream ended or the device is unplugged."""
        while len(self.pending) < n and not self.ended and self.plugged:
            self._sample()

    def take(self, n: int) -> bytes:
        data = bytes(self.pending[:n])
        del self.pending[:n]
        return data

    def try_open(self, t_s: float | None) -> bool:
        """A host tries to open the port (at simulated time `t_s`, None: as fast as read)."""
        if self.plugged:
            return True
        if t_s is not None:
            self.produce_until(t_s)
            return self.plugged
        self.failed_opens += 1
        if self.failed_opens <= self.options.reopen_failures:
            return False
        self.produce_until(self.plug_back_s)
        return self.plugged

    def receive(self, data: bytes) -> None:
        """Bytes written by the host: `$Q` answers `$I`, `$R,<rate>` sets the rate and answers."""
        lines = (self._command_buf + data).split(b"\n")
        self._command_buf = lines.pop()[-256:]
        for line in lines:
            command = parse_host_command(line) if self.options.dialect == "cartlab" else None
            if command is None:
                self.stats.bad_commands += line.strip() != b""
                continue
            self.stats.commands += 1
            kind, value = command
            if kind == "R":
                if value is None or not _MIN_RATE_HZ <= value <= _MAX_RATE_HZ:
                    self.stats.bad_commands += 1
                    continue
                if self.sample_index:             # next sample: one new period after the last
                    self._rate_t0, self._rate_k = self.next_sample_s - 1.0 / self.rate_hz, 1
                else:
                    self._rate_t0, self._rate_k = self.next_sample_s, 0
                self.rate_hz = value
                self.next_sample_s = self._rate_t0 + self._rate_k / value
            if self.plugged:
                self.pending += self._info_line()

    def close(self) -> None:
        if self.capture is not None:
            self.capture.close()
            self.capture = None

    # -- one sample --------------------------------------------------------------
    def _sample(self) -> None:
        t = self.next_sample_s
        self._advance_to(t)
        self._check_settled(t)
        if t > self.end_s:
            self.ended = True
            return
        if self.plugged and t >= self.next_disconnect_s:
            self._unplug(t)
        line = self._line(t)
        index = self.sample_index
        self.sample_index += 1
        self.seq = (self.seq + 1) % _U32
        self._rate_k += 1
        self.next_sample_s = self._rate_t0 + self._rate_k / self.rate_hz
        self.stats.samples += 1
        if not self.plugged:
            self.stats.lost_unplugged += 1
            return
        self._send(index, line)

    def _advance_to(self, t: float) -> None:
        """Advance the carts to `t` in whole physics steps, with one odd step ending exactly
        where a phase of the hand ends (the hand lets go at its instant, not at the next step)."""
        s, hand = self.state, self.hand
        n = max(1, round(self.options.substep_hz / self.rate_hz))
        dt = (t - s.t) / n if t > s.t else 0.0
        while dt > 0.0 and t - s.t > 1e-6 * dt:
            hand.update(s.t, s.x1, s.x2)
            end = min(t, hand.phase_end)
            steps = math.floor((end - s.t) / dt + 1e-6)
            if steps >= 1:
                advance(self.params, s, dt, steps, hand.path1, hand.path2)
            elif end - s.t > 1e-6 * dt:
                advance(self.params, s, end - s.t, 1, hand.path1, hand.path2)
            else:
                s.t = end
        s.t = t
        hand.update(t, s.x1, s.x2)

    def _check_settled(self, t: float) -> None:
        hand, s, o = self.hand, self.state, self.options
        if hand.phase != "ring":
            self._ring_start_s = self._settled_since = None
            if hand.done and self.end_s == math.inf and o.duration_s == 0 and hand.cases:
                self.end_s = t + (o.tail_s if o.student == "off" else 0.0)   # a student's record ends when drawn
            return
        if self._ring_start_s is None:
            self._ring_start_s = t
        speeds = [abs(s.v1)] if hand.path1 is None else []
        if o.carts == 2 and hand.path2 is None:
            speeds.append(abs(s.v2))
        if max(speeds, default=0.0) < o.settle_mps:
            self._settled_since = t if self._settled_since is None else self._settled_since
        else:
            self._settled_since = None
        still = self._settled_since is not None and t - self._settled_since >= o.settle_hold_s
        if still or t - self._ring_start_s >= o.ring_max_s:
            hand.ring_over(t)
            self._ring_start_s = self._settled_since = None

    def _line(self, t: float) -> bytes:
        o, s = self.options, self.state
        cpm, noise = o.counts_per_m, o.noise_counts
        counts = [round(s.x1 * cpm + noise * self._noise.next())]
        if o.carts == 2:
            counts.append(round(s.x2 * cpm + noise * self._noise.next()))
        t_dev_us = self.device_us(t)
        if o.dialect == "cartlab":
            return encode_data(self.seq, t_dev_us, counts)
        if o.dialect == "csv":
            return encode_csv(t_dev_us / 1e6, [c / cpm for c in counts])
        second = counts[1] if len(counts) == 2 else 0
        return encode_ecp(counts[0], second, 0, 0.0, t_dev_us / 1e3)

    # -- faults, plugging ------------------------------------------------------------
    def _send(self, index: int, line: bytes) -> None:
        o, u = self.options, self._fault_u
        drop, corrupt, garbage = u.next(), u.next(), u.next()
        if garbage < o.garbage:
            size = int(self._fault_rng.integers(1, 33))
            self.pending += self._fault_rng.integers(0, 256, size, dtype=np.uint8).tobytes()
            self.stats.garbage_bursts += 1
        if drop < o.drop:
            self.stats.dropped += 1
            self.stats.faults.append((index, "drop"))
            return
        if corrupt < o.corrupt:
            kind = _CORRUPTIONS[int(self._fault_rng.integers(0, len(_CORRUPTIONS)))]
            line = self._corrupt(line, kind)
            self.stats.corrupted += 1
            self.stats.faults.append((index, kind))
        self.pending += line
        self.last_line_bytes = len(line)
        self.stats.lines_sent += 1
        self.stats.bytes_sent += len(line)

    def _corrupt(self, line: bytes, kind: str) -> bytes:
        rng = self._fault_rng
        body = len(line) - 1                      # never touch the final newline
        at = int(rng.integers(1, body))           # inside the frame, after its first byte
        if kind == "bitflip":
            at = int(rng.integers(0, body))
            flipped = line[at] ^ (1 << int(rng.integers(0, 7)))
            return line[:at] + bytes([flipped]) + line[at + 1:]
        if kind == "truncate":                    # the rest of the line, newline included, is lost
            return line[:at]
        if kind == "nul":
            return line[:at] + b"\x00" + line[at:]
        if kind == "non_ascii":
            return line[:at] + bytes([int(rng.integers(0x80, 0x100))]) + line[at:]
        filler = bytes(rng.integers(ord("a"), ord("z") + 1, 300, dtype=np.uint8))
        return line[:at] + filler + line[at:]

    def _unplug(self, t: float) -> None:
        self.plugged = False
        if self.options.realtime:
            self.pending.clear()          # what the host had not read yet is lost in transit
        self.connection += 1
        self.failed_opens = 0
        self.plug_back_s = t + self.options.disconnect_s
        self.next_disconnect_s = max(t + self.options.disconnect_every_s, self.plug_back_s)
        self.stats.disconnects += 1

    def _plug_back(self) -> None:
        self.plugged = True
        if self.options.reboot_on_reconnect:
            self.seq = self.options.seq0
            self.boot_s = self.next_sample_s
            self._boot()

    def _boot(self) -> None:
        o = self.options
        if o.dialect == "cartlab":
            self.pending += self._info_line()
        elif o.dialect == "csv":
            self.pending += encode_csv_header(o.carts)

    def _info_line(self) -> bytes:
        o = self.options
        return encode_info(o.model, o.firmware, o.counts_per_m, self.rate_hz)
