"""cartlab's records: pydantic v2 models for everything that crosses a process or file boundary.

The bottom layer: imports nothing of `daq` or `ident`.
"""

from schemas.base import MAX_PAYLOAD_BYTES, Record
from schemas.errors import SchemaError

__all__ = ["MAX_PAYLOAD_BYTES", "Record", "SchemaError"]
