"""Thin Zenoh adapter of the `daq` service: publishers, queryables, liveliness.

What goes out (keys from `schemas.keys` only, JSON payloads of `schemas` records):
- `samples`: `SampleBatch`, CongestionControl.DROP (a live view may miss a batch; the run
  file never does);
- `state`: `DetectorStateMsg`, reliable and blocking;
- `runs/<run_id>/finished`: `RunFinished` through a `zenoh.ext` advanced publisher with a
  cache and publisher detection, so an advanced subscriber with history that starts late
  still receives it (the last `FINISHED_PUBLISHERS` runs stay cached); every finished record
  is also answered by a queryable on the same keys (`session.get(".../runs/*/finished")`);
- queryables `daq/status` (`DaqStatus`), `daq/runs` (`RunList`), `daq/zero` (`ZeroReply`),
  `daq/arm` (`DaqStatus`), `daq/run?id=<run_id>` (the run's MCAP bytes);
- liveliness token `cartlab/<bench>/daq`.

Threading: Zenoh calls the queryable callbacks on its own threads. They never block: status,
runs and finished records are answered at once from immutable snapshots the service loop
publishes with `set_snapshot`; zero, arm and run requests are put on `requests` and answered
by the loop (`reply_*`).
"""

from __future__ import annotations

import queue
from collections import OrderedDict
from dataclasses import dataclass
from typing import Literal

import zenoh
from zenoh import ext

from daq.errors import DaqIOError
from schemas import Record, keys
from schemas.bus import BusConfig
from schemas.daq import DaqStatus, RunFinished, RunList

FINISHED_PUBLISHERS = 64
JSON = zenoh.Encoding.APPLICATION_JSON
MCAP_ENCODING = zenoh.Encoding("application/mcap")


@dataclass(frozen=True)
class BusRequest:
    """A query the service loop must answer: `kind` and the run id (for `run`)."""

    kind: Literal["zero", "arm", "run"]
    query: zenoh.Query
    run_id: str | None = None


@dataclass(frozen=True)
class _Snapshot:
    status: bytes
    runs: bytes
    finished: tuple[tuple[str, bytes], ...]


def open_session(bus: BusConfig) -> zenoh.Session:
    """A Zenoh session from the config file (when given) or the model's settings."""
    try:
        if bus.config_file:
            config = zenoh.Config.from_file(bus.config_file)
        else:
            config = zenoh.Config.from_json5(bus.zenoh_json5())
        return zenoh.open(config)
    except zenoh.ZError as exc:
        where = bus.config_file or f"listen={bus.listen} connect={bus.connect}"
        raise DaqIOError(f"cannot open the Zenoh session ({where}): {exc}; check that the endpoint "
                         "is free (another daq on this port?) and that the config file is valid") from exc


