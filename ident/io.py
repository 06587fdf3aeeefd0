"""Loaders: files to `IdData` (thin adapters; the numerics live elsewhere).

Formats
- delimited text exports: our CSV (`time_s,pos1_m[,pos2_m]`, no options needed), Logger Pro
  CSV (`"Time (s)","Position (m)"`), ECP Executive / Teensy TSV (`Sample  Time  Commanded Pos
  Encoder 2 Pos …` then `[ 0 0.000 2 13 0.0000;` rows). Columns are chosen by name
  (case-insensitive substring), values scaled to metres (from a unit in the column name, or
  `scale` in metres per unit: `(mm)`, `[mm]` or `_mm`). `[`, `]` and a row-ending `;` on data
  rows, blank lines and `#` or `%` comments are ignored, but a commented header (numpy's
  `savetxt` writes `# time_s,pos1_m`) names the columns when no other line does; the separator
  (`,` `;` tab whitespace) and a decimal comma are sniffed per file.
- `daq` MCAP runs (`/samples` SampleBatch messages, `cartlab.run` RunMetadata): the release
  time and pulled cart come from the metadata.

The input is the lab's position step `u = step_m·H(t - t_r)`; with no release time known the
step is placed at the first complete release the release finder finds (`ident.releases`),
which the fitters refine anyway.
"""

from __future__ import annotations

import itertools
import re
from array import array
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ident.data import FloatArray, IdData, check_arrays, from_release
from ident.errors import DataFileError, IdentValueError
from ident.releases.select import DEFAULT_STEP_M, with_found_release
from ident.text_dialect import SAMPLE_LINES, TextDialect, clean, sniff
from schemas import SchemaError, run_file, topics

_UNIT_SCALES = {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "in": 0.0254, "s": 1.0, "ms": 1e-3, "us": 1e-6}
_POSITION_HINTS = ("pos", "encoder", "x1", "x2", "distance", "position")
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
    names, comments, blocks = _read(text, max_rows, None)
    return Table(names, blocks[0], comments)


#: Which columns to keep, given the column names: groups of column indices, one array each.
Select = Callable[[list[str]], list[list[int]]]


