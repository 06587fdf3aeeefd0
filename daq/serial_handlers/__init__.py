"""pyserial URL handlers of cartlab: `protocol_sim` (`sim://`) and `protocol_replay` (`replay://`).

pyserial imports `<package>.protocol_<scheme>` and swallows ImportErrors there, so each
handler module is also import-tested directly.

`EndOfStream` is raised by `read()` of a `sim://` or `replay://` port once every byte of a
finite stream has been delivered (the simulated script is over, the replayed file is
exhausted). It is a `serial.SerialException`, so code that only knows pyserial sees an
I/O error; `daq.serial_link.SerialLink` reports it as the `eof` event instead of
reconnecting.
"""

import serial


class EndOfStream(serial.SerialException):
    """A finite simulated or replayed stream has delivered its last byte."""


__all__ = ["EndOfStream"]
