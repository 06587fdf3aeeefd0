"""`sim://[name]?opt=value&...` — the simulated rig as a pyserial port (see `daq.sim`).

pyserial builds `Serial(None, **kwargs)`, sets `.port = url` and calls `open()`. Reads
follow pyserial's semantics: `read(size)` returns when `size` bytes are there or the
timeout has passed (`realtime=1`, paced by `Serial.clock`); with `realtime=0` samples are
made on demand, so `read(size)` returns `size` bytes at once until the stream ends. After
the last byte `read` raises `EndOfStream`. While the simulated device is unplugged,
`read`/`in_waiting` raise `SerialException` and so does `open()`; a rig that is unplugged
is kept (per URL) so that reopening the same URL reconnects to the same running rig (in
real time, unless it has been back for more than a minute without being reopened).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import serial
from serial.serialutil import PortNotOpenError, SerialBase, SerialException

from daq.serial_handlers import EndOfStream
from daq.sim.options import parse_sim_url
from daq.sim.rig import Rig

_PARKED: dict[str, tuple[Rig, float]] = {}    # url -> (unplugged rig, its wall-clock origin)
_PARKED_LOCK = threading.Lock()
_FAST_BLOCK = 4096
_STALE_S = 60.0


class Serial(SerialBase):
    """A `sim://` port. `clock` and `sleep` pace real-time mode (class attributes, injectable)."""

    is_open: bool
    clock: Callable[[], float] = staticmethod(time.monotonic)
    sleep: Callable[[float], None] = staticmethod(time.sleep)

    def __init__(self, *args: object, **kwargs: object) -> None:
        self.rig: Rig | None = None
        self._lock = threading.Lock()       # read and write may come from different threads
        self._origin = 0.0
        self._connection = 0
        super().__init__(*args, **kwargs)

    # -- pyserial plumbing ---------------------------------------------------------
    def open(self) -> None:
        if self.is_open:
            raise SerialException("port is already open")
        if self._port is None:
            raise SerialException("port must be configured before it can be used")
        url = str(self._port)
        options = parse_sim_url(url)
        with _PARKED_LOCK:
            parked = _PARKED.pop(url, None)
        if parked is not None and options.realtime and self.clock() - parked[1] > parked[0].plug_back_s + _STALE_S:
            parked[0].close()                 # unplugged long ago and never reopened: a new rig
            parked = None
        if parked is None:
            rig, origin = Rig(options), self.clock()
        else:
            rig, origin = parked
            now = self.clock() - origin if options.realtime else None
            if not rig.try_open(now):
                with _PARKED_LOCK:
                    _PARKED[url] = (rig, origin)
                raise SerialException(f"could not open port {url}: the simulated device is unplugged")
        self.rig, self._origin, self._connection = rig, origin, rig.connection
        self.is_open = True

    def close(self) -> None:
        rig, self.rig = self.rig, None
        if rig is not None:
            if not rig.plugged and not rig.ended:
                with _PARKED_LOCK:
                    _PARKED[str(self._port)] = (rig, self._origin)
            else:
                rig.close()
        self.is_open = False

    def _reconfigure_port(self, force_update: bool = False) -> None:
        """Baud rate, parity and the like mean nothing to the simulated link."""

    def _update_dtr_state(self) -> None: ...
    def _update_rts_state(self) -> None: ...
    def _update_break_state(self) -> None: ...

    # -- data ----------------------------------------------------------------------
    def _live_rig(self) -> Rig:
        if not self.is_open or self.rig is None:
            raise PortNotOpenError()
        rig = self.rig
        if rig.connection != self._connection and (rig.options.realtime or rig.plugged or not rig.pending):
            raise SerialException("device reports readiness to read but returned no data "
                                  "(the simulated device was unplugged)")
        return self.rig

    def _now(self) -> float:
        return self.clock() - self._origin

    def _produce(self, rig: Rig, want: int) -> None:
        with self._lock:
            if rig.options.realtime:
                rig.produce_until(self._now())
            else:
                rig.produce_bytes(want)
        self._live_rig()

    @property
    def in_waiting(self) -> int:
        rig = self._live_rig()
        self._produce(rig, _FAST_BLOCK)
        return len(rig.pending)

    def read(self, size: int = 1) -> bytes:
        rig = self._live_rig()
        if size <= 0:
            return b""
        if rig.options.realtime:
            self._wait_for(rig, size)
        else:
            self._produce(rig, size)
        with self._lock:
            data = rig.take(size)
        if not data and rig.finished:
            raise EndOfStream(f"{self._port}: end of the simulated stream")
        if rig.capture is not None and data:
            rig.capture.write(data)
        return data

    def _wait_for(self, rig: Rig, size: int) -> None:
        """Real time: block until `size` bytes are pending, the timeout passed or the end."""
        timeout = self._timeout
        deadline = None if timeout is None else self.clock() + timeout
        while True:
            self._produce(rig, size)
            if len(rig.pending) >= size or rig.ended:
                return
            now = self.clock()
            if deadline is not None and now >= deadline:
                return
            due_s = rig.next_sample_s if rig.plugged else rig.plug_back_s
            if rig.plugged:                             # sleep until about enough lines are due
                lines_needed = (size - len(rig.pending)) // max(1, rig.last_line_bytes)
                due_s += max(0, lines_needed - 1) / rig.rate_hz
                due_s = min(due_s, max(rig.next_disconnect_s, rig.next_sample_s))
            delay = due_s - (now - self._origin)       # same arithmetic as _now(): no lost wake-up
            limit = 0.05 if deadline is None else deadline - now
            self.sleep(min(max(delay, 1e-4), limit))

    def write(self, data: bytes | bytearray | memoryview) -> int:
        rig = self._live_rig()
        payload = bytes(data)
        with self._lock:
            rig.receive(payload)
        return len(payload)

    def reset_input_buffer(self) -> None:
        rig = self._live_rig()
        with self._lock:
            rig.pending.clear()

    def reset_output_buffer(self) -> None:
        self._live_rig()

    @property
    def out_waiting(self) -> int:
        return 0


__all__ = ["Serial", "serial"]