def _read(text: str | Iterable[str], max_rows: int | None, select: Select | None
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


def _find_column(names: list[str], wanted: str) -> int:
    lowered = [n.lower() for n in names]
    if wanted.lower() in lowered:
        return lowered.index(wanted.lower())
    hits = [i for i, n in enumerate(lowered) if wanted.lower() in n]
    if len(hits) != 1:
        raise IdentValueError("column", f"exactly one column matching {wanted!r} in {names}",
                              f"{len(hits)} matches")
    return hits[0]


def _default_time_column(names: list[str]) -> int:
    for i, n in enumerate(names):
        if n.lower() in ("t", "time") or n.lower().startswith(("time", "t_")):
            return i
    hits = [i for i, n in enumerate(names) if "time" in n.lower()]
    if not hits:
        raise IdentValueError("time column", f"a column named like 'time' in {names} (name it with --time "
                              "COLUMN; a file without one: --rate HZ)", "none")
    return hits[0]


def _default_position_columns(names: list[str]) -> list[int]:
    lowered = [n.lower() for n in names]
    ours = [i for i, n in enumerate(lowered) if re.fullmatch(r"pos\d_m", n)]
    if ours:
        return ours
    hits = [i for i, n in enumerate(lowered)
            if any(h in n for h in _POSITION_HINTS) and "command" not in n and "target" not in n]
    if not hits:
        raise IdentValueError("position columns", f"columns named like position/encoder in {names} (name "
                              "them with --pos COLUMN, once per cart)", "none")
    return hits


def _one_data_set(names: list[str], chosen: list[int]) -> None:
    """Refuse columns chosen by default from several data sets: an export with a time column
    per data set (Logger Pro's `Run 1: Time (s)`, `Run 1: Position (m)`, `Run 2: Time (s)`,
    …), where each column belongs to the time column at or before it."""
    times = [i for i, n in enumerate(names) if "time" in n.lower() or n.lower() == "t"]
    if len(times) < 2:
        return
    sets = {max([t for t in times if t <= i], default=times[0]) for i in chosen}
    if len(sets) > 1:
        first = min(sets)
        pos = [names[i] for i in chosen if i > first and max(t for t in times if t <= i) == first]
        raise IdentValueError("columns", f"one data set's time and positions, each data set with its own time "
                              f"column ({', '.join(names[t] for t in times)}): choose one, e.g. --time "
                              f"{names[first]!r}{''.join(f' --pos {p!r}' for p in pos)}", f"{len(sets)} data sets")


def unit_scale(name: str) -> float | None:
    """Scale to SI from a unit in a column name: 'Position (cm)' → 0.01, 'pos1_m' → 1."""
    match = re.search(r"[\(\[]\s*([a-zA-Zµ]+)\s*[\)\]]\s*$", name) or re.search(r"_([a-z]+)$", name)
    if match is None:
        return None
    return _UNIT_SCALES.get(match.group(1).lower().replace("µ", "u"))


def load_text(path: str | Path, time_col: str | None = None, pos_cols: list[str] | None = None,
              scale: float | None = None, release_time_s: float | None = None,
              step_m: float = DEFAULT_STEP_M, pulled_cart: int | None = None,
              input_col: str | None = None, rate_hz: float | None = None, raw: bool = False) -> IdData:
    """Load a delimited export. `scale` (m per unit) overrides a unit found in the names.
    The time base is the file's (a given `release_time_s` is on it); a file without a time
    column (columns named col0, col1, … when there is no header) needs `rate_hz`, and its
    time base is then k / rate_hz.

    With `input_col` (e.g. the ECP's 'Control Effort', a motor input) `u` is that column as
    recorded; otherwise `u` is the release step.
    """
    file = Path(path)
    if rate_hz is not None and time_col is None and (not np.isfinite(rate_hz) or rate_hz <= 0.0):
        raise IdentValueError("rate_hz", "a positive sample rate", rate_hz)
    chosen: dict[str, list[int]] = {}
    scales: list[float] = []

    def select(names: list[str]) -> list[list[int]]:
        """The time, position and input columns, each parsed straight into its own array
        (no copies taken afterwards: the positions are one C-ordered (N, n_y) block)."""
        chosen["y"] = (_default_position_columns(names) if pos_cols is None
                       else [_find_column(names, c) for c in pos_cols])
        chosen["t"] = ([] if rate_hz is not None and time_col is None
                       else [_default_time_column(names) if time_col is None else _find_column(names, time_col)])
        if time_col is None or pos_cols is None:
            _one_data_set(names, chosen["t"] + chosen["y"])
        chosen["u"] = [] if input_col is None else [_find_column(names, input_col)]
        scales.extend(_position_scale(names[i], scale) for i in chosen["y"])  # refused before the parse
        return [chosen["t"], chosen["y"], chosen["u"]]

    names, comments, (t_block, y, u_block) = _read(text_lines(file), count_lines(file), select)
    release_time_s, pulled_cart = _from_comments(comments, release_time_s, pulled_cart)
    if chosen["t"]:
        t = _one_column(t_block)
        t *= unit_scale(names[chosen["t"][0]]) or 1.0
    else:
        t = np.arange(y.shape[0]) / float(rate_hz or 1.0)
    y *= np.array(scales, dtype=np.float64)
    columns = tuple(names[i] for i in chosen["y"])
    u_in = _one_column(u_block) if chosen["u"] else None
    u_note = "" if input_col is None else f"input: column {names[chosen['u'][0]]!r} as recorded"
    t, _, y = check_arrays(t, None, y)
    _check_plausible(y)
    t.flags.writeable = y.flags.writeable = False   # handed to IdData as they are, not copied
    if u_in is not None:
        return IdData(t, u_in, y, release_time_s, pulled_cart, file.name, (u_note,), columns)
    if raw:
        return IdData(t, np.zeros(t.shape), y, release_time_s, pulled_cart, file.name, (), columns)
    return replace(_step_run(t, y, release_time_s, step_m, pulled_cart, file.name), columns=columns)


def _one_column(block: FloatArray) -> FloatArray:
    """An (N, 1) block as (N,), still owning its data when it did (no copy)."""
    if block.flags.owndata:
        block.resize((block.shape[0],), refcheck=False)
        return block
    return block[:, 0].copy()


def _from_comments(comments: dict[str, str], release_time_s: float | None, pulled_cart: int | None
                   ) -> tuple[float | None, int | None]:
    """The release time and pulled cart a `daq export` CSV states in its comments, unless given."""
    if release_time_s is None:
        try:
            stated = float(comments.get("release_time_s", ""))
        except ValueError:
            stated = float("nan")
        release_time_s = stated if np.isfinite(stated) else None
    if pulled_cart is None and comments.get("pulled_cart") in ("1", "2"):
        pulled_cart = int(comments["pulled_cart"])
    return release_time_s, pulled_cart


#: Largest |position| a lab track allows (m): anything beyond is a wrong scale or a broken file.
MAX_POSITION_M = 10.0


def _check_plausible(y: FloatArray) -> None:
    largest = float(np.max(np.abs(y))) if y.size else 0.0
    if largest > MAX_POSITION_M:
        raise IdentValueError("position amplitude", f"|position| ≤ {MAX_POSITION_M:g} m on a lab track "
                              "(check the scale, metres per unit)", f"{largest:.3g} m")


def _position_scale(name: str, scale: float | None) -> float:
    if scale is not None:
        if not np.isfinite(scale) or scale == 0.0:
            raise IdentValueError("scale", "a finite non-zero number of metres per unit", scale)
        return float(scale)
    found = unit_scale(name)
    if found is None:
        raise IdentValueError(f"scale of column {name!r}",
                              "a unit in the column name or --scale M_PER_UNIT", "neither")
    return found


def load_mcap(path: str | Path, step_m: float = DEFAULT_STEP_M,
              release_time_s: float | None = None, raw: bool = False) -> IdData:
    """Load a `daq` run file: samples, release time and pulled cart from its metadata.

    Read by `schemas.run_file` (the one damage-tolerant reader, with its limits), so a
    truncated file (a killed writer) yields every complete chunk, and a file beyond a limit
    (a decompression bomb) is refused; the last `cartlab.run` metadata record wins.
    """
    file = Path(path)
    try:
        read = run_file.read_run(file)
    except SchemaError as exc:
        raise DataFileError(f"cannot load the run file {file}: {exc}") from exc
    except OSError as exc:
        raise DataFileError(f"cannot read the run file {file}: {exc}") from exc
    if read.t_ns.size == 0:
        raise DataFileError(f"expected {topics.SAMPLES} samples in {file}, got none"
                            + (f" (unreadable: {read.stop_reason})" if read.stop_reason else ""))
    metadata = read.metadata
    first = metadata.first_t_ns if metadata is not None else int(read.t_ns[0])
    t = (read.t_ns - first).astype(np.float64) * 1e-9
    release = release_time_s
    if release is None and metadata is not None:
        release = metadata.release_time_s
    pulled = metadata.pulled_cart if metadata is not None else None
    t, _, y = check_arrays(t, None, read.pos_m)
    _check_plausible(y)
    names = tuple(f"pos{j + 1}_m" for j in range(y.shape[1]))
    data = (IdData(t, np.zeros(t.shape), y, release, pulled, file.name, (), names) if raw
            else replace(_step_run(t, y, release, step_m, pulled, file.name), columns=names))
    if read.complete:
        return data
    damage = (read.stop_reason or "file ended early")[:120]
    return replace(data, notes=(*data.notes, f"run file damaged after {len(t)} samples ({damage})"))


def _step_run(t: FloatArray, y: FloatArray, release_time_s: float | None, step_m: float,
              pulled_cart: int | None, name: str) -> IdData:
    """The record with the release step at the known release, or where the finder puts it."""
    if release_time_s is not None:
        return from_release(t, y, release_time_s, step_m, pulled_cart, name)
    return with_found_release(t, y, step_m, pulled_cart, name)


def _starts_as_mcap(file: Path) -> bool:
    try:
        return run_file.has_mcap_magic(file)
    except OSError as exc:
        raise DataFileError(f"cannot read {file}: {exc}") from exc


def load(path: str | Path, time_col: str | None = None, pos_cols: list[str] | None = None,
         scale: float | None = None, release_time_s: float | None = None,
         step_m: float = DEFAULT_STEP_M, input_col: str | None = None,
         rate_hz: float | None = None, raw: bool = False) -> IdData:
    """Load a run from an MCAP file (`.mcap`, or any file that starts with the MCAP magic: a
    `.mcap.part` left by a killed writer) or a delimited text export (anything else).

    `raw=True` loads the positions only (a zero input, no release estimated): a raw record
    with several releases, or one that starts in motion (`ident.releases` finds them)."""
    file = Path(path)
    if not file.exists():
        raise DataFileError(f"expected an existing file, got {str(file)!r}")
    if file.suffix == ".mcap" or _starts_as_mcap(file):
        return load_mcap(file, step_m, release_time_s, raw=raw)
    return load_text(file, time_col, pos_cols, scale, release_time_s, step_m, input_col=input_col, raw=raw,
                     rate_hz=rate_hz)
