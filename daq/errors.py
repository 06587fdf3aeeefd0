"""The exception tree of `daq`: one root, subclasses that also inherit the fitting builtin."""

from __future__ import annotations


class DaqError(Exception):
    """Root of every error `daq` raises on purpose."""


class DaqValueError(DaqError, ValueError):
    """A bad option, URL parameter or value: names the value and what was expected."""

    def __init__(self, what: str, expected: str, got: object) -> None:
        self.what = what
        self.expected = expected
        self.got = got
        super().__init__(f"{what}: expected {expected}, got {got!r}")


class DaqIOError(DaqError, OSError):
    """A port, file or session that could not be used."""
