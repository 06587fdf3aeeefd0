"""`ident fit PATH`: identify one run file and print its `FitReport` (text or JSON).

The "fit a run" use case (`ident.fitrun.fit_file`: load, simple identification by RK4/Euler,
PEM; no diagnosis, no figures), printed by `ident.report.text`. Exit status 0 on success,
2 on unusable input or a failed fit.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path
from typing import Any

from ident.commands.run_file_options import add_release_options, add_run_file_options

METHODS = ("pem", "rk4", "euler", "all")


def add_parser(subparsers: Any) -> None:
    parser = subparsers.add_parser("fit", help="fit a run file: PEM and/or the physical model",
                                   description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_run_file_options(parser, "1: one cart (order 2), 2: both carts (order 4); default: the moving columns")
    parser.add_argument("--method", choices=METHODS, default="all")
    parser.add_argument("--input", dest="input_col", default=None,
                        help="input column (e.g. 'Control Effort' for a motor input); default: the release step")
    parser.add_argument("--release-s", dest="release", type=float, default=None,
                        help="release time (s) if known (fits the whole record from there)")
    add_release_options(parser)
    parser.add_argument("--step-m", type=float, default=None,
                        help="pull distance (m); default: a raw record's release's own signed pull, else 0.15")
    parser.add_argument("--friction", action="store_true",
                        help="fit the Euler simulation with dry friction (Coulomb, m/s²; its parameters from the "
                             "converged simulation, the handout's Euler recursion beside them)")
    parser.add_argument("--order", type=int, default=None, help="PEM order (default: 2 per cart)")
    parser.add_argument("--noise-model", choices=("oe", "innovation"), default="oe",
                        help="PEM noise model: output error (white noise) or innovation form with K")
    parser.add_argument("--json", action="store_true", help="print the FitReport as JSON")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ident.commands.releases import use_run_drive
    from ident.errors import IdentError
    from ident.report.text import format_fit_report

    try:
        use_run_drive(args, "fit")
        numbers = release_numbers(args)
        fits = [fit_path(args, number) for number in numbers]
    except IdentError as exc:
        print(f"ident fit: error: {exc}", file=sys.stderr)
        return 2
    failed = [f.report for f in fits if f.report.status == "failed"]
    if args.all:
        if args.json:
            print("[" + ",\n".join(f.report.model_dump_json(indent=2) for f in fits) + "]")
        else:
            print("\n\n".join(f"release {k}:\n" + format_fit_report(f.report, args.path)
                              for k, f in zip(numbers, fits, strict=True)))
        return 2 if len(failed) == len(fits) else 0
    report = fits[0].report
    if report.status == "failed":
        from ident.commands.releases import drive_without_release

        driven = drive_without_release(args, "fit") if args.input_col is None and args.release is None else None
        print(f"ident fit: error: {report.reason}" + (f"; {driven}" if driven else ""), file=sys.stderr)
        return 2
    print(report.model_dump_json(indent=2) if args.json else format_fit_report(report, args.path))
    return 0


def release_numbers(args: argparse.Namespace) -> list[int | None]:
    """Which releases to fit: all of them (`--all`), release K (`--release K`), or the first
    complete one; none (the whole record as loaded) with a motor input or a known release time."""
    from ident.releases import FIRST_COMPLETE

    if args.input_col is not None or args.release is not None:
        if args.all or args.release_number is not None:
            from ident.errors import IdentValueError

            raise IdentValueError("--release/--all", "no --input or --release-s with them "
                                  "(a release is found in a raw record of a hand release)", "both")
        return [None]
    if args.all:
        from ident.io import load
        from ident.releases import releases_of

        data = load(args.path, args.time_col, args.pos_cols, args.scale, rate_hz=args.rate_hz, raw=True)
        count = len(releases_of(data))
        if count == 0:
            from ident.errors import IdentValueError

            raise IdentValueError("--all", "a record with releases (see `ident releases`)", "none found")
        return list(range(1, count + 1))
    return [args.release_number if args.release_number is not None else FIRST_COMPLETE]


def fit_path(args: argparse.Namespace, number: int | None = None) -> Any:
    """The use case on `args.path` as the options say, on release `number` (None: the
    record as loaded): a `ident.fitrun.RunFit`."""
    from ident.fitrun import FitSettings, RunFileOptions, RunIdentity, fit_file
    from ident.fitrun.analysis import Method
    from ident.releases.select import select_or_whole

    options = RunFileOptions(time_col=args.time_col,
                             pos_cols=None if args.pos_cols is None else tuple(args.pos_cols),
                             scale=args.scale, release_time_s=args.release, step_m=args.step_m,
                             input_col=args.input_col, rate_hz=args.rate_hz)
    methods: tuple[Method, ...] = ("rk4", "euler", "pem") if args.method == "all" else (args.method,)
    settings = FitSettings(methods=methods, carts=args.carts, order=args.order,
                           noise_model=args.noise_model, step_input=args.input_col is None,
                           friction=args.friction)
    who = RunIdentity(run_id=run_id_of(Path(args.path)), worker="ident-fit")
    return fit_file(args.path, who, options=options, settings=settings, diagnose=False,
                    release=number, select=select_or_whole)


def run_id_of(path: Path) -> str:
    """A run id from a file name (a record's names are checked: no dots first, no slashes)."""
    return re.sub(r"[^A-Za-z0-9_.-]", "-", path.stem).lstrip(".-")[:128] or "run"
