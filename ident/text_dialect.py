"""The dialect of a delimited text export: which separator, and whether decimals use a comma.

Exports come from Logger Pro and spreadsheets (`,`), from a spreadsheet in a locale with
decimal commas (`;` separators, `0,015`), from the ECP Executive (whitespace, MATLAB-like
`[ … ;` rows) and from tab-separated tools (`\t`, possibly with decimal commas). `sniff`
decides once per file from its data lines, so every row is split the same way:

- `;` between values (not only the MATLAB row end) → `;`;
- else a tab → tab;
- else a comma: a separator, unless no value has a decimal point and every line reads as
  whitespace-separated `digits,digits` tokens (then a decimal comma);
- else runs of whitespace.
With a `;` or tab separator (or the whitespace case above), values like `0,015` mean a
decimal comma. The standard library's `csv.Sniffer` finds separators only (and prefers `,`
in `0,1;0,2`), so these rules are written here. No I/O.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass

_DECIMAL_COMMA = re.compile(r"^[+-]?\d+,\d+([eE][+-]?\d+)?$")
_POINT_NUMBER = re.compile(r"(^|[^\d])\d*\.\d")
#: Data lines looked at (the header is before them; the rest of the file follows the same rules).
SAMPLE_LINES = 200


@dataclass(frozen=True)
class TextDialect:
    """`delimiter` None: runs of whitespace. `decimal_comma`: `0,5` is one half."""

    delimiter: str | None
    decimal_comma: bool

    def split(self, line: str) -> list[str]:
        """The fields of a cleaned line, quotes and blanks stripped, empties dropped."""
        parts = line.split() if self.delimiter is None else line.split(self.delimiter)
        return [f.strip().strip('"').strip() for f in parts if f.strip().strip('"').strip()]

    def cells(self, line: str) -> list[str]:
        """The fields of a cleaned line with empty cells kept ('' where a shorter data set of a
        delimited export has ended); whitespace-separated lines have none."""
        if self.delimiter is None:
            return self.split(line)
        return [f.strip().strip('"').strip() for f in line.split(self.delimiter)]

    def number(self, field: str) -> str:
        """The field in Python's float syntax (decimal comma → point)."""
        return field.replace(",", ".") if self.decimal_comma else field

    def describe(self) -> str:
        name = {None: "whitespace", ",": "comma", ";": "semicolon", "\t": "tab"}[self.delimiter]
        return f"{name}-separated, decimal {'comma' if self.decimal_comma else 'point'}"


def clean(raw: str) -> str:
    """A line without MATLAB brackets and without the `;` that ends an ECP row."""
    line = raw.replace("[", " ").replace("]", " ").strip()
    return line[:-1].rstrip() if line.endswith(";") else line


def _data_lines(lines: Iterable[str]) -> list[str]:
    """Cleaned lines that start like a number (the header and comments are skipped)."""
    found = []
    for raw in lines:
        line = clean(raw)
        if line and not line.startswith("#") and (line[0].isdigit() or line[0] in "+-."):
            found.append(line)
            if len(found) >= SAMPLE_LINES:
                break
    return found


def sniff(lines: Iterable[str]) -> TextDialect:
    """The dialect of a file from its lines (see the module docstring for the rules)."""
    data = _data_lines(lines)
    if not data:
        return TextDialect(None, False)
    if any(";" in line for line in data):
        delimiter: str | None = ";"
    elif any("\t" in line for line in data):
        delimiter = "\t"
    elif any("," in line for line in data):
        tokens = [token for line in data for token in line.split()]
        points = any(_POINT_NUMBER.search(line) for line in data)
        if not points and all(_DECIMAL_COMMA.match(t) or t.lstrip("+-").isdigit() for t in tokens) \
                and any(len(line.split()) > 1 for line in data):
            return TextDialect(None, True)
        return TextDialect(",", False)
    else:
        return TextDialect(None, False)
    fields = [f for line in data for f in TextDialect(delimiter, False).split(line)]
    return TextDialect(delimiter, any(_DECIMAL_COMMA.match(f) for f in fields))
