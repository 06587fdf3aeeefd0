"""The read side of a serial port for the daq service: chunks in, events out, reconnects.

    link = SerialLink("sim://?realtime=0", baudrate=115200)
    link.open()                       # raises DaqIOError if the port cannot be opened
    while True:
        got = link.read()             # LinkRead(data, event, gap_s)
        if got.event is LinkEvent.EOF: break
        frames = decoder.feed(got.data)

`read` takes what is waiting (`read(in_waiting)`, capped at `max_read`); when nothing is
waiting it calls `read(max_read)`, which returns after `timeout_s` with whatever arrived
(pyserial semantics), so a slow stream costs one call per `timeout_s`, not one per byte.
It never uses `readline` (slow in pyserial). A `SerialException` or `OSError` closes the
port and reports `DISCONNECTED`; later calls wait `backoff_s` (doubling up to
`backoff_max_s`, through the injected `sleep`) and try to reopen: `DOWN` while that fails,
`RECONNECTED` (with `gap_s`, the outage by the injected clock) when it works. `EndOfStream`
(a finite sim or replay) gives `EOF` for this and every later call. Nothing here decodes.
"""

from __future__ import annotations

import contextlib
import enum
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import serial

import daq  # noqa: F401  (registers the sim:// and replay:// handlers)
from daq.errors import DaqIOError
from daq.serial_handlers import EndOfStream


class LinkEvent(enum.Enum):
    DATA = "data"                  # data may be empty (read timeout)
    DISCONNECTED = "disconnected"  # the port just failed; it is closed
    DOWN = "down"                  # still disconnected, a reopen attempt failed
    RECONNECTED = "reconnected"    # reopened; gap_s says how long it was down
    EOF = "eof"                    # a finite stream ended


@dataclass(frozen=True, slots=True)
class LinkRead:
    data: bytes
    event: LinkEvent
    gap_s: float | None = None


@dataclass(slots=True)
class LinkStats:
    bytes_read: int = 0
    disconnects: int = 0
    reconnects: int = 0
    failed_reopens: int = 0
    total_gap_s: float = 0.0


Opener = Callable[..., Any]


class SerialLink:
    """One serial URL, read in chunks, reopened with bounded back-off (see module docstring)."""

    def __init__(self, url: str, *, baudrate: int = 115200, timeout_s: float = 0.02,
                 max_read: int = 65536, backoff_s: float = 0.1, backoff_max_s: float = 2.0,
                 give_up_after_s: float | None = None,
                 clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep,
                 opener: Opener = serial.serial_for_url) -> None:
        self.url = url
        self.baudrate = baudrate
        self.timeout_s = timeout_s
        self.max_read = max_read
        self.backoff_s = backoff_s
        self.backoff_max_s = backoff_max_s
        self.give_up_after_s = give_up_after_s
        self.clock = clock
        self.sleep = sleep
        self.opener = opener
        self.stats = LinkStats()
        self._port: Any = None
        self._down_since: float | None = None
        self._backoff = backoff_s
        self._eof = False

    @property
    def is_open(self) -> bool:
        return self._port is not None

    def open(self) -> None:
        """First open; a failure here is an error (a wrong URL should not be retried forever)."""
        try:
            self._port = self.opener(self.url, baudrate=self.baudrate, timeout=self.timeout_s)
        except EndOfStream:
            self._eof = True
        except ValueError:
            raise                  # a bad URL option (SimOptionError is also a SerialException)
        except (serial.SerialException, OSError) as exc:
            raise DaqIOError(f"serial port {self.url}: expected a port that opens, got {exc}") from exc

    def read(self) -> LinkRead:
        if self._eof:
            return LinkRead(b"", LinkEvent.EOF)
        if self._port is None:
            return self._reopen()
        try:
            waiting = self._port.in_waiting
            data = self._port.read(min(self.max_read, waiting) if waiting else self.max_read)
        except EndOfStream:
            self._close_port()
            self._eof = True
            return LinkRead(b"", LinkEvent.EOF)
        except (serial.SerialException, OSError):
            self._close_port()
            self._down_since = self.clock()
            self._backoff = self.backoff_s
            self.stats.disconnects += 1
            return LinkRead(b"", LinkEvent.DISCONNECTED)
        self.stats.bytes_read += len(data)
        return LinkRead(bytes(data), LinkEvent.DATA)

    def _reopen(self) -> LinkRead:
        down_since = self._down_since if self._down_since is not None else self.clock()
        if self.give_up_after_s is not None and self.clock() - down_since > self.give_up_after_s:
            raise DaqIOError(f"serial port {self.url}: expected it back within "
                             f"{self.give_up_after_s} s, got nothing")
        self.sleep(self._backoff)
        try:
            self._port = self.opener(self.url, baudrate=self.baudrate, timeout=self.timeout_s)
        except EndOfStream:
            self._eof = True
            return LinkRead(b"", LinkEvent.EOF)
        except (serial.SerialException, OSError):
            self.stats.failed_reopens += 1
            self._backoff = min(2.0 * self._backoff, self.backoff_max_s)
            return LinkRead(b"", LinkEvent.DOWN)
        gap_s = self.clock() - down_since
        self.stats.reconnects += 1
        self.stats.total_gap_s += gap_s
        self._down_since = None
        return LinkRead(b"", LinkEvent.RECONNECTED, gap_s)

    def write(self, data: bytes) -> bool:
        """Send a command; False when the port is down (the command is not queued)."""
        if self._port is None:
            return False
        try:
            self._port.write(data)
        except (serial.SerialException, OSError):
            return False
        return True

    def close(self) -> None:
        self._close_port()

    def _close_port(self) -> None:
        port, self._port = self._port, None
        if port is not None:
            with contextlib.suppress(serial.SerialException, OSError):
                port.close()
