"""The worker's Zenoh adapter: callbacks enqueue raw messages, methods publish and query.

Nothing here decides anything and no callback does more than `queue.put`: parsing and
scheduling happen on the worker's own thread (`ident.worker.service`). Subscriptions:

| key | how | event |
|---|---|---|
| `keys.ALL_FINISHED` | advanced subscriber, history + late publishers + recovery | `finished` |
| `keys.ALL_FITS` | advanced subscriber, history (claims and reports of other workers) | `fit` |
| liveliness `keys.ALL_IDENT_ALIVE` | history | `worker` PUT/DELETE |
| liveliness `keys.ALL_DAQ_ALIVE` | history | `daq` PUT/DELETE |

Published: liveliness token `keys.ident_alive(name)` (declared by `declare_alive`, once the
worker's fit process is ready, not when the session opens), and per run an advanced publisher with
a cache on `keys.run_fit(bench, run_id)` (claim first, then the report). A queryable on
`keys.ALL_FITS` answers with every complete report this worker has seen (its own and the
others') and with its own claims in progress, from immutable snapshots the loop replaces: a
worker that starts after the one that fitted a run is gone still learns that the run is done,
from any survivor, and a worker about to publish learns of a claim that fences it.

Bounds: a payload larger than `MAX_PAYLOAD_BYTES` is dropped in the callback (never copied);
the event queue holds at most `MAX_QUEUED` events and `MAX_QUEUED_BYTES` of payload, and one
that does not fit is dropped and counted (`take_dropped`), so the loop catches up by asking
again. A fetched run file larger
than `MAX_FETCH_BYTES` is refused before it touches the disk; every query has a timeout.
"""

from __future__ import annotations

import contextlib
import json
import queue
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import zenoh
import zenoh.ext

from ident.errors import IdentError, IdentValueError
from ident.worker.runs_dir import write_atomic
from schemas import MAX_PAYLOAD_BYTES, keys
from schemas.bus import BusConfig
from schemas.daq import RunList
from schemas.fit import FitReport

EventKind = Literal["finished", "fit", "worker", "daq"]

#: How many messages each advanced subscriber asks every publisher's cache for.
HISTORY_SAMPLES = 64
#: Most fit publishers a worker keeps (their caches answer late subscribers); oldest go first.
MAX_FIT_PUBLISHERS = 512
#: Most events waiting for the loop; beyond, events are dropped and counted (then caught up).
MAX_QUEUED = 2048
#: Most payload bytes waiting for the loop (the count bound alone would allow 2048 x 4 MiB).
MAX_QUEUED_BYTES = 64 << 20
#: Largest `finished` record accepted (a RunFinished is well under 4 KiB).
MAX_FINISHED_BYTES = 64 << 10
#: Largest run file fetched from a daq (bytes): the reader's own file limit.
MAX_FETCH_BYTES = 1 << 30
#: Longest a fetch may take (s): a replier that never answers costs at most this.
FETCH_TIMEOUT_S = 5.0


class RunUnavailable(IdentError, ConnectionError):
    """A run's file could not be had now (no daq answered, or it refused): retry later."""


@dataclass(frozen=True, slots=True)
class BusEvent:
    """A raw message as a callback saw it; `up` is the liveliness sense (PUT = True)."""

    kind: EventKind
    key: str
    payload: bytes = b""
    up: bool = True


def zenoh_config(bus: BusConfig) -> zenoh.Config:
    """The `zenoh.Config` of a `BusConfig` (a config file, when given, is used as it is)."""
    if bus.config_file:
        return zenoh.Config.from_file(bus.config_file)
    return zenoh.Config.from_json5(bus.zenoh_json5())


