"""Base class for every record that crosses a process or file boundary.

Records are pydantic v2 models: frozen, `extra="forbid"`, carrying a schema version, with
units in field names. JSON Schemas for Zenoh and MCAP are generated from them, never
written by hand. This module must not import anything of ours but `schemas`.
"""

from __future__ import annotations

import json
from typing import ClassVar, Self

from pydantic import BaseModel, ConfigDict, ValidationError

from schemas.errors import SchemaError

#: Largest JSON payload any service accepts (a fit report with figures' names, a run list).
MAX_PAYLOAD_BYTES = 4 * 1024 * 1024


class Record(BaseModel):
    """A frozen, strict, versioned message."""

    # NaN and infinities are refused: JSON has no spelling for them, and a record that
    # validated must survive its own round trip (producers send None for "unknown").
    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)
    SCHEMA_VERSION: ClassVar[int] = 1

    schema_version: int = 1

    def to_json_bytes(self) -> bytes:
        return self.model_dump_json().encode()

    @classmethod
    def from_json_bytes(cls, data: bytes | bytearray | memoryview | str) -> Self:
        """Parse and validate a JSON payload; raise `SchemaError` naming the problem."""
        raw = data.encode() if isinstance(data, str) else bytes(data)
        if len(raw) > MAX_PAYLOAD_BYTES:
            raise SchemaError(cls.__name__, f"at most {MAX_PAYLOAD_BYTES} bytes", f"{len(raw)} bytes")
        try:
            record = cls.model_validate_json(raw)
        except ValidationError as exc:
            first = exc.errors()[0]
            where = ".".join(str(p) for p in first["loc"]) or "(root)"
            raise SchemaError(cls.__name__, f"a valid {cls.__name__} ({where}: {first['msg']})",
                              _preview(raw)) from exc
        if record.schema_version != cls.SCHEMA_VERSION:
            raise SchemaError(cls.__name__, f"schema_version {cls.SCHEMA_VERSION}",
                              str(record.schema_version))
        return record

    @classmethod
    def json_schema_bytes(cls) -> bytes:
        """The JSON Schema of this record, as MCAP `jsonschema` channels want it."""
        schema = cls.model_json_schema()
        schema.setdefault("title", cls.__name__)
        return json.dumps(schema, separators=(",", ":")).encode()

    @classmethod
    def schema_name(cls) -> str:
        return f"cartlab.{cls.__name__}"


def _preview(raw: bytes, limit: int = 80) -> str:
    text = raw[:limit].decode("utf-8", errors="replace")
    return repr(text + ("…" if len(raw) > limit else ""))
