"""Start a Zenoh router from Python (no `zenohd` needed): the lab's hub for several benches.

The Python binding of Zenoh runs a full router when a session is opened with
`mode: "router"`; user/password authentication and access control are enforced by it.

    python tools/zenoh_router.py                                  # plain router on tcp/127.0.0.1:7447
    python tools/zenoh_router.py --listen tcp/127.0.0.1:7500
    python tools/zenoh_router.py --config tools/zenoh/router-secure.json5 \
        --credentials /etc/cartlab/zenoh-credentials.txt --listen tcp/10.0.0.5:7447

It prints one line `zenoh router <zid> listening on <endpoints>` once it accepts
connections and runs until SIGINT or SIGTERM. Every `daq` and `ident worker` then runs as a
client: `--mode client --connect tcp/<router>:7447` or `--zenoh-config <client>.json5`
(`tools/zenoh/*-client.json5`).

The script `tools/zenoh_router.py` runs `main`. From Python (tests, tools):
`with open_router(router_config(...)) as session: ...`;
`client_config(...)` builds a client config from a file with the endpoint and the
credentials replaced. Multicast and gossip scouting are always turned off here.
"""

from __future__ import annotations

import argparse
import json
import signal
import sys
import threading
from collections.abc import Sequence
from pathlib import Path
from types import FrameType

import zenoh

from schemas.bus import DEFAULT_LISTEN, BusConfig
from testkit.repo import REPO

#: the deployment configs beside the script `tools/zenoh_router.py`
CONFIGS = REPO / "tools" / "zenoh"
SECURE_ROUTER = CONFIGS / "router-secure.json5"
DAQ_CLIENT = CONFIGS / "daq-bench1-client.json5"
IDENT_CLIENT = CONFIGS / "ident-client.json5"
VIEWER_CLIENT = CONFIGS / "viewer-client.json5"


def _set(config: zenoh.Config, path: str, value: object) -> None:
    config.insert_json5(path, json.dumps(value))


def _no_scouting(config: zenoh.Config) -> None:
    _set(config, "scouting/multicast/enabled", False)
    _set(config, "scouting/gossip/enabled", False)


def router_config(config_file: Path | None = None, *, listen: Sequence[str] | None = None,
                  credentials: Path | None = None) -> zenoh.Config:
    """A router config: `config_file` (JSON5) or a plain loopback router, with overrides.

    `listen` replaces the listen endpoints; `credentials` replaces
    `transport/auth/usrpwd/dictionary_file` (lines `user:password`).
    """
    if config_file is None:
        config = zenoh.Config.from_json5(
            BusConfig(mode="router", listen=list(listen or [DEFAULT_LISTEN])).zenoh_json5())
    else:
        config = zenoh.Config.from_file(str(config_file))
    if listen is not None:
        _set(config, "listen/endpoints", list(listen))
    if credentials is not None:
        _set(config, "transport/auth/usrpwd/dictionary_file", str(credentials))
    _set(config, "mode", "router")
    _no_scouting(config)
    return config


def client_config(config_file: Path, *, connect: Sequence[str] | None = None,
                  user: str | None = None, password: str | None = None,
                  fail_after_ms: int | None = None) -> zenoh.Config:
    """A client config from `config_file` with the router endpoint and credentials replaced.

    `fail_after_ms`: make `zenoh.open` raise `zenoh.ZError` when no router accepted the
    session within that time (`connect/exit_on_failure` with a finite `timeout_ms`; without a
    timeout Zenoh would block forever), instead of retrying in the background.
    """
    config = zenoh.Config.from_file(str(config_file))
    if connect is not None:
        _set(config, "connect/endpoints", list(connect))
    if user is not None:
        _set(config, "transport/auth/usrpwd/user", user)
    if password is not None:
        _set(config, "transport/auth/usrpwd/password", password)
    if fail_after_ms is not None:
        _set(config, "connect/timeout_ms", fail_after_ms)
        _set(config, "connect/exit_on_failure", True)
    _no_scouting(config)
    return config


def open_router(config: zenoh.Config) -> zenoh.Session:
    """Open the router session (a context manager: `with open_router(cfg) as router:`)."""
    zenoh.init_log_from_env_or("error")
    return zenoh.open(config)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="zenoh_router", description=__doc__.split("\n\n")[0])
    parser.add_argument("--config", type=Path, default=None,
                        help="a Zenoh JSON5 router config (e.g. tools/zenoh/router-secure.json5); "
                             "default: a plain router, scouting off")
    parser.add_argument("--listen", action="append", default=None, metavar="ENDPOINT",
                        help=f"listen endpoint, repeatable (default: the config's, or {DEFAULT_LISTEN})")
    parser.add_argument("--credentials", type=Path, default=None,
                        help="user:password file replacing transport/auth/usrpwd/dictionary_file")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.config is not None and not args.config.is_file():
        print(f"zenoh_router: --config: expected an existing JSON5 file, got {str(args.config)!r}",
              file=sys.stderr)
        return 2
    if args.credentials is not None and not args.credentials.is_file():
        print(f"zenoh_router: --credentials: expected an existing file, got {str(args.credentials)!r}",
              file=sys.stderr)
        return 2
    stop = threading.Event()

    def on_signal(_signum: int, _frame: FrameType | None) -> None:
        stop.set()

    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, on_signal)
    try:
        config = router_config(args.config, listen=args.listen, credentials=args.credentials)
        session = open_router(config)
    except zenoh.ZError as exc:
        print(f"zenoh_router: cannot start the router: {exc}", file=sys.stderr)
        return 1
    with session:
        endpoints = json.loads(config.get_json("listen/endpoints"))
        print(f"zenoh router {session.info.zid()} listening on {', '.join(map(str, endpoints))}",
              flush=True)
        while not stop.wait(0.5):
            pass
    return 0


if __name__ == "__main__":
    sys.exit(main())
