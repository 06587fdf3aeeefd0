"""`python -m daq.web`: serve the bench page (the body of `daq serve`).

    python -m daq.web [--host 127.0.0.1] [--port 8000] [--connect tcp/127.0.0.1:7447]
                      [--listen ENDPOINT] [--zenoh-config FILE] [--runs-dir DIR]
                      [--allow-host NAME]

By default the server is a Zenoh peer that connects to a daq on this machine
(`tcp/127.0.0.1:7447`, the daq's default listener) and serves on loopback only.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from daq.web.live import DEFAULT_DISPLAY_HZ
from daq.web.server import BenchPageServer
from daq.web.service import WebSettings
from schemas.bus import DEFAULT_LISTEN, BusConfig


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="daq serve", description="Serve the bench page: live "
                                     "plot, detector state, Zero/Arm, runs and their fits.")
    parser.add_argument("--host", default="127.0.0.1",
                        help="address to serve on (default 127.0.0.1: this machine only)")
    parser.add_argument("--port", type=int, default=8000, help="HTTP port (default 8000)")
    parser.add_argument("--listen", action="append", default=[], metavar="ENDPOINT",
                        help="Zenoh endpoint to listen on (repeatable; default none)")
    parser.add_argument("--connect", action="append", default=[], metavar="ENDPOINT",
                        help=f"Zenoh endpoint to connect to (repeatable; default {DEFAULT_LISTEN} "
                        "when neither --listen nor --connect is given)")
    parser.add_argument("--mode", choices=["peer", "client"], default="peer",
                        help="Zenoh mode (client when connecting to a lab router)")
    parser.add_argument("--zenoh-config", type=Path, default=None,
                        help="Zenoh JSON5 config file, used as it is (overrides the above)")
    parser.add_argument("--runs-dir", type=Path, default=None,
                        help="the daq's runs directory, to serve MCAP files, reports, figures")
    parser.add_argument("--allow-host", action="append", default=[], metavar="NAME",
                        help="a name the page may be reached by besides localhost and --host "
                        "(repeatable; e.g. the lab PC's name when serving the room with "
                        "--host 0.0.0.0); requests with any other Host are refused")
    parser.add_argument("--display-hz", type=float, default=DEFAULT_DISPLAY_HZ,
                        help=f"points per second per cart sent to the page "
                        f"(default {DEFAULT_DISPLAY_HZ:g}; recording is never decimated)")
    return parser


def settings_from_args(args: argparse.Namespace) -> WebSettings:
    connect = list(args.connect) or ([] if args.listen else [DEFAULT_LISTEN])
    bus = BusConfig(mode=args.mode, listen=list(args.listen), connect=connect,
                    config_file=None if args.zenoh_config is None else str(args.zenoh_config))
    return WebSettings(bus=bus, runs_dir=args.runs_dir, display_hz=args.display_hz,
                       allow_hosts=tuple(args.allow_host))


def serve(settings: WebSettings, host: str, port: int) -> None:
    """Run the page server until interrupted (SIGINT/SIGTERM)."""
    BenchPageServer(settings, host, port).run()


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        settings = settings_from_args(args)
    except ValueError as exc:
        parser.error(str(exc))
    if not args.display_hz > 0:
        parser.error(f"--display-hz: expected a rate > 0, got {args.display_hz:g}")
    if args.runs_dir is not None and not args.runs_dir.is_dir():
        parser.error(f"--runs-dir: expected an existing directory, got {str(args.runs_dir)!r}")
    print(f"bench page on http://{host_for_url(args.host)}:{args.port}/", file=sys.stderr)
    serve(settings, args.host, args.port)
    return 0


def host_for_url(host: str) -> str:
    return f"[{host}]" if ":" in host else host


if __name__ == "__main__":
    raise SystemExit(main())