class WorkerBus:
    """One Zenoh session of one worker. Use as a context manager."""

    def __init__(self, bus: BusConfig, name: str, events: queue.Queue[Any]) -> None:
        """`events` receives `BusEvent`s (the worker's queue also carries its own items)."""
        self.name = keys.check_name("worker", name)
        self._bus = bus
        self._events = events
        self._session: zenoh.Session | None = None
        self._handles: list[Any] = []
        self._fit_publishers: dict[str, Any] = {}
        self._fit_snapshot: tuple[tuple[str, bytes], ...] = ()
        self._claims: dict[str, bytes] = {}
        self._claim_snapshot: tuple[tuple[str, bytes], ...] = ()
        self._dropped = 0
        self._queued_bytes = 0
        self._bytes_lock = threading.Lock()
        self._transport_opened = threading.Event()
        self._token: Any = None

    # -- lifecycle ----------------------------------------------------------------------
    def __enter__(self) -> WorkerBus:
        self.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def session(self) -> zenoh.Session:
        if self._session is None:
            raise RuntimeError("worker bus: expected an open session, got a closed one")
        return self._session

    def open(self) -> None:
        zenoh.init_log_from_env_or("error")
        session = self._session = zenoh.open(zenoh_config(self._bus))
        token = keys.ident_alive(self.name)
        if any(reply.ok is not None for reply in session.liveliness().get(token, timeout=1.0)):
            self.close()
            # two workers of one name would both own the same runs
            raise IdentValueError("worker name", "a name no alive worker uses",
                                  f"{self.name!r}, already alive on the bus")
        history = zenoh.ext.HistoryConfig(detect_late_publishers=True, max_samples=HISTORY_SAMPLES)
        recovery = zenoh.ext.RecoveryConfig(periodic_queries=None, heartbeat=True)
        live = session.liveliness()
        self._handles = [
            zenoh.ext.declare_advanced_subscriber(session, keys.ALL_FINISHED, self._on_finished,
                                                  history=history, recovery=recovery),
            zenoh.ext.declare_advanced_subscriber(session, keys.ALL_FITS, self._on_fit,
                                                  history=history),
            live.declare_subscriber(keys.ALL_IDENT_ALIVE, self._on_worker, history=True),
            live.declare_subscriber(keys.ALL_DAQ_ALIVE, self._on_daq, history=True),
            session.declare_queryable(keys.ALL_FITS, self._on_fit_query),
            session.info.declare_transport_events_listener(self._on_transport),
        ]

    def declare_alive(self) -> None:
        """Declare the liveliness token `keys.ident_alive(name)`: from now on the others count
        this worker in (they hand it runs). The worker does this once it can fit at once."""
        if self._token is None:
            self._token = self.session.liveliness().declare_token(keys.ident_alive(self.name))
            self._handles.append(self._token)

    def close(self) -> None:
        for handle in [*self._fit_publishers.values(), *reversed(self._handles)]:
            # closing anyway: whatever undeclare raises, the session close cleans up
            with contextlib.suppress(Exception):
                handle.undeclare()
        self._fit_publishers.clear()
        self._handles.clear()
        self._token = None
        if self._session is not None:
            self._session.close()
            self._session = None

    # -- callbacks: enqueue only --------------------------------------------------------
    def _enqueue(self, event: BusEvent) -> None:
        with self._bytes_lock:
            if self._queued_bytes + len(event.payload) > MAX_QUEUED_BYTES:
                self._dropped += 1
                return
            self._queued_bytes += len(event.payload)
        try:
            self._events.put_nowait(event)
        except queue.Full:
            self.taken(event)
            self._dropped += 1

    def taken(self, event: object) -> None:
        """The loop took `event` off the queue: its bytes no longer count."""
        if isinstance(event, BusEvent) and event.payload:
            with self._bytes_lock:
                self._queued_bytes -= len(event.payload)

    def _payload(self, sample: zenoh.Sample, limit: int = MAX_PAYLOAD_BYTES) -> bytes | None:
        if len(sample.payload) > limit:
            self._dropped += 1
            return None
        return sample.payload.to_bytes()

    def _on_finished(self, sample: zenoh.Sample) -> None:
        payload = self._payload(sample, MAX_FINISHED_BYTES)
        if payload is not None:
            self._enqueue(BusEvent("finished", str(sample.key_expr), payload))

    def _on_fit(self, sample: zenoh.Sample) -> None:
        payload = self._payload(sample)
        if payload is not None:
            self._enqueue(BusEvent("fit", str(sample.key_expr), payload))

    def _on_worker(self, sample: zenoh.Sample) -> None:
        self._enqueue(BusEvent("worker", str(sample.key_expr),
                               up=sample.kind == zenoh.SampleKind.PUT))

    def _on_daq(self, sample: zenoh.Sample) -> None:
        self._enqueue(BusEvent("daq", str(sample.key_expr),
                               up=sample.kind == zenoh.SampleKind.PUT))

    def take_dropped(self) -> int:
        """How many events were dropped since the last call (a flood, or oversized)."""
        dropped, self._dropped = self._dropped, 0
        return dropped

    def _on_fit_query(self, query: zenoh.Query) -> None:
        # Answered from immutable snapshots: no lock, no Zenoh call but the replies.
        asked = query.key_expr
        for key, payload in (*self._fit_snapshot, *self._claim_snapshot):
            if asked.intersects(zenoh.KeyExpr(key)):
                query.reply(key, payload, encoding=zenoh.Encoding.APPLICATION_JSON)

    def set_fit_snapshot(self, reports: dict[str, bytes]) -> None:
        """Replace what the fit queryable answers: key -> complete report JSON."""
        self._fit_snapshot = tuple(reports.items())

    def set_claim(self, bench: str, run_id: str, claim: FitReport | None) -> None:
        """Answer (or stop answering) the fit queryable with my claim on a run."""
        key = keys.run_fit(bench, run_id)
        if claim is None:
            self._claims.pop(key, None)
        else:
            self._claims[key] = claim.to_json_bytes()
        self._claim_snapshot = tuple(self._claims.items())

    # -- publishing ---------------------------------------------------------------------
    def publish_fit(self, report: FitReport) -> None:
        """Put a claim or report on `runs/<run_id>/fit` through that run's cached publisher."""
        key = keys.run_fit(report.bench, report.run_id)
        publisher = self._fit_publishers.get(key)
        if publisher is None:
            if len(self._fit_publishers) >= MAX_FIT_PUBLISHERS:
                oldest = next(iter(self._fit_publishers))
                self._fit_publishers.pop(oldest).undeclare()
            publisher = zenoh.ext.declare_advanced_publisher(
                self.session, key, encoding=zenoh.Encoding.APPLICATION_JSON,
                congestion_control=zenoh.CongestionControl.BLOCK,
                reliability=zenoh.Reliability.RELIABLE,
                cache=zenoh.ext.CacheConfig(max_samples=2), publisher_detection=True,
                sample_miss_detection=zenoh.ext.MissDetectionConfig(
                    heartbeat=None, sporadic_heartbeat=1.0))
            self._fit_publishers[key] = publisher
        publisher.put(report.to_json_bytes())

    # -- queries (blocking, called from the worker thread only) -------------------------
    def alive_workers(self, timeout_s: float = 1.0) -> set[str]:
        names = set()
        for reply in self.session.liveliness().get(keys.ALL_IDENT_ALIVE, timeout=timeout_s):
            if reply.ok is not None:
                names.add(str(reply.ok.key_expr).rsplit("/", 1)[-1])
        return names

    def alive_benches(self, timeout_s: float = 1.0) -> set[str]:
        benches = set()
        for reply in self.session.liveliness().get(keys.ALL_DAQ_ALIVE, timeout=timeout_s):
            if reply.ok is not None:
                benches.add(keys.bench_of(str(reply.ok.key_expr)))
        return benches

    def known_fits(self, timeout_s: float = 2.0) -> list[bytes]:
        """Complete reports the other alive workers remember (their fit queryables)."""
        return [reply.ok.payload.to_bytes()
                for reply in self.session.get(keys.ALL_FITS, timeout=timeout_s)
                if reply.ok is not None]

    def list_runs(self, bench: str, timeout_s: float = 2.0) -> RunList | None:
        """The `runs` queryable of one bench's daq, or None when it does not answer."""
        for reply in self.session.get(keys.daq_query(bench, "runs"), timeout=timeout_s):
            if reply.ok is not None:
                return RunList.from_json_bytes(reply.ok.payload.to_bytes())
        return None

    def fit_state(self, bench: str, run_id: str, timeout_s: float = 2.0) -> list[bytes]:
        """What the other workers answer for one run: their complete report or live claim."""
        return [reply.ok.payload.to_bytes()
                for reply in self.session.get(keys.run_fit(bench, run_id), timeout=timeout_s)
                if reply.ok is not None and len(reply.ok.payload) <= MAX_PAYLOAD_BYTES]

    def _on_transport(self, event: zenoh.TransportEvent) -> None:
        if event.kind == zenoh.SampleKind.PUT:
            self._transport_opened.set()

    def wait_reconnected(self, timeout_s: float) -> bool:
        """After a stall of this process: wait (bounded) for the session to open a transport
        again, which it does when the stall outlasted the lease and the link was dropped. True
        if it did; False after `timeout_s` (the link survived, or nothing answers)."""
        self._transport_opened.clear()
        return self._transport_opened.wait(timeout_s)

    def wait_for_workers(self, names: set[str], timeout_s: float) -> bool:
        """Wait (bounded) until every worker in `names` answers the liveliness query again;
        False after `timeout_s` (some are really gone)."""
        deadline = time.monotonic() + timeout_s
        while not names <= self.alive_workers(timeout_s=0.5):
            if time.monotonic() > deadline:
                return False
            time.sleep(0.05)   # polling the routing state: Zenoh has no event for "declarations synced"
        return True

    def fetch_run(self, bench: str, run_id: str, dest: Path, timeout_s: float = FETCH_TIMEOUT_S,
                  max_bytes: int = MAX_FETCH_BYTES) -> Path:
        """Fetch a run's MCAP bytes from its daq's `run` queryable into `dest`.

        Raises `RunUnavailable` when no reply comes within `timeout_s`, or every reply is an
        error or larger than `max_bytes` (refused before anything is written).
        """
        selector = f"{keys.daq_query(bench, 'run')}?id={keys.check_name('run_id', run_id)}"
        errors = []
        for reply in self.session.get(selector, timeout=timeout_s):
            if reply.ok is not None:
                size = len(reply.ok.payload)
                if size > max_bytes:
                    errors.append(f"a reply of {size} bytes (at most {max_bytes})")
                    continue
                write_atomic(dest, reply.ok.payload.to_bytes())
                return dest
            errors.append(reply.err.payload.to_string()[:200] if reply.err is not None else "?")
        raise RunUnavailable(
            f"run {bench}/{run_id}: expected its MCAP bytes from {selector} within {timeout_s:g} s, got "
            + (json.dumps(errors) if errors else "no reply"))


__all__ = ["FETCH_TIMEOUT_S", "MAX_FETCH_BYTES", "MAX_QUEUED", "BusEvent", "RunUnavailable",
           "WorkerBus", "zenoh_config"]
