"""`ident diagnose PATH`: what the linear simulation gets wrong, the cause, the gain.

Loads an MCAP run or a text export (`ident.io.load`, put on a uniform grid by
`ident.data.make_uniform`), runs `ident.diagnose.diagnose` (with `--input`, a measured force
input column enters the model) and prints one JSON object (the
`schemas.diagnosis.DiagnosisReport` record) with `--json`, a readable summary otherwise;
`--figures DIR` writes the figures. Exit status 0 on success, 2 on unusable input. With
`--all`, a release that cannot be diagnosed is named on stderr and left out of the array; the
status is 2 only when none can be.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from ident.commands.aliases import add_deprecated_alias
from ident.commands.run_file_options import add_release_options, add_run_file_options


def add_parser(subparsers: Any) -> None:
    parser = subparsers.add_parser("diagnose", help="name what the linear model misses and measure the gain",
                                   description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_run_file_options(parser, "1: one cart, 2: the two-cart chain; default: from the columns")
    parser.add_argument("--step-m", dest="step_m", type=float, default=None,
                        help="step size (m); default: estimated with the other parameters")
    add_deprecated_alias(parser, "--step", "--step-m", "step_m", float)
    parser.add_argument("--input", dest="input_col", default=None,
                        help="a measured force input column (e.g. 'Control Effort' for a motor pulse): "
                             "modelled with a gain per cart, so its response is never taken for a mode; "
                             "default: a hand release, no input")
    parser.add_argument("--from-s", dest="from_s", type=float, default=None,
                        help="with --input: diagnose the record from this time (s, on the file's time base); "
                             "a long record is otherwise fitted from its start, as far as a work grid that "
                             "resolves its modes reaches")
    parser.add_argument("--to-s", dest="to_s", type=float, default=None,
                        help="with --input: diagnose the record up to this time (s)")
    add_release_options(parser)
    parser.add_argument("--json", action="store_true", help="print one JSON object (an array with --all)")
    parser.add_argument("--figures", type=Path, default=None, help="write figures (PNG, SVG) here")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ident.commands.releases import use_run_drive
    from ident.errors import IdentError

    try:
        use_run_drive(args, "diagnose")
        results = diagnose_releases(args)
    except IdentError as exc:
        print(f"ident diagnose: error: {exc}", file=sys.stderr)
        return 2
    if args.figures is not None:
        from ident.diagnose.figures import write_figures
        from ident.progress import stage

        stage("writing figures")
        for number, (result, carts) in results.items():
            out = args.figures if not args.all else args.figures / f"release{number}"
            write_figures(result, out, cart_numbers=carts)
    reports = [result.report for result, _ in results.values()]
    if args.all:
        print("[" + ",\n".join(r.model_dump_json(indent=2) for r in reports) + "]" if args.json
              else "\n\n".join(f"release {k}:\n{summary(r)}" for k, r in zip(results, reports, strict=True)))
    else:
        print(reports[0].model_dump_json(indent=2) if args.json else summary(reports[0]))
    return 0


def diagnose_releases(args: argparse.Namespace) -> dict[int, tuple[Any, tuple[int, ...]]]:
    """Load the file raw, pick the release(s) and diagnose each: release number (0 for the
    whole record) -> (`Diagnosis`, the cart numbers of its columns)."""
    from ident.commands.releases import drive_without_release
    from ident.data import make_uniform
    from ident.errors import IdentValueError
    from ident.io import load
    from ident.progress import stage
    from ident.releases import FIRST_COMPLETE, choose, releases_of

    stage("loading")
    # raw: a record may hold several releases, or start in motion
    raw = load(args.path, time_col=args.time_col, pos_cols=args.pos_cols, scale=args.scale,
               input_col=args.input_col, rate_hz=args.rate_hz, raw=True)
    data = make_uniform(raw)
    if args.input_col is not None:   # a motor input: the record (or the stretch asked for) as one response
        return {0: diagnose_window(args, data, None, raw.y, args.from_s, args.to_s)}
    if args.from_s is not None or args.to_s is not None:
        raise IdentValueError("--from-s/--to-s", "a record with --input (a hand release is chosen with "
                              "--release K; see `ident releases`)", "no --input")
    stage("finding the releases")
    # on the record as loaded, as `ident releases` and `ident fit` find them (the same instants)
    releases = releases_of(raw)
    if args.all:
        if not releases:
            raise IdentValueError("--all", "a record with releases (see `ident releases`)", "none found")
        return _each(args, data, raw.y, releases)
    if not releases and args.release_number is None:
        driven = drive_without_release(args)
        if driven:   # no free response to fit: the drive's response needs the drive
            raise IdentValueError("record", "a hand release (see `ident releases`), or --input for a driven record",
                                  f"no release found, and {driven}")
        return {0: diagnose_window(args, data, None, raw.y)}
    release = choose(releases, args.release_number or FIRST_COMPLETE)
    return {release.number: diagnose_window(args, data, release, raw.y)}


def _each(args: argparse.Namespace, data: Any, readings: Any,
          releases: list[Any]) -> dict[int, tuple[Any, tuple[int, ...]]]:
    """Every release diagnosed on its own: one that cannot be (a window too short to fit) is
    named on stderr and the others go on (one 47-sample window had refused the whole record);
    the first error is raised when none can be."""
    from ident.errors import IdentError

    results: dict[int, tuple[Any, tuple[int, ...]]] = {}
    first: IdentError | None = None
    for release in releases:
        try:
            results[release.number] = diagnose_window(args, data, release, readings)
        except IdentError as exc:
            first = first or exc
            print(f"ident diagnose: release {release.number} at {release.release_time_s:.3f} s not diagnosed: {exc}",
                  file=sys.stderr)
    if not results:
        assert first is not None
        raise first
    return results


def diagnose_window(args: argparse.Namespace, data: Any, release: Any, readings: Any, start_s: float | None = None,
                    stop_s: float | None = None) -> tuple[Any, tuple[int, ...]]:
    """Diagnose `data` on the release's window (None: the whole record, or [`start_s`,
    `stop_s`] of it) with the carts that move freely (`--carts` overrides): a held or constant
    column is never fitted as free. `readings` (M, n_out) the positions as loaded, before
    `data` was made uniform (their encoder lattice)."""
    from ident.diagnose import diagnose
    from ident.errors import IdentValueError
    from ident.progress import stage
    from ident.releases import moving_columns

    numbers = data.cart_numbers()
    moving = moving_columns(data, release)
    if not moving:
        raise IdentValueError("positions", "a cart that moves", "constant positions")
    carts = args.carts or min(len(moving), 2)
    if carts == 1 and args.carts is None:
        # the free cart first, then the others (a held cart's motion may enter as an input)
        columns = moving[:1] + [j for j in range(data.n_outputs) if j not in moving]
    else:
        columns = moving[:2] if len(moving) >= carts else list(range(data.n_outputs))
    y = data.y[:, columns]
    stage("fitting the linear model and selecting effects")
    result = diagnose(data.t, y, carts=carts, step_m=args.step_m, source=Path(args.path).name,
                      u=None if args.input_col is None else data.u,
                      start_s=start_s if release is None else release.release_time_s,
                      stop_s=stop_s if release is None else release.end_time_s, readings=readings[:, columns])
    return result, tuple(numbers[j] for j in columns[:carts])


def diagnose_file(args: argparse.Namespace) -> Any:
    """Load the file as the arguments say and diagnose its first complete release, or the
    whole record when none is found (a `Diagnosis`)."""
    args = argparse.Namespace(**{"release_number": None, "all": False, "from_s": None, "to_s": None, **vars(args)})
    return next(iter(diagnose_releases(args).values()))[0]


def summary(report: Any) -> str:
    """A readable summary of a `DiagnosisReport`."""
    from ident.diagnose import explain

    ev = report.evidence
    lines = [(f"{report.source}: {report.carts} cart(s), {report.sample_rate_hz:.1f} Hz, "
              f"release at {report.release_time_s:.3f} s, fitted from {report.window_start_s:.3f} s"),
             f"baseline   {report.baseline.model}: fit {report.baseline.fit_percent:.3f} %",
             "evidence   residual " + ("white" if ev.residual_is_white else "NOT white")
             + f" ({ev.whiteness_fraction_outside:.0%} of lags outside), rms {1e3 * ev.residual_rms_m:.3f} mm"
             f" vs noise {1e3 * ev.noise_std_m:.3f} mm; envelope {ev.envelope_shape.replace('_', ' ')}"
             f" over {ev.envelope_peaks} peaks; {explain.rest_words(ev.stuck_for_s, ev.rest_offset_m)}"
             + (f"; encoder lattice {1e6 * ev.lattice_quantum_m:.2f} um" if ev.lattice_quantum_m else "")
             + (f"; second frequency {ev.second_frequency_hz:.2f} Hz" if ev.second_frequency_hz else ""),
             "first round (whole-window fit %, gain, likelihood ratio window/blocked-CV vs bound):"]
    for c in report.candidates:
        params = ", ".join(f"{k}={v:.4g}" for k, v in c.parameters.items()) or c.note
        lines.append(f"  {'*' if c.effect == report.cause else ' '} {c.effect:17s} {c.fit_percent:8.3f} %"
                     f" {c.gain_points:+8.3f}  LR {c.lr_train:9.1f}/{c.lr_validation:9.1f}"
                     f" vs {c.threshold_train:.1f}/{c.threshold_validation:.1f}  {params}")
    lines.append("effects (forward selection, ranked by own gain; CV ratio vs noise bound):")
    for e in report.effects:
        params = ", ".join(f"{k}={v:.4g}" + (f"±{e.parameter_std[k]:.2g}" if k in e.parameter_std else "")
                           for k, v in e.parameters.items())
        lines.append(f"  {e.rank}. {e.effect:17s} {e.gain_points:+8.3f} points  CV {e.cv_ratio:9.1f} vs "
                     f"{e.cv_threshold:.1f}{'' if e.material else '  (immaterial)'}  {params}")
    if not report.effects:
        lines.append("  none: no effect beats the noise")
    lines.append(f"cause      {report.cause}; whole-window fit {report.baseline.fit_percent:.3f} % -> "
                 f"{report.extended.fit_percent:.3f} %, gain {report.gain_points:+.3f} points")
    lines.append("corrected  " + ", ".join(f"{k}={v:.5g}" for k, v in report.corrected_linear.items()))
    lines.append("")
    lines.append(report.explanation)
    lines.append("")
    lines.append("validation: " + report.validation)
    return "\n".join(lines)