class DaqBus:
    """The bench's Zenoh presence. Create, use from one thread (the loop), `close()` in finally."""

    def __init__(self, bench: str, bus: BusConfig, session: zenoh.Session | None = None) -> None:
        self.bench = keys.check_name("bench", bench)
        self.requests: queue.SimpleQueue[BusRequest] = queue.SimpleQueue()
        self._own_session = session is None
        self.session = session if session is not None else open_session(bus)
        self._snapshot = _Snapshot(b"", RunList(bench=bench, runs=[]).to_json_bytes(), ())
        self._finished_pubs: OrderedDict[str, ext.AdvancedPublisher] = OrderedDict()
        try:
            self._declare()
        except BaseException:
            self.close()
            raise

    def _declare(self) -> None:
        s = self.session
        self._samples = s.declare_publisher(keys.samples(self.bench), encoding=JSON,
                                            congestion_control=zenoh.CongestionControl.DROP)
        self._state = s.declare_publisher(keys.state(self.bench), encoding=JSON,
                                          congestion_control=zenoh.CongestionControl.BLOCK,
                                          reliability=zenoh.Reliability.RELIABLE)
        self._queryables = [
            s.declare_queryable(keys.daq_query(self.bench, "status"), self._on_status),
            s.declare_queryable(keys.daq_query(self.bench, "runs"), self._on_runs),
            s.declare_queryable(keys.daq_query(self.bench, "zero"), self._on_zero),
            s.declare_queryable(keys.daq_query(self.bench, "arm"), self._on_arm),
            s.declare_queryable(keys.daq_query(self.bench, "run"), self._on_run),
            s.declare_queryable(keys.ALL_FINISHED, self._on_finished),
        ]
        self._token = s.liveliness().declare_token(keys.daq_alive(self.bench))

    # --- publishing (loop thread) --------------------------------------------------------------
    def publish_samples(self, payload: bytes) -> None:
        self._samples.put(payload)

    def publish_state(self, record: Record) -> None:
        self._state.put(record.to_json_bytes())

    def publish_finished(self, record: RunFinished) -> None:
        """Put the run-end record on its key through a cached advanced publisher."""
        key = keys.run_finished(self.bench, record.run_id)
        pub = self._finished_pubs.pop(key, None)
        if pub is None:
            pub = ext.declare_advanced_publisher(
                self.session, key, encoding=JSON, congestion_control=zenoh.CongestionControl.BLOCK,
                reliability=zenoh.Reliability.RELIABLE, cache=ext.CacheConfig(max_samples=1),
                publisher_detection=True,
                sample_miss_detection=ext.MissDetectionConfig(heartbeat=None, sporadic_heartbeat=1.0))
        self._finished_pubs[key] = pub
        pub.put(record.to_json_bytes())
        while len(self._finished_pubs) > FINISHED_PUBLISHERS:
            _, old = self._finished_pubs.popitem(last=False)
            old.undeclare()

    def set_snapshot(self, status: DaqStatus, runs: RunList | None = None) -> None:
        """Replace what the status/runs/finished queryables answer (one atomic assignment).

        `runs=None` keeps the run list and finished records of the last snapshot: they are
        encoded only when they change (a long-lived runs directory holds hundreds of runs).
        """
        old = self._snapshot
        if runs is None:
            self._snapshot = _Snapshot(status.to_json_bytes(), old.runs, old.finished)
            return
        finished = tuple((keys.run_finished(self.bench, r.run_id), r.to_json_bytes()) for r in runs.runs)
        self._snapshot = _Snapshot(status.to_json_bytes(), runs.to_json_bytes(), finished)

    # --- replies (loop thread) -------------------------------------------------------------------
    @staticmethod
    def reply_record(request: BusRequest, record: Record) -> None:
        with request.query as query:
            query.reply(query.key_expr, record.to_json_bytes(), encoding=JSON)

    @staticmethod
    def reply_bytes(request: BusRequest, data: bytes) -> None:
        with request.query as query:
            query.reply(query.key_expr, data, encoding=MCAP_ENCODING)

    @staticmethod
    def reply_error(request: BusRequest, message: str) -> None:
        with request.query as query:
            query.reply_err(message.encode(), encoding=zenoh.Encoding.TEXT_PLAIN)

    # --- callbacks (Zenoh threads: never block) -------------------------------------------------
    def _on_status(self, query: zenoh.Query) -> None:
        status = self._snapshot.status
        if not status:
            query.reply_err(b"daq is starting: expected a status within a second, got none yet",
                            encoding=zenoh.Encoding.TEXT_PLAIN)
            return
        query.reply(query.key_expr, status, encoding=JSON)

    def _on_runs(self, query: zenoh.Query) -> None:
        query.reply(query.key_expr, self._snapshot.runs, encoding=JSON)

    def _on_finished(self, query: zenoh.Query) -> None:
        asked = query.key_expr
        for key, payload in self._snapshot.finished:
            if asked.intersects(zenoh.KeyExpr(key)):
                query.reply(key, payload, encoding=JSON)

    def _on_zero(self, query: zenoh.Query) -> None:
        self.requests.put(BusRequest("zero", query))

    def _on_arm(self, query: zenoh.Query) -> None:
        self.requests.put(BusRequest("arm", query))

    def _on_run(self, query: zenoh.Query) -> None:
        run_id = query.parameters.get("id")
        if run_id is None and query.payload is not None:
            run_id = query.payload.to_string()
        self.requests.put(BusRequest("run", query, run_id))

    # --- lifetime ---------------------------------------------------------------------------------
    def close(self) -> None:
        """Undeclare everything (callbacks outlive their Python handles otherwise), close."""
        for name in ("_token", "_samples", "_state"):
            handle = getattr(self, name, None)
            if handle is not None:
                handle.undeclare()
        for queryable in getattr(self, "_queryables", []):
            queryable.undeclare()
        for pub in self._finished_pubs.values():
            pub.undeclare()
        self._finished_pubs.clear()
        if self._own_session:
            self.session.close()
