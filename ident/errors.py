"""The exception tree of `ident`: one root, subclasses that also inherit the fitting builtin."""

from __future__ import annotations


class IdentError(Exception):
    """Root of every error `ident` raises on purpose."""


class IdentValueError(IdentError, ValueError):
    """Bad data or argument: names the value and what was expected."""

    def __init__(self, what: str, expected: str, got: object) -> None:
        self.what = what
        self.expected = expected
        self.got = got
        super().__init__(f"{what}: expected {expected}, got {got}")


class IdentDimensionError(IdentValueError):
    """An array of the wrong shape."""


class FitFailed(IdentError, RuntimeError):
    """An optimisation that did not converge to a usable model."""


class DataFileError(IdentError, OSError):
    """A run or export file that cannot be read."""
