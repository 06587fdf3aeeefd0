"""Loaders: files to `IdData` (thin adapters; the numerics live elsewhere).

Formats
- delimited text exports: our CSV (`time_s,pos1_m[,pos2_m]`, no options needed), Logger Pro
  CSV (`"Time (s)","Position (m)"`), ECP Executive / Teensy TSV (`Sample  Time  Commanded Pos
  Encoder 2 Pos …` then `[ 0 0.000 2 13 0.0000;` rows). Columns are chosen by name
  (case-insensitive substring), values scaled to metres (from a unit in the column name, or
  `scale` in metres per unit: `(mm)`, `[mm]` or `_mm`); the file is parsed by
  `ident.text_table` (headers, comments, separators, several data sets).
- `daq` MCAP runs (`/samples` SampleBatch messages, `cartlab.run` RunMetadata): the release
  time and pulled cart come from the metadata.

The input is the lab's position step `u = step_m·H(t - t_r)`; with no release time known the
step is placed at the first complete release the release finder finds (`ident.releases`),
which the fitters refine anyway.
"""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import numpy as np

from ident.data import FloatArray, IdData, check_arrays, from_release
from ident.errors import DataFileError, IdentValueError
from ident.releases.select import DEFAULT_STEP_M, with_found_release
from ident.text_table import Table, count_lines, read_columns, read_table, text_lines
from schemas import SchemaError, run_file, topics

_UNIT_SCALES = {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "in": 0.0254, "s": 1.0, "ms": 1e-3, "us": 1e-6}
#: Words in a column name that mark a position (the default position columns; never a drive).
POSITION_HINTS = ("pos", "encoder", "x1", "x2", "distance", "position")


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
            if any(h in n for h in POSITION_HINTS) and "command" not in n and "target" not in n]
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

    names, comments, (t_block, y, u_block) = read_columns(text_lines(file), count_lines(file), select)
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


#: The columns of a run's drive, as the device sent it (`SampleBatch.target`, `.duty`).
DRIVE_COLUMNS = ("target", "duty")


def load_mcap(path: str | Path, step_m: float = DEFAULT_STEP_M,
              release_time_s: float | None = None, raw: bool = False, input_col: str | None = None) -> IdData:
    """Load a `daq` run file: samples, release time and pulled cart from its metadata.
    With `input_col` (a column of `DRIVE_COLUMNS`: the run's drive) `u` is that column as
    recorded, as `load_text` does with a text export's drive column, less its value at the run's
    first sample (where daq zeroed the carts at rest under it).

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
    if input_col is not None:
        if read.drive is None:
            raise IdentValueError("--input", "a run whose samples carry the rig's drive "
                                  f"({', '.join(DRIVE_COLUMNS)}: the ecp dialect's)",
                                  f"{input_col!r} in a run without one")
        column = DRIVE_COLUMNS[_find_column(list(DRIVE_COLUMNS), input_col)]
        drive = read.drive[:, DRIVE_COLUMNS.index(column)]
        # the carts rest under the drive at the run's first sample (daq armed on them still and
        # zeroed them there), so the drive acts from its value there: an input on at the first
        # sample would be switched on there (`ident.data.input_jumps`), and a motor pulse's
        # off-edge had fitted 49 % instead of 99.96 %
        u = (drive - drive[0]).astype(np.float64)
        note = f"input: the run's {column!r} as recorded, from its value at the run's first sample ({drive[0]:.6g})"
        data = IdData(t, u, y, release, pulled, file.name, (note,), names)
    elif raw:
        data = IdData(t, np.zeros(t.shape), y, release, pulled, file.name, (), names)
    else:
        data = replace(_step_run(t, y, release, step_m, pulled, file.name), columns=names)
    if read.complete:
        return data
    damage = (read.stop_reason or "file ended early")[:120]
    return replace(data, notes=(*data.notes, f"run file damaged after {len(t)} samples ({damage})"))


def run_drive_columns(path: str | Path) -> tuple[str, ...]:
    """`DRIVE_COLUMNS` when `path` is a `daq` run whose samples carry the rig's drive, else ()."""
    read = _read_run_quietly(Path(path))
    return DRIVE_COLUMNS if read is not None and read.drive is not None else ()


def run_drive(path: str | Path) -> str | None:
    """The column a `daq` run begun by the rig's drive (`RunMetadata.trigger` "drive": a motor
    pulse's edge) is fitted against: its response is to that drive, not a hand's release.
    `duty` when it changes in the run, else `target` (a lab export's replay sends no duty); None
    for any other file."""
    read = _read_run_quietly(Path(path))
    if read is None or read.drive is None or read.metadata is None or read.metadata.trigger != "drive":
        return None
    return next((DRIVE_COLUMNS[j] for j in (1, 0) if np.ptp(read.drive[:, j]) > 0.0), None)


def _read_run_quietly(file: Path) -> run_file.RunContents | None:
    """The run file at `file`, or None when it is not one that can be read."""
    try:
        return run_file.read_run(file) if file.is_file() and is_run_file(file) else None
    except (SchemaError, OSError, DataFileError):
        return None


def _step_run(t: FloatArray, y: FloatArray, release_time_s: float | None, step_m: float,
              pulled_cart: int | None, name: str) -> IdData:
    """The record with the release step at the known release, or where the finder puts it."""
    if release_time_s is not None:
        return from_release(t, y, release_time_s, step_m, pulled_cart, name)
    return with_found_release(t, y, step_m, pulled_cart, name)


def is_run_file(file: Path) -> bool:
    """True for an MCAP file: `.mcap`, or any file that starts with the MCAP magic (a
    `.mcap.part` left by a killed writer)."""
    try:
        return file.suffix == ".mcap" or run_file.has_mcap_magic(file)
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
    if is_run_file(file):
        return load_mcap(file, step_m, release_time_s, raw=raw, input_col=input_col)
    return load_text(file, time_col, pos_cols, scale, release_time_s, step_m, input_col=input_col, raw=raw,
                     rate_hz=rate_hz)


__all__ = ["DRIVE_COLUMNS", "MAX_POSITION_M", "POSITION_HINTS", "Table", "is_run_file", "load", "load_mcap",
           "load_text", "read_table", "run_drive", "run_drive_columns", "unit_scale"]
