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
    if note:
        print(note, file=sys.stderr)
    return 0


#: Column names of a recorded drive (a motor's command, `ident diagnose --input`).
DRIVE_HINTS = ("effort", "input", "duty", "voltage", "current", "command", "pwm", "force")
#: A drive that switches at most this long (s) before a listed release is named beside it.
DRIVE_LEAD_S = 0.2


def drive_note(args: argparse.Namespace, releases: list[Any]) -> str | None:
    """A note when a text export has a column named like a drive (`DRIVE_HINTS`) that switches
    within `DRIVE_LEAD_S` before a listed release: in the positions alone a force step on a
    cart at rest is a release from a still hold (a motor pulse's on and off), and the record
    is the response to that drive (`ident diagnose FILE --input COLUMN`). None otherwise."""
    import itertools
    from pathlib import Path

    import numpy as np

    from ident.data import input_jumps
    from ident.errors import IdentError
    from ident.io import POSITION_HINTS, load
    from ident.text_table import MAX_HEAD_LINES, read_table, text_lines

    path = Path(args.path)
    if not releases or path.suffix == ".mcap":
        return None
    try:   # the names only: the header and the first rows, not the whole record again
        names = read_table(itertools.islice(text_lines(path), MAX_HEAD_LINES + 2)).names
    except (IdentError, OSError):
        return None
    drives = [n for n in names if any(h in n.lower() for h in DRIVE_HINTS)
              and not any(h in n.lower() for h in POSITION_HINTS)]   # a commanded position is no force
    for name in drives:
        try:
            data = load(path, time_col=args.time_col, pos_cols=args.pos_cols, scale=args.scale,
                        input_col=name, rate_hz=args.rate_hz, raw=True)
        except IdentError:
            continue
        switches = data.t[np.clip(input_jumps(data.u) + 1, 0, data.n_samples - 1)]
        led = [(r.number, r.release_time_s - float(s)) for r in releases for s in switches
               if 0.0 <= r.release_time_s - float(s) <= DRIVE_LEAD_S]
        if led:
            which = ", ".join(f"{1e3 * lead:.0f} ms before release {k}" for k, lead in led)
            return (f"note: column {name!r} switches {which}: a recorded drive moves the carts there, not a "
                    f"hand; `ident diagnose {args.path} --input '{name}'` fits the response to it")
    return None


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
