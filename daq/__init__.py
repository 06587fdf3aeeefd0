"""cartlab `daq`: serial encoders in, live Zenoh samples and one MCAP file per run out.

Importing `daq` registers its pyserial URL handlers (`sim://`, `replay://`), so
`serial.serial_for_url("sim://...")` works anywhere `daq` is imported.
"""

import serial

_HANDLERS = "daq.serial_handlers"
if _HANDLERS not in serial.protocol_handler_packages:
    serial.protocol_handler_packages.append(_HANDLERS)

__version__ = "0.1.0"

__all__ = ["__version__"]
