"""The `daq` console script: `daq run|serve|info|export|recover ...`.

    daq run --port URL [--dialect cartlab|csv|ecp] [--bench NAME] [--runs-dir DIR]
            [--zenoh-config FILE | --listen ENDPOINT ... --connect ENDPOINT ...] [--no-zenoh]
            [--until-eof] [--counts-per-m N] [--invert 1|2]
    daq serve [--host H] [--port P] [--connect ENDPOINT ...] [--runs-dir DIR] ...   (the bench page;
            every option after `serve` goes to `daq.web`: `daq serve --help` lists them)
    daq info RUN.mcap [--json]
    daq export RUN.mcap --format csv|mat|json [-o FILE]
    daq recover PATH            (a .mcap.part file or a runs directory)

Exit codes: 0 success, 1 an error a person can act on (message on stderr), 2 bad usage.
"""

from __future__ import annotations

import argparse
import json
import logging
import signal
import sys
from collections.abc import Sequence
from pathlib import Path
from types import FrameType

from pydantic import ValidationError

from daq.errors import DaqError
from daq.frames import DIALECTS
from schemas import SchemaError, topics
from schemas.bus import DEFAULT_LISTEN, BusConfig

log = logging.getLogger(__name__)
PACKAGE_LOG = logging.getLogger("daq")   # the console script shows what every daq module logs


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="daq", description="Bench acquisition: serial encoders → "
                                     "release detection → live Zenoh samples and one MCAP file per run.")
    parser.add_argument("-v", "--verbose", action="store_true", help="log detector state changes")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    run = sub.add_parser("run", help="acquire from a serial port (or sim://, replay://)")
    run.add_argument("--port", required=True, help="serial URL: /dev/ttyACM0, sim://?..., replay://FILE?speed=max")
    run.add_argument("--dialect", choices=DIALECTS, default="cartlab")
    run.add_argument("--bench", default="bench1", help="bench name in Zenoh keys (default bench1)")
    run.add_argument("--runs-dir", type=Path, default=Path("runs"), help="where run files go (default ./runs)")
    run.add_argument("--zenoh-config", help="a Zenoh JSON5 config file (router/client deployments)")
    run.add_argument("--listen", action="append", default=None, metavar="ENDPOINT",
                     help=f"Zenoh listen endpoint, repeatable (default {DEFAULT_LISTEN})")
    run.add_argument("--connect", action="append", default=[], metavar="ENDPOINT",
                     help="Zenoh endpoint to connect to, repeatable")
    run.add_argument("--mode", choices=("peer", "client", "router"), default="peer")
    run.add_argument("--no-zenoh", action="store_true", help="record only, publish nothing")
    run.add_argument("--until-eof", action="store_true", help="stop when a finite stream (replay, sim) ends")
    run.add_argument("--counts-per-m", type=float, default=None,
                     help="encoder counts per metre (default: from the device's $I line)")
    run.add_argument("--invert", type=int, choices=(1, 2), action="append", default=[],
                     help="reverse the sign of channel 1 or 2 (repeatable)")
    run.add_argument("--baudrate", type=int, default=115200)
    run.set_defaults(func=_cmd_run)

    serve = sub.add_parser("serve", add_help=False, help="serve the bench page (live plot, Zero/Arm, runs, "
                           "fits); 'daq serve --help' for its options")
    serve.set_defaults(func=_cmd_serve)

    info = sub.add_parser("info", help="metadata, counters and release time of a run file")
    info.add_argument("file", type=Path)
    info.add_argument("--json", action="store_true", help="print JSON (has release_time_s)")
    info.set_defaults(func=_cmd_info)

    export = sub.add_parser("export", help="export a run to CSV, MAT or JSON")
    export.add_argument("file", type=Path)
    export.add_argument("--format", choices=("csv", "mat", "json"), required=True)
    export.add_argument("-o", "--output", type=Path, default=None,
                        help="output file (default: beside the run, same stem; '-' = stdout for csv/json)")
    export.set_defaults(func=_cmd_export)

    recover = sub.add_parser("recover", help="recover .mcap.part files left by a crash")
    recover.add_argument("path", type=Path, help="a .mcap.part file or a runs directory")
    recover.set_defaults(func=_cmd_recover)
    return parser


def _bus_config(args: argparse.Namespace) -> BusConfig | None:
    if args.no_zenoh:
        return None
    if args.zenoh_config:
        if not Path(args.zenoh_config).is_file():
            raise DaqError(f"--zenoh-config: expected an existing JSON5 file, got {args.zenoh_config!r}")
        return BusConfig(config_file=args.zenoh_config)
    listen = args.listen if args.listen is not None else ([] if args.connect else [DEFAULT_LISTEN])
    return BusConfig(mode=args.mode, listen=listen, connect=args.connect)


