"""`replay://<path>?speed=1|max|<factor>[&dialect=...][&rate_hz=...]` — a file as a serial stream.

The file is a raw byte capture (e.g. `sim://...&capture=`) or a text export
(`time_s,pos1[,pos2]` CSV/TSV); its bytes are delivered unchanged. A lab export of an ECP
rig (a header line naming `Time` and `Encoder k Pos` columns: the ECP-210 app's `.txt`,
ECP Executive's raw-data export) is streamed as the device sent it instead: each row becomes
a line of `dialect` (default `ecp`), see `daq.serial_handlers.lab_export`. `<path>` is absolute
(`replay:///data/run.bin`) or relative to the working directory (`replay://runs/a.bin`);
percent-escapes are decoded.

- `speed=max` (default): as fast as read; `read(size)` returns `size` bytes at once.
- `speed=1` (or any factor > 0): paced by the time stamps of the lines (decoded with
  `dialect`, default guessed from the first bytes: `$` -> cartlab, `:` -> ecp, else csv;
  the u32 clock is unwrapped), or at `rate_hz` lines per second when given. Bytes before
  the first time stamp go out at once; a line goes out when its time has come.

After the last byte `read` raises `EndOfStream`. Options are checked like `sim://`'s.
"""

from __future__ import annotations

import bisect
import math
import time
import urllib.parse
from collections.abc import Callable
from pathlib import Path

from serial.serialutil import PortNotOpenError, SerialBase, SerialException

from daq.decode import make_decoder
from daq.frames import DataFrame
from daq.serial_handlers import EndOfStream
from daq.serial_handlers.lab_export import export_columns, export_to_dialect
from daq.sim.options import DIALECT_NAMES, SimOptionError
from daq.timeline import Timeline

REPLAY_OPTIONS: tuple[tuple[str, str, str], ...] = (
    ("speed", "max", ("`max`: as fast as read; a number > 0: real time times that factor, paced by the "
                      "lines' time stamps (1: real time)")),
    ("dialect", "guessed", ("cartlab, csv or ecp: how to read the time stamps for pacing "
                            "(guess: `$` -> cartlab, four `:` -> ecp, else csv); a lab export (header naming "
                            "`Time` and `Encoder k Pos`) is streamed as lines of this dialect (default ecp)")),
    ("rate_hz", "-", "pace at this many lines per second instead of by the time stamps"),
)


def describe_replay_options() -> str:
    """The Markdown table of the `replay://` options."""
    rows = ["| option | default | meaning |", "|---|---|---|"]
    rows += [f"| `{name}` | `{default}` | {text} |" for name, default, text in REPLAY_OPTIONS]
    return "\n".join(rows)


def _parse(url: str) -> tuple[Path, float, str | None, float | None]:
    parts = urllib.parse.urlsplit(url)
    if parts.scheme != "replay" or not (parts.netloc or parts.path):
        raise SimOptionError("url", "replay://<path>?speed=1|max", url)
    path = Path(urllib.parse.unquote(parts.netloc + parts.path))
    speed, dialect, rate = math.inf, None, None
    for name, text in urllib.parse.parse_qsl(parts.query, keep_blank_values=True):
        if name == "speed":
            try:
                speed = math.inf if text == "max" else float(text)
            except ValueError:
                speed = -1.0
            if not speed > 0:
                raise SimOptionError("replay option 'speed'", "max or a number > 0", text)
        elif name == "dialect":
            if text not in DIALECT_NAMES:
                raise SimOptionError("replay option 'dialect'", "one of " + ", ".join(DIALECT_NAMES), text)
            dialect = text
        elif name == "rate_hz":
            try:
                rate = float(text)
            except ValueError:
                rate = -1.0
            if not 0 < rate < 1e7:
                raise SimOptionError("replay option 'rate_hz'", "a number in (0, 1e7)", text)
        else:
            raise SimOptionError("replay option name", "one of speed, dialect, rate_hz", name)
    return path, speed, dialect, rate


def guess_dialect(head: bytes) -> str:
    """`$` first -> cartlab; a data line with `:` -> ecp; anything else -> csv."""
    for line in head.splitlines():
        stripped = line.strip()
        if stripped.startswith(b"$"):
            return "cartlab"
        if stripped.count(b":") == 4:
            return "ecp"
    return "csv"


