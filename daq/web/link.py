"""The bench page's Zenoh adapter: callbacks enqueue raw messages, methods query the daqs.

No callback does more than `inbox.put`; parsing happens on the server's event loop
(`daq.web.service`). Subscriptions:

| key | how | inbox kind |
|---|---|---|
| liveliness `keys.ALL_DAQ_ALIVE` | history | `alive` (PUT/DELETE) |
| `keys.ALL_FINISHED` | advanced subscriber, history + late publishers | `finished` |
| `keys.ALL_FITS` | advanced subscriber, history + late publishers | `fit` |
| `keys.samples(b)`, `keys.state(b)` | per bench, declared when its daq is first seen | `samples`, `state` |

Queries (`status`, `zero`, `arm`, `runs`, `run`) block for at most their timeout; the
server calls them from worker threads, never from a Zenoh callback.
"""

from __future__ import annotations

import contextlib
import queue
from dataclasses import dataclass
from typing import Any, Literal

import zenoh
import zenoh.ext

from schemas import keys
from schemas.bus import BusConfig
from schemas.daq import DaqStatus, RunList, ZeroReply

InboxKind = Literal["alive", "finished", "fit", "samples", "state"]
HISTORY_SAMPLES = 64


@dataclass(frozen=True, slots=True)
class InboxItem:
    """A raw message as a callback saw it; `up` is the liveliness sense (PUT = True)."""

    kind: InboxKind
    key: str
    payload: bytes = b""
    up: bool = True


class QueryFailed(Exception):
    """A daq queryable that did not answer, or answered with an error."""


def zenoh_config(bus: BusConfig) -> zenoh.Config:
    """The `zenoh.Config` of a `BusConfig` (a config file, when given, is used as it is)."""
    if bus.config_file:
        return zenoh.Config.from_file(bus.config_file)
    return zenoh.Config.from_json5(bus.zenoh_json5())


class WebLink:
    """One Zenoh session of the page server. `open()` it, `close()` it."""

    def __init__(self, bus: BusConfig, inbox: queue.SimpleQueue[InboxItem]) -> None:
        self._bus = bus
        self._inbox = inbox
        self._session: zenoh.Session | None = None
        self._handles: list[Any] = []
        self._followed: set[str] = set()

    @property
    def session(self) -> zenoh.Session:
        if self._session is None:
            raise RuntimeError("web link: expected an open session, got a closed one")
        return self._session

    def open(self) -> None:
        zenoh.init_log_from_env_or("error")
        session = self._session = zenoh.open(zenoh_config(self._bus))
        history = zenoh.ext.HistoryConfig(detect_late_publishers=True,
                                          max_samples=HISTORY_SAMPLES)
        self._handles = [
            session.liveliness().declare_subscriber(keys.ALL_DAQ_ALIVE, self._on_alive,
                                                    history=True),
            zenoh.ext.declare_advanced_subscriber(session, keys.ALL_FINISHED,
                                                  self._enqueue("finished"), history=history),
            zenoh.ext.declare_advanced_subscriber(session, keys.ALL_FITS,
                                                  self._enqueue("fit"), history=history),
        ]

    def close(self) -> None:
        for handle in reversed(self._handles):
            # closing anyway: whatever undeclare raises, the session close cleans up
            with contextlib.suppress(Exception):
                handle.undeclare()
        self._handles.clear()
        self._followed.clear()
        if self._session is not None:
            self._session.close()
            self._session = None

    def follow(self, bench: str) -> None:
        """Subscribe to one bench's live samples and state (once per bench)."""
        if bench in self._followed:
            return
        self._followed.add(bench)
        session = self.session
        self._handles += [
            session.declare_subscriber(keys.samples(bench), self._enqueue("samples")),
            session.declare_subscriber(keys.state(bench), self._enqueue("state")),
        ]

    # -- callbacks: enqueue only -------------------------------------------------------
    def _enqueue(self, kind: InboxKind) -> Any:
        inbox = self._inbox

        def on_sample(sample: zenoh.Sample) -> None:
            inbox.put(InboxItem(kind, str(sample.key_expr), sample.payload.to_bytes()))

        return on_sample

    def _on_alive(self, sample: zenoh.Sample) -> None:
        self._inbox.put(InboxItem("alive", str(sample.key_expr),
                                  up=sample.kind == zenoh.SampleKind.PUT))

    # -- queries (blocking; call from a worker thread) ---------------------------------
    def _query(self, selector: str, timeout_s: float, payload: bytes | None = None) -> bytes:
        errors = []
        for reply in self.session.get(selector, payload=payload, timeout=timeout_s):
            if reply.ok is not None:
                return bytes(reply.ok.payload.to_bytes())
            if reply.err is not None:
                errors.append(reply.err.payload.to_string())
        if errors:
            raise QueryFailed(f"{selector}: the daq answered with an error: {'; '.join(errors)}")
        raise QueryFailed(f"{selector}: no reply within {timeout_s:g} s (is the daq running?)")

    def status(self, bench: str, timeout_s: float = 2.0) -> DaqStatus:
        return DaqStatus.from_json_bytes(self._query(keys.daq_query(bench, "status"), timeout_s))

    def arm(self, bench: str, timeout_s: float = 2.0) -> DaqStatus:
        return DaqStatus.from_json_bytes(self._query(keys.daq_query(bench, "arm"), timeout_s))

    def zero(self, bench: str, timeout_s: float = 2.0) -> ZeroReply:
        return ZeroReply.from_json_bytes(self._query(keys.daq_query(bench, "zero"), timeout_s))

    def runs(self, bench: str, timeout_s: float = 2.0) -> RunList:
        return RunList.from_json_bytes(self._query(keys.daq_query(bench, "runs"), timeout_s))

    def run_bytes(self, bench: str, run_id: str, timeout_s: float = 10.0) -> bytes:
        """A run's MCAP bytes from its daq's `run` queryable (`?id=<run_id>`, id also as payload)."""
        run_id = keys.check_name("run_id", run_id)
        return self._query(f"{keys.daq_query(bench, 'run')}?id={run_id}", timeout_s, run_id.encode())
