"""Lab exports of an ECP rig's records, turned back into the stream the device sent.

The lab's apps save what the encoder box streamed as a table with a header line naming
the columns: the ECP-210 Teensy app's tab-separated `.txt`
(`Sample  Time  Encoder 1 Pos  Encoder 2 Pos  Control Effort`, time in s) and ECP
Executive's raw-data export (`Sample  Time  Commanded Pos  Encoder 2 Pos  Control Effort`,
rows wrapped in `[ ... ;` / `]`). `replay://` streams such a file in a dialect, so daq reads
it through the same decoder as the live rig: each row becomes one line of that dialect.

Columns are found by name: `Time` (s), `Encoder 1 Pos` and `Encoder 2 Pos` (counts; a
missing encoder reads 0, `Commanded Pos` is a command, not a position), `Control Effort`
(the ecp line's target, as exported: the 2025 app's duty targets are whole counts, ECP
Executive's efforts volts). Rows that are not all numbers are skipped. Pure.
"""

from __future__ import annotations

import re

from daq.decode.cartlab import encode_data
from daq.decode.text import encode_csv, encode_csv_header, encode_ecp

_SPLIT_HEADER = re.compile(r"\t| {2,}")
_WRAPPING = str.maketrans({"[": " ", "]": " ", ";": " "})


def export_columns(head: bytes) -> list[str] | None:
    """The column names of a lab export's header line, or None when `head` is not one."""
    for raw in head.splitlines():
        line = raw.decode("ascii", "replace").strip()
        if not line:
            continue
        names = [n.strip() for n in _SPLIT_HEADER.split(line) if n.strip()]
        if "Time" in names and any(n.startswith("Encoder") and n.endswith("Pos") for n in names):
            return names
        return None
    return None


def export_to_dialect(data: bytes, dialect: str) -> bytes:
    """Every data row of the export `data` as one line of `dialect` (cartlab, csv or ecp)."""
    names = export_columns(data[:4096])
    if names is None:
        raise ValueError("not a lab export: expected a header line naming Time and Encoder k Pos columns")
    time_col = names.index("Time")
    enc = [names.index(n) if n in names else None for n in ("Encoder 1 Pos", "Encoder 2 Pos")]
    effort = names.index("Control Effort") if "Control Effort" in names else None
    out = bytearray(encode_csv_header(2) if dialect == "csv" else b"")
    seq = 0
    for raw in data.splitlines():
        fields = raw.decode("ascii", "replace").translate(_WRAPPING).split()
        if len(fields) != len(names):
            continue
        try:
            values = [float(f) for f in fields]
        except ValueError:
            continue
        t_s = values[time_col]
        pos = [round(values[c]) if c is not None else 0 for c in enc]
        if dialect == "ecp":
            target = values[effort] if effort is not None else 0.0
            out += encode_ecp(pos[0], pos[1], target, 0.0, t_s * 1e3)
        elif dialect == "csv":
            out += encode_csv(t_s, [float(p) for p in pos], digits=0)
        else:
            out += encode_data(seq, round(t_s * 1e6), pos)
            seq += 1
    return bytes(out)
