"""Which serial URLs `daq run --port` accepts: a device path, or a URL whose scheme a pyserial
handler package knows (pyserial's own: `socket://`, `rfc2217://`, `loop://`, …; ours: `sim://`,
`replay://`).

Checked before opening, because pyserial answers an unknown scheme with a bare `ValueError`
("protocol 'tcp' not known") that names neither the option nor what would work. The scheme
list is read from the handler packages themselves (`serial.protocol_handler_packages`), so a
handler added later is accepted without touching this module.
"""

from __future__ import annotations

import importlib
import pkgutil
import re

import serial

from daq.errors import DaqValueError

_SCHEME = re.compile(r"^([A-Za-z][A-Za-z0-9+.-]*)://")
_PREFIX = "protocol_"


def known_schemes() -> list[str]:
    """Sorted URL schemes of every registered pyserial handler package."""
    schemes: set[str] = set()
    for package_name in ("serial.urlhandler", *serial.protocol_handler_packages):
        try:
            package = importlib.import_module(package_name)
        except ImportError:
            continue
        for info in pkgutil.iter_modules(getattr(package, "__path__", [])):
            if info.name.startswith(_PREFIX):
                schemes.add(info.name[len(_PREFIX):])
    return sorted(schemes)


def check_port(url: str) -> str:
    """`url` unchanged if it is a device path or a URL with a known scheme, else `DaqValueError`
    naming the scheme and listing the ones that work."""
    match = _SCHEME.match(url)
    if match is None:
        return url
    scheme = match.group(1).lower()
    schemes = known_schemes()
    if scheme not in schemes:
        raise DaqValueError("--port", "a device path (/dev/ttyACM0, COM3) or a URL with one of the schemes "
                            + ", ".join(f"{s}://" for s in schemes)
                            + " (a TCP serial bridge is socket://HOST:PORT)", url)
    return url
