"""A delimited text export as a table: its header's column names, its comments, and the
numbers of the columns a caller keeps (`ident.io` chooses them and scales them to metres).

The separator and decimal mark are sniffed once per file (`ident.text_dialect`). `[`, `]` and a
row-ending `;` on data rows, blank lines and `#` or `%` comments are ignored, but a commented
header (numpy's `savetxt` writes `# time_s,pos1_m`, MATLAB `% time_s pos1_cm`) names the columns
when no other line does; a unit in brackets in a name (`Position [mm]`) is kept as `(mm)`. An
export of several data sets of unequal length (Logger Pro's runs) has empty cells where a shorter
one has ended: the kept columns are read to their end. No numerics beyond the parse.
"""

from __future__ import annotations

import itertools
import re
from array import array
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ident.data import FloatArray
from ident.errors import DataFileError
from ident.text_dialect import SAMPLE_LINES, TextDialect, clean, sniff

_NUMBER = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$")


@dataclass(frozen=True)
class Table:
    """A parsed text export: column names, float rows (N, n_columns), and the `# key: value`
    comment lines (`daq export` writes the run's metadata there)."""

    names: list[str]
    values: FloatArray
    comments: dict[str, str] = field(default_factory=dict)


#: Longest line a text export may have (characters): a file without newlines (a sparse file of
#: NULs, a binary file) is refused at its first line, not read whole into memory.
MAX_LINE_CHARS = 64 * 1024
#: Most lines read before the first data row (headers, comments).
MAX_HEAD_LINES = 10_000


def read_table(text: str | Iterable[str], max_rows: int | None = None) -> Table:
    """Parse a delimited export into named columns (see the module docstring).

    The separator and the decimal mark are sniffed once per file (`ident.text_dialect`).
    Non-numeric lines before the first data row are headers (the last one names the
    columns); after it, a row that is not all numbers (text, nan, inf) is a `DataFileError`
    naming the line and the dialect it was read in, never skipped. Values go straight into
    one float64 array of `max_rows` rows when the caller knows a bound (a file's line count),
    else into a growing flat `array('d')`: memory stays near the values' size (8 bytes each),
    not the Python objects' (about 10x more).
    """
    names, comments, blocks = read_columns(text, max_rows, None)
    return Table(names, blocks[0], comments)


#: Which columns to keep, given the column names: groups of column indices, one array each.
Select = Callable[[list[str]], list[list[int]]]


def read_columns(text: str | Iterable[str], max_rows: int | None, select: Select | None
                 ) -> tuple[list[str], dict[str, str], list[FloatArray]]:
    """`read_table`'s parse: names, comments, and one (N, len(group)) array per group of
    `select(names)` (every column in one array without `select`). Only the selected fields
    are converted and stored: an ECP export's five columns of which three are used (about
    23 bytes a row) cost 24 bytes a row, not 40 plus the copies taken from them."""
    lines = iter(text.splitlines() if isinstance(text, str) else text)
    head = _head(lines)
    dialect = sniff(head)
    names: list[str] = []
    values = _Rows(max_rows)
    width = 0
    comments: dict[str, str] = {}
    header = commented = ""   # the header line; a commented one (`# time_s,pos1_m`)
    ended = 0   # the line where the chosen columns' cells were first empty
    for number, raw in enumerate(itertools.chain(head, lines), start=1):
        line = clean(raw)
        if line.startswith(("#", "%")):
            key, colon, value = line[1:].partition(":")
            if colon and key.strip().isidentifier():
                comments.setdefault(key.strip(), value.strip())
            elif not width:
                commented = raw.strip()[1:]
            continue
        if not line:
            continue
        fields = [dialect.number(f) for f in dialect.split(line)]
        if fields and all(_NUMBER.match(f) for f in fields):
            if not width:
                width = len(fields)
                if len(names) != width:  # no header line, or one we could not split
                    # a header written as a comment (numpy's savetxt, MATLAB's %), else numbered
                    names = (_header_names(dialect, header, width) or _header_names(dialect, commented, width)
                             or [f"col{i}" for i in range(width)])
                values.start(select(names) if select is not None else [list(range(width))])
            elif len(fields) != width:
                # a delimited export of several data sets of unequal length (Logger Pro's runs):
                # the shorter ones' cells are empty; the chosen columns' data end at their first
                cells = [dialect.number(f) for f in dialect.cells(line)] + [""] * width
                if len(fields) > width or any(cells[width:]) or dialect.delimiter is None:
                    raise DataFileError(f"expected {width} values per row, got {len(fields)} in line {number} "
                                        f"(read as {dialect.describe()})")
                fields = cells
                if not values.kept(fields):
                    ended = ended or number
                    continue
            if ended:
                raise DataFileError(f"expected a value in every row of the chosen columns until they end (a "
                                    f"shorter data set), got one missing in line {ended} and values again in "
                                    f"line {number} (read as {dialect.describe()})")
            values.add(fields)
        elif not width:
            header = raw
            names = _header_names(dialect, raw)
        else:
            raise DataFileError(f"expected numbers in every data row, got {raw.strip()[:60]!r} "
                                f"in line {number} (read as {dialect.describe()})")
    if not width:
        raise DataFileError(f"expected numeric rows after the header, got none (read as {dialect.describe()})")
    return names, comments, values.arrays()


