"""The one exception of the `schemas` package."""

from __future__ import annotations


class SchemaError(ValueError):
    """A payload or name that does not match its model.

    Subclasses `ValueError` so callers that only know builtins still catch it.
    """

    def __init__(self, what: str, expected: str, got: str) -> None:
        self.what = what
        self.expected = expected
        self.got = got
        super().__init__(f"{what}: expected {expected}, got {got}")
