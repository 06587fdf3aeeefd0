"""`ident worker`: serve finished runs over Zenoh, fitting each exactly once (see `ident.worker`)."""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import signal
import socket
import sys
import threading
from pathlib import Path
from typing import TYPE_CHECKING, Any

from schemas.bus import BusConfig

if TYPE_CHECKING:
    from ident.worker.job import Fitter


def add_parser(sub: Any) -> None:
    parser: argparse.ArgumentParser = sub.add_parser(
        "worker", help="fit every finished run published over Zenoh, exactly once per run",
        description="Subscribe to cartlab/*/runs/*/finished, fit each run (simple ID, PEM, "
                    "diagnosis), publish the report on cartlab/<bench>/runs/<run_id>/fit and "
                    "write <run_id>.fit/.")
    parser.add_argument("--runs-dir", type=Path, default=Path("runs"),
                        help="local runs directory: scanned at start, fits written beside runs "
                             "(default: ./runs)")
    parser.add_argument("--listen", action="append", default=None, metavar="ENDPOINT",
                        help="Zenoh endpoint to listen on (repeatable; default: none)")
    parser.add_argument("--connect", action="append", default=None, metavar="ENDPOINT",
                        help="Zenoh endpoint to connect to (repeatable; default tcp/127.0.0.1:7447)")
    parser.add_argument("--mode", choices=("peer", "client"), default="peer",
                        help="Zenoh session mode (client when a router is used)")
    parser.add_argument("--zenoh-config", type=Path, default=None,
                        help="a Zenoh JSON5 config file, used as it is (overrides the above)")
    parser.add_argument("--name", default=None,
                        help="worker name, unique among workers (default: <host>-<pid>)")
    parser.add_argument("--settle-s", type=float, default=0.2,
                        help="how long a claim waits for rival claims, seconds (default 0.2)")
    parser.add_argument("--fitter", default=None, metavar="MODULE:FUNCTION",
                        help="fitting pipeline plug-in (default ident.worker.pipeline:fit_run)")
    parser.add_argument("-v", "--verbose", action="store_true", help="log every decision")
    parser.set_defaults(func=run)


def bus_config(args: argparse.Namespace) -> BusConfig:
    if args.zenoh_config is not None:
        return BusConfig(config_file=str(args.zenoh_config))
    connect = args.connect if args.connect is not None else (
        [] if args.listen else ["tcp/127.0.0.1:7447"])
    return BusConfig(mode=args.mode, listen=args.listen or [], connect=connect)


def default_name() -> str:
    host = "".join(c if c.isalnum() or c in "_.-" else "-" for c in socket.gethostname())
    return f"{host or 'worker'}-{os.getpid()}"


def fitter_named(spec: str | None) -> Fitter:
    """The function `--fitter MODULE:FUNCTION` names; the default pipeline without one.

    Imported here, when the command runs, so other `ident` commands do not load the worker.
    """
    if spec is None:
        from ident.worker.pipeline import fit_run

        return fit_run
    module_name, _, attr = spec.partition(":")
    try:
        fitter = getattr(importlib.import_module(module_name), attr) if module_name and attr else None
    except ImportError as exc:
        raise ValueError(f"--fitter: cannot import {module_name!r} ({exc}); expected MODULE:FUNCTION") from exc
    if not callable(fitter):
        raise ValueError(f"--fitter: expected MODULE:FUNCTION naming a function, got {spec!r}")
    return fitter


def run(args: argparse.Namespace) -> int:
    from ident.worker.service import WorkerOptions, run_worker

    try:
        fitter = fitter_named(args.fitter)
    except ValueError as exc:
        print(f"ident worker: {exc}", file=sys.stderr)
        return 2
    logging.basicConfig(level=logging.DEBUG if args.verbose else logging.INFO,
                        format="%(asctime)s ident worker %(message)s")
    options = WorkerOptions(name=args.name or default_name(), runs_dir=args.runs_dir,
                            bus=bus_config(args), settle_s=args.settle_s)
    stop = threading.Event()

    def _stop(signum: int, frame: object) -> None:
        # Leave at once, also in the middle of a fit: the fit's child process is ended, the
        # session closes on the way out, the worker's token and claims vanish with it, and
        # another worker takes the run over.
        if not stop.is_set():
            stop.set()
            raise SystemExit(0)

    signal.signal(signal.SIGTERM, _stop)
    signal.signal(signal.SIGINT, _stop)
    from ident.errors import IdentError

    logging.getLogger("ident.worker").info("worker %s serving %s", options.name,
                                           options.runs_dir)
    try:
        run_worker(options, fitter, stop)
    except IdentError as exc:
        print(f"ident worker: {exc}", file=sys.stderr)
        return 2
    except SystemExit:
        pass   # raised by `_stop`; the fit process and the session were closed on the way out
    return 0