class _Rows:
    """Numeric rows gathered for `read_table`, one array per group of columns: preallocated
    when a bound on the row count is known (no reallocation, so no second copy at the peak),
    else flat."""

    def __init__(self, max_rows: int | None) -> None:
        self._max_rows = max_rows
        self._groups: list[list[int]] = []
        self._blocks: list[FloatArray] = []
        self._flats: list[array[float]] = []
        self._filled: list[tuple[FloatArray, list[int]]] = []
        self._columns: list[tuple[FloatArray, int]] = []
        self.n = 0

    def start(self, groups: list[list[int]]) -> None:
        """Keep these groups of columns (indices into a row's fields)."""
        self._groups = groups
        if self._max_rows is not None:
            self._blocks = [np.empty((self._max_rows, len(g)), dtype=np.float64) for g in groups]
            pairs = list(zip(self._blocks, groups, strict=True))
            self._columns = [(b[:, 0], g[0]) for b, g in pairs if len(g) == 1]
            self._filled = [(b, g) for b, g in pairs if len(g) > 1]   # no writes for empty groups
        else:
            self._flats = [array("d") for _ in groups]

    def kept(self, cells: list[str]) -> bool:
        """Whether every kept column has a value in `cells` (a row's fields, '' where empty)."""
        return all(cells[i] for group in self._groups for i in group)

    def add(self, fields: list[str]) -> None:
        if self._blocks:
            for column, i in self._columns:   # a scalar write costs a fraction of a row's
                column[self.n] = float(fields[i])
            for block, group in self._filled:
                block[self.n] = [float(fields[i]) for i in group]
        else:
            for flat, group in zip(self._flats, self._groups, strict=True):
                flat.extend(float(fields[i]) for i in group)
        self.n += 1

    def arrays(self) -> list[FloatArray]:
        if self._blocks:   # shrunk in place (the unused rows were never touched, not in RSS):
            for block in self._blocks:   # arrays that own their data, which IdData keeps uncopied
                block.resize((self.n, block.shape[1]), refcheck=False)
            return self._blocks
        return [np.frombuffer(flat, dtype=np.float64).reshape(-1, len(group))
                for flat, group in zip(self._flats, self._groups, strict=True)]


def _head(lines: Iterator[str]) -> list[str]:
    """The lines up to `SAMPLE_LINES` data rows (what the dialect is sniffed from)."""
    head: list[str] = []
    data = 0
    for raw in lines:
        head.append(raw)
        line = raw.lstrip(" [")
        if line[:1].isdigit() or line[:1] in "+-.":
            data += 1
        if data >= SAMPLE_LINES or len(head) >= MAX_HEAD_LINES:
            break
    return head


def count_lines(path: Path) -> int:
    """Newlines in a file plus one (an upper bound on its rows), counted in 1 MiB blocks."""
    count = 1
    try:
        with path.open("rb") as handle:
            while block := handle.read(1 << 20):
                count += block.count(b"\n") + block.count(b"\r")
    except OSError as exc:
        raise DataFileError(f"cannot read {path}: {exc}") from exc
    return count


def text_lines(path: Path) -> Iterator[str]:
    """The lines of a text file, read one at a time; a line over `MAX_LINE_CHARS` is a
    `DataFileError` (no whole-file read, whatever the file holds)."""
    try:
        handle = path.open(encoding="utf-8", errors="replace", newline=None)
    except OSError as exc:
        raise DataFileError(f"cannot read {path}: {exc}") from exc
    with handle:
        for number in itertools.count(1):
            try:
                line = handle.readline(MAX_LINE_CHARS + 1)
            except OSError as exc:
                raise DataFileError(f"cannot read {path}: {exc}") from exc
            if not line:
                return
            if len(line) > MAX_LINE_CHARS:
                raise DataFileError(f"expected text lines of at most {MAX_LINE_CHARS} characters, got a "
                                    f"longer line {number} in {path.name} (not a text export?)")
            yield line.rstrip("\n")


def _header_names(dialect: TextDialect, raw: str, width: int | None = None) -> list[str]:
    """The column names of a header line; a unit in brackets (`Position [mm]`) is kept, as
    `Position (mm)` (the brackets `clean` drops are the MATLAB rows' of the data lines). With
    `width`, names for that many columns or none: a whitespace-separated header's names may
    hold single spaces (`Encoder 1 Pos`) or be split by them (`time x1 x2`)."""
    line = clean(re.sub(r"\[\s*([^\[\]]*?)\s*\]", r"(\1)", raw))
    names = dialect.split(line) if dialect.delimiter is not None else _split_header(line)
    if width is None or len(names) == width:
        return names
    names = line.split()
    return names if len(names) == width else []


def _split_header(line: str) -> list[str]:
    """A whitespace-separated header: names may hold single spaces ('Encoder 1 Pos')."""
    if "\t" in line:
        return [f.strip().strip('"') for f in line.split("\t") if f.strip()]
    return [f.strip().strip('"') for f in re.split(r"\s{2,}", line.strip()) if f.strip()]


__all__ = ["MAX_HEAD_LINES", "MAX_LINE_CHARS", "Select", "Table", "count_lines", "read_columns", "read_table",
           "text_lines"]