def _cmd_run(args: argparse.Namespace) -> int:
    from daq.port_url import check_port
    from daq.service import Service, ServiceConfig

    check_port(args.port)

    signs = (-1 if 1 in args.invert else 1, -1 if 2 in args.invert else 1)
    config = ServiceConfig(port=args.port, runs_dir=args.runs_dir, bench=args.bench, dialect=args.dialect,
                           bus=_bus_config(args), counts_per_m=args.counts_per_m, signs=signs,
                           until_eof=args.until_eof, baudrate=args.baudrate)
    service = Service(config)

    def stop(signum: int, _frame: FrameType | None) -> None:
        log.info("signal %d: finishing the open run and stopping", signum)
        service.request_stop()

    previous = {sig: signal.signal(sig, stop) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        n_runs = service.run()
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    log.info("stopped: %d run(s) recorded in %s", n_runs, args.runs_dir)
    return 0


def _cmd_serve(args: argparse.Namespace) -> int:
    """The bench page: `daq.web` parses the rest of the command line (imported here, so that
    `daq run` never loads the web stack)."""
    from daq.web.__main__ import main as serve_main

    return serve_main(args.serve_argv)


def _cmd_info(args: argparse.Namespace) -> int:
    from daq.run_file import load_run, run_info

    info = run_info(load_run(args.file), args.file)
    if args.json:
        print(json.dumps(info, indent=2))
        return 0
    meta = info.pop("metadata") or {}
    counters = meta.pop("counters", {})
    for key, value in info.items():
        print(f"{key:>16}: {value}")
    for key in ("bench", "run_id", "dialect", "port", "counts_per_m", "signs", "n_channels", "pulled_cart",
                "detector_method", "software_version", "started_utc", "ended_utc"):
        print(f"{key:>16}: {meta.get(key)}")
    print(f"{'counters':>16}: " + ", ".join(f"{k}={v}" for k, v in counters.items()
                                             if k not in ("schema_version", "gap_intervals")))
    print(f"{'gaps':>16}: {len(counters.get('gap_intervals', []))}")
    return 0


def _cmd_export(args: argparse.Namespace) -> int:
    from daq.run_file import export_csv, export_json, export_mat, load_run

    run = load_run(args.file)
    stem = args.file.name.removesuffix(".part").removesuffix(".mcap")
    out = args.output or args.file.with_name(f"{stem}.{args.format}")
    if args.format == "mat":
        if str(out) == "-":
            raise DaqError("export --format mat: expected an output file, got '-' (stdout)")
        export_mat(run, out)
    else:
        text = export_csv(run) if args.format == "csv" else export_json(run, args.file)
        if str(out) == "-":
            sys.stdout.write(text)
            return 0
        out.write_text(text)
    print(out)
    return 0


def _cmd_recover(args: argparse.Namespace) -> int:
    from daq.recorder import recover_dir, recover_one

    path: Path = args.path
    if path.is_dir():
        results = recover_dir(path)
    elif path.name.endswith(topics.PART_SUFFIX) and (path.is_file() or path.is_symlink()):
        results = [recover_one(path)]
    else:
        raise DaqError(f"recover: expected a .mcap.part file or a runs directory, got {str(path)!r}")
    for result in results:
        print(f"{result.part.name}: {result.outcome}: {result.detail}")
    if not results:
        print(f"nothing to recover in {path}")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args, rest = parser.parse_known_args(argv)
    if args.command == "serve":
        args.serve_argv = rest   # `daq serve` owns everything after its name
    elif rest:
        parser.error(f"unrecognized arguments: {' '.join(rest)}")
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("daq: %(message)s"))
    PACKAGE_LOG.addHandler(handler)
    PACKAGE_LOG.setLevel(logging.DEBUG if args.verbose else logging.INFO)
    try:
        code: int = args.func(args)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first["loc"])
        print(f"daq {args.command}: {exc.title} {where}: {first['msg']}", file=sys.stderr)
        return 1
    except (DaqError, SchemaError) as exc:
        print(f"daq {args.command}: {exc}", file=sys.stderr)
        return 1
    except OSError as exc:
        print(f"daq {args.command}: {exc}", file=sys.stderr)
        return 1
    finally:
        PACKAGE_LOG.removeHandler(handler)
    return code


if __name__ == "__main__":
    sys.exit(main())
