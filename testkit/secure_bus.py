"""The secure router of the lab and its clients, for the access tests (`tests/test_access*.py`).

A real Zenoh router (`testkit.zenoh_router`, as `tools/zenoh_router.py` runs it, router mode in
the test process) runs the shipped `tools/zenoh/router-secure.json5` with a credentials file of
`PASSWORDS`; clients use the shipped `tools/zenoh/*-client.json5` with the endpoint and password
replaced. `Inbox` collects a subscriber's samples and waits on them with a deadline;
`put_until_received` repeats a put until it arrives (declarations propagate asynchronously).
"""

from __future__ import annotations

import queue
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import zenoh

from testkit.zenoh_router import (
    DAQ_CLIENT,
    IDENT_CLIENT,
    SECURE_ROUTER,
    VIEWER_CLIENT,
    client_config,
    open_router,
    router_config,
)

PASSWORDS = {"daq-bench1": "pw-daq1", "daq-bench2": "pw-daq2", "ident": "pw-ident", "viewer": "pw-view",
             "operator": "pw-op"}
CLIENT_FILES = {"daq-bench1": DAQ_CLIENT, "ident": IDENT_CLIENT, "viewer": VIEWER_CLIENT}
WAIT_S = 10.0
REFUSE_MS = 700


class Router:
    """The secure router of the lab and the clients opened against it (closed at the end)."""

    def __init__(self, endpoint: str, credentials: Path) -> None:
        self.endpoint = endpoint
        self.session = open_router(router_config(SECURE_ROUTER, listen=[endpoint], credentials=credentials))
        self._closers: list[Callable[[], Any]] = []

    def client(self, user: str, password: str | None = None, config_file: Path | None = None,
               fail_after_ms: int = 5000) -> zenoh.Session:
        path = config_file or CLIENT_FILES.get(user, VIEWER_CLIENT)
        config = client_config(path, connect=[self.endpoint], user=user,
                               password=PASSWORDS[user] if password is None else password,
                               fail_after_ms=fail_after_ms)
        session = zenoh.open(config)
        self._closers.append(session.close)
        return session

    def keep(self, handle: Any) -> Any:
        self._closers.append(handle.undeclare)
        return handle

    def close(self) -> None:
        for close in reversed(self._closers):
            close()
        self.session.close()


class Inbox:
    """A subscriber's samples, as (key, payload) pairs, waited on with a deadline."""

    def __init__(self) -> None:
        self.queue: queue.Queue[tuple[str, str]] = queue.Queue()
        self.seen: list[tuple[str, str]] = []

    def __call__(self, sample: zenoh.Sample) -> None:
        self.queue.put((str(sample.key_expr), sample.payload.to_string()))

    def wait_for(self, key: str, payload: str, timeout_s: float = WAIT_S) -> list[tuple[str, str]]:
        deadline = time.monotonic() + timeout_s
        while (key, payload) not in self.seen:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError(f"expected {(key, payload)} within {timeout_s} s, got {self.seen}")
            try:
                self.seen.append(self.queue.get(timeout=left))
            except queue.Empty:
                continue
        return self.seen


def put_until_received(sender: zenoh.Session, inbox: Inbox, key: str, payload: str,
                        before: Callable[[], None] = lambda: None) -> list[tuple[str, str]]:
    """Repeat `before(); put(key, payload)` until `inbox` has it (declarations propagate
    asynchronously: the first puts may go out before the subscriber is known)."""
    deadline = time.monotonic() + WAIT_S
    for attempt in range(200):
        before()
        sender.put(key, f"{payload}#{attempt}")
        try:
            return inbox.wait_for(key, f"{payload}#{attempt}", timeout_s=0.1)
        except TimeoutError:
            if time.monotonic() > deadline:
                break
    raise TimeoutError(f"{key}: nothing received within {WAIT_S} s")




def client_file(template: Path, dest: Path, endpoint: str, user: str) -> Path:
    """A shipped client config `template` written to `dest` with `endpoint` and `user`'s password."""
    text = template.read_text().replace("tcp/127.0.0.1:7447", endpoint)
    dest.write_text(text.replace(f"change-me-{user.removeprefix('daq-')}", PASSWORDS[user]))
    return dest


__all__ = ["CLIENT_FILES", "PASSWORDS", "REFUSE_MS", "WAIT_S", "Inbox", "Router", "client_file",
           "put_until_received"]
