"""`ident releases PATH`: every release in a raw record (text export or MCAP run).

For each release: where the hand let go (`release_time_s`, on the file's time base), the end
of its free response (before the next release or touch, or the end of the record), the
pulled cart, the carts that move freely, and whether the end of the record cut it. A JSON
array with `--json`, a table otherwise. Exit status 0 (also when none is found), 2 on
unusable input.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from ident.commands.run_file_options import add_run_file_options


def add_parser(subparsers: Any) -> None:
    parser = subparsers.add_parser("releases", help="list every release in a raw record",
                                   description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_run_file_options(parser, None)
    parser.add_argument("--json", action="store_true", help="print a JSON array")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ident.errors import IdentError

    try:
        releases = releases_of_file(args)
    except IdentError as exc:
        print(f"ident releases: error: {exc}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps([r.to_dict() for r in releases], indent=2))
    else:
        print(table(args.path, releases))
    note = drive_note(args, releases)
    if not releases and (driven := drive_without_release(args)):
        note = f"note: no hand release; {driven}"
    if note:
        print(note, file=sys.stderr)
    return 0


#: Column names of a recorded drive (a motor's command, `ident diagnose --input`).
DRIVE_HINTS = ("effort", "input", "duty", "target", "voltage", "current", "command", "pwm", "force")
#: A drive that switches at most DRIVE_LEAD_S before or DRIVE_LAG_S after a listed release is named
#: beside it (the finder dated a 2025 ECP-210 motor pulse's off-switch in a daq run 1 ms before it).
DRIVE_LEAD_S = 0.2
DRIVE_LAG_S = 0.05


def drive_note(args: argparse.Namespace, releases: list[Any]) -> str | None:
    """A note when a file has a drive (`recorded_drives`) that switches within `DRIVE_LEAD_S`
    before or `DRIVE_LAG_S` after a listed release: in the positions alone a force step on a
    cart at rest is a release from a still hold (a motor pulse's on and off), and the record
    is the response to that drive (`ident diagnose FILE --input COLUMN`). None otherwise."""
    if not releases:
        return None
    for name, switches in recorded_drives(args):
        led = [(r.number, r.release_time_s - float(s)) for r in releases for s in switches
               if -DRIVE_LAG_S <= r.release_time_s - float(s) <= DRIVE_LEAD_S]
        if led:
            which = ", ".join(f"{1e3 * abs(lead):.0f} ms {'before' if lead >= 0 else 'after'} release {k}"
                              for k, lead in led)
            return (f"note: column {name!r} switches {which}: a recorded drive moves the carts there, not a "
                    f"hand; `{_command(args, name)}` fits the response to it")
    return None


def drive_without_release(args: argparse.Namespace, command: str = "diagnose") -> str | None:
    """For a record with no release: what to do when a column named like a drive switches in
    it (the carts' motion is the response to that drive, `ident COMMAND --input`); None when
    none does. Fitted as a free response from where it first moves, such a record had named
    a 0.19 Hz "coupled mode" at 12 % fit (the 2025 ECP-210 motor pulses, 07-Feb-2025_11_16_25)."""
    drives = recorded_drives(args)
    if not drives:
        return None
    name, switches = drives[0]
    at = ", ".join(f"{float(s):.2f}" for s in switches[:4]) + (", ..." if switches.size > 4 else "")
    return (f"column {name!r} switches at {at} s: a recorded drive moves the carts; "
            f"`{_command(args, name, command)}` fits the response to it")


def _command(args: argparse.Namespace, drive: str, command: str = "diagnose") -> str:
    """The `ident COMMAND` line that fits the response to `drive`, with the loader's options
    as given."""
    import shlex

    words = ["ident", command, args.path]
    if args.time_col is not None:
        words += ["--time", args.time_col]
    for column in args.pos_cols or []:
        words += ["--pos", column]
    if args.scale is not None:
        words += ["--scale", repr(args.scale)]
    if args.rate_hz is not None:
        words += ["--rate-hz", repr(args.rate_hz)]
    return shlex.join([*words, "--input", drive])


def recorded_drives(args: argparse.Namespace) -> list[tuple[str, Any]]:
    """(name, switch times (s) on the file's time base) of every column of a text export named
    like a drive (`DRIVE_HINTS`, not a position), or of a `daq` run's drive (`DRIVE_COLUMNS`),
    that switches at least once."""
    import numpy as np

    from ident.data import input_jumps
    from ident.errors import IdentError
    from ident.io import load

    out = []
    for name in _drive_names(args.path):
        try:
            data = load(args.path, time_col=args.time_col, pos_cols=args.pos_cols, scale=args.scale,
                        input_col=name, rate_hz=args.rate_hz, raw=True)
        except IdentError:
            continue
        jumps = input_jumps(data.u)
        if jumps.size:
            out.append((name, data.t[np.clip(jumps + 1, 0, data.n_samples - 1)]))
    return out


def _drive_names(path_text: str) -> list[str]:
    """The columns of the file that may hold a drive: a run's `DRIVE_COLUMNS` when its samples
    carry them, a text export's columns named like a drive (`DRIVE_HINTS`, not a position)."""
    import itertools
    from pathlib import Path

    from ident.errors import IdentError
    from ident.io import POSITION_HINTS, is_run_file, run_drive_columns
    from ident.text_table import MAX_HEAD_LINES, read_table, text_lines

    path = Path(path_text)
    try:
        if is_run_file(path):
            return list(run_drive_columns(path))
        # the names only: the header and the first rows, not the whole record again
        names = read_table(itertools.islice(text_lines(path), MAX_HEAD_LINES + 2)).names
    except (IdentError, OSError):
        return []
    return [n for n in names if any(h in n.lower() for h in DRIVE_HINTS)
            and not any(h in n.lower() for h in POSITION_HINTS)]   # a commanded position is no force


def use_run_drive(args: argparse.Namespace, command: str) -> None:
    """A `daq` run begun by the rig's drive is fitted as the response to it (`ident.io.run_drive`):
    `args.input_col` is set to the drive's column, unless a release was asked for (`--release`,
    `--all`, `--release-s`); stderr says so."""
    if getattr(args, "all", False) or any(getattr(args, name, None) is not None
                                          for name in ("release_number", "release")):
        return
    from ident.io import run_drive

    drive = None if args.input_col is not None else run_drive(args.path)
    if drive is not None:
        args.input_col = drive
        print(f"ident {command}: note: the run began where the rig's drive switched (a motor pulse, not a hand): "
              f"the response to its {drive!r} is fitted (as --input {drive})", file=sys.stderr)


def releases_of_file(args: argparse.Namespace) -> list[Any]:
    """Load the file raw as the arguments say and find its releases."""
    from ident.io import load
    from ident.releases import find_releases

    data = load(args.path, time_col=args.time_col, pos_cols=args.pos_cols, scale=args.scale,
                rate_hz=args.rate_hz, raw=True)
    return find_releases(data.t, data.y, data.cart_numbers())


def table(path: str, releases: list[Any]) -> str:
    """A readable table of releases."""
    if not releases:
        return f"{path}: no release found"
    lines = [f"{path}: {len(releases)} release(s)",
             "   #  release (s)   end (s)  pulled  moving   amplitude (mm)  ended by"]
    for r in releases:
        amp = "/".join(f"{1e3 * a:.1f}" for a in r.amplitudes_m)
        ending = r.ended_by.replace("_", " ") + ("" if r.complete else " (cut)")
        lines.append(f"{r.number:4d}  {r.release_time_s:11.3f}  {r.end_time_s:8.3f}  cart {r.pulled_cart}"
                     f"  {','.join(map(str, r.moving_carts)):6s}  {amp:>14s}  {ending}")
    return "\n".join(lines)