def line_schedule(data: bytes, dialect: str, rate_hz: float | None) -> tuple[list[int], list[float]]:
    """(end offsets, due times in s) of every line that carries a time stamp, ascending."""
    ends: list[int] = []
    times: list[float] = []
    decoder = make_decoder(dialect)
    timeline = Timeline(clock_bits=32 if dialect == "cartlab" else None)
    t0: float | None = None
    start = 0
    while start < len(data):
        newline = data.find(b"\n", start)
        end = len(data) if newline < 0 else newline + 1
        frames = [f for f in decoder.feed(data[start:end]) if isinstance(f, DataFrame)]
        if frames:
            if rate_hz is not None:
                due = len(times) / rate_hz
            else:
                t_s = timeline.push(frames[-1].seq, frames[-1].t_us).t_ns / 1e9
                t0 = t_s if t0 is None else t0
                due = max(t_s - t0, times[-1] if times else 0.0)
            ends.append(end)
            times.append(due)
        start = end
    return ends, times


class Serial(SerialBase):
    """A `replay://` port. `clock`/`sleep` pace `speed` < max (class attributes, injectable)."""

    is_open: bool
    clock: Callable[[], float] = staticmethod(time.monotonic)
    sleep: Callable[[float], None] = staticmethod(time.sleep)

    def __init__(self, *args: object, **kwargs: object) -> None:
        self._data = b""
        self._pos = 0
        self._speed = math.inf
        self._ends: list[int] = []
        self._times: list[float] = []
        self._origin = 0.0
        super().__init__(*args, **kwargs)

    def open(self) -> None:
        if self.is_open:
            raise SerialException("port is already open")
        if self._port is None:
            raise SerialException("port must be configured before it can be used")
        path, speed, dialect, rate = _parse(str(self._port))
        try:
            self._data = path.read_bytes()
        except OSError as exc:
            raise SerialException(f"could not open port {self._port}: {exc}") from exc
        if export_columns(self._data[:4096]) is not None:
            dialect = dialect or "ecp"
            self._data = export_to_dialect(self._data, dialect)
        self._pos, self._speed = 0, speed
        if speed != math.inf:
            chosen = dialect or guess_dialect(self._data[:4096])
            self._ends, self._times = line_schedule(self._data, chosen, rate)
        self._origin = self.clock()
        self.is_open = True

    def close(self) -> None:
        self.is_open = False

    def _reconfigure_port(self, force_update: bool = False) -> None:
        """Nothing to configure on a file."""

    def _update_dtr_state(self) -> None: ...
    def _update_rts_state(self) -> None: ...
    def _update_break_state(self) -> None: ...

    def _available_end(self) -> int:
        """Offset up to which bytes are due now."""
        if self._speed == math.inf:
            return len(self._data)
        elapsed = (self.clock() - self._origin) * self._speed
        due = bisect.bisect_right(self._times, elapsed)
        if due >= len(self._ends):
            return len(self._data)
        # bytes before the first stamped line go at once; then each line when due
        return self._ends[due - 1] if due > 0 else 0

    @property
    def in_waiting(self) -> int:
        if not self.is_open:
            raise PortNotOpenError()
        return max(0, self._available_end() - self._pos)

    def read(self, size: int = 1) -> bytes:
        if not self.is_open:
            raise PortNotOpenError()
        if self._pos >= len(self._data):
            raise EndOfStream(f"{self._port}: end of the replayed file")
        if size <= 0:
            return b""
        if self._speed != math.inf:
            self._wait_for(size)
        end = min(self._pos + size, self._available_end())
        data = self._data[self._pos:end]
        self._pos = max(self._pos, end)
        return data

    def _wait_for(self, size: int) -> None:
        deadline = None if self._timeout is None else self.clock() + self._timeout
        while self._available_end() - self._pos < size and self._available_end() < len(self._data):
            now = self.clock()
            if deadline is not None and now >= deadline:
                return
            due = bisect.bisect_right(self._ends, self._pos)
            delay = self._times[min(due, len(self._times) - 1)] / self._speed - (now - self._origin)
            limit = 0.05 if deadline is None else deadline - now
            self.sleep(min(max(delay, 1e-4), limit))

    def write(self, data: bytes | bytearray | memoryview) -> int:
        """Commands to a replayed device are accepted and ignored."""
        if not self.is_open:
            raise PortNotOpenError()
        return len(bytes(data))

    def reset_input_buffer(self) -> None: ...
    def reset_output_buffer(self) -> None: ...

    @property
    def out_waiting(self) -> int:
        return 0
