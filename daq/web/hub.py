"""What the bench page knows: benches, detector state, daq status, runs and fits.

A plain state machine fed with `schemas` records (by the Zenoh adapter, on the event
loop, never on a Zenoh thread). Every change queues an `Event`; `flush()` hands out the
queued events plus one decimated `samples` event per bench, so the page receives at most
one batch per bench per flush (the server flushes every 50 ms: at most 20 updates/s). What
was flushed also goes to the bench's bounded `History`, which the snapshot carries.

Pure: no clock, no I/O, no Zenoh. Names in events are JSON-ready dicts.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from daq.web.live import DEFAULT_DISPLAY_HZ, Decimator, History
from daq.web.runs_view import fit_summary, run_row
from schemas.daq import DaqStatus, DetectorStateMsg, RunFinished, RunList, SampleBatch
from schemas.fit import FitReport

#: Detector state changes kept per bench for the plot's marks (a run is 2-3 of them).
MAX_STATE_MARKS = 64

NO_DAQ = ("no daq found on Zenoh: start one (`daq run --port ... --bench NAME`) and check that "
          "this server connects to it (--connect ENDPOINT, default tcp/127.0.0.1:7447)")


@dataclass(frozen=True)
class Event:
    """One server-sent event: `name`, the bench it concerns (None: every page), JSON data."""

    name: str
    bench: str | None
    data: dict[str, Any]


@dataclass
class BenchView:
    """Everything known about one bench."""

    name: str
    alive: bool = False
    state: DetectorStateMsg | None = None
    status: DaqStatus | None = None
    status_error: str | None = None
    finished: dict[str, RunFinished] = field(default_factory=dict)
    fits: dict[str, FitReport] = field(default_factory=dict)
    #: Unix time (s) since which what is shown is no longer current (daq gone or silent,
    #: port unplugged), None while it is; set from the caller's clock (the hub has none).
    stale_since: float | None = None
    decimator: Decimator = field(default_factory=Decimator)
    #: The last detector state changes (device time), for the release and run marks of a
    #: page that opens late; bounded.
    states: deque[DetectorStateMsg] = field(default_factory=lambda: deque(maxlen=MAX_STATE_MARKS))
    history: History = field(default_factory=History)


def bench_problems(view: BenchView) -> list[str]:
    """Messages a person can act on, worst first."""
    if not view.alive:
        return [f"daq for bench {view.name} is not running: start it with "
                f"`daq run --bench {view.name} --port ...` (or check its Zenoh endpoint)"]
    problems = []
    if view.status_error:
        problems.append(view.status_error)
    if view.status is not None and not view.status.connected:
        problems.append(f"encoder port {view.status.port} is not connected: check the USB "
                        "cable and power of the encoder box; daq reopens the port by itself")
    return problems


def stale_reason(view: BenchView) -> str | None:
    """Why the state and positions shown are not current (None: they are): short, for badges."""
    if not view.alive:
        return "daq gone"
    if view.status_error:
        return "daq not answering"
    if view.status is not None and not view.status.connected:
        return "port gone"
    return None


def update_stale(view: BenchView, now_s: float | None) -> None:
    """Start the stale clock when the bench turns stale (at `now_s`), stop it when it is back."""
    if stale_reason(view) is None:
        view.stale_since = None
    elif view.stale_since is None:
        view.stale_since = now_s


def status_view(view: BenchView) -> dict[str, Any]:
    status = view.status
    return {
        "bench": view.name,
        "alive": view.alive,
        "status": None if status is None else status.model_dump(mode="json"),
        "problems": bench_problems(view),
        "stale": stale_reason(view),
        "stale_since": view.stale_since,
    }


class Hub:
    """The page's model of every bench; see the module docstring."""

    def __init__(self, display_hz: float = DEFAULT_DISPLAY_HZ,
                 fit_files: Callable[[str], list[str]] | None = None) -> None:
        """`fit_files(run_id)` lists the files of a run's fit folder (injected: I/O)."""
        self.display_hz = display_hz
        self._fit_files = fit_files or (lambda run_id: [])
        self.benches: dict[str, BenchView] = {}
        self._events: list[Event] = []
        self.samples_in = 0

    def bench(self, name: str) -> BenchView:
        view = self.benches.get(name)
        if view is None:
            view = BenchView(name=name, decimator=Decimator(self.display_hz),
                             history=History(self.display_hz))
            self.benches[name] = view
        return view

    def bench_list(self) -> list[dict[str, Any]]:
        return [{"name": v.name, "alive": v.alive} for v in sorted(self.benches.values(),
                                                                     key=lambda v: v.name)]

    def default_bench(self) -> str | None:
        alive = [b["name"] for b in self.bench_list() if b["alive"]]
        names = alive or [b["name"] for b in self.bench_list()]
        return names[0] if names else None

    def _emit(self, name: str, bench: str | None, data: dict[str, Any]) -> None:
        self._events.append(Event(name, bench, data))

    def on_alive(self, bench: str, alive: bool, now_s: float | None = None) -> None:
        """The daq's liveliness; `now_s` (unix s) dates a turn to stale."""
        view = self.bench(bench)
        if view.alive == alive:
            return
        view.alive = alive
        if not alive:
            view.status_error = None
        update_stale(view, now_s)
        self._emit("benches", None, {"benches": self.bench_list()})
        self._emit("status", bench, status_view(view))

    def on_samples(self, batch: SampleBatch) -> None:
        self.samples_in += len(batch.t_ns)
        self.bench(batch.bench).decimator.feed(batch)

    def on_state(self, msg: DetectorStateMsg) -> None:
        view = self.bench(msg.bench)
        view.state = msg
        if not view.states or view.states[-1] != msg:
            view.states.append(msg)
        self._emit("state", msg.bench, msg.model_dump(mode="json"))

    def on_status(self, bench: str, status: DaqStatus | None, error: str | None,
                  now_s: float | None = None) -> None:
        """A status reply (or the error of asking); `now_s` (unix s) dates a turn to stale."""
        view = self.bench(bench)
        view.status, view.status_error = (status or view.status), error
        update_stale(view, now_s)
        if status is not None and (view.state is None or view.state.state != status.state):
            view.state = DetectorStateMsg(bench=bench, state=status.state,
                                          t_ns=status.last_t_ns or 0, run_id=status.run_id)
            self._emit("state", bench, view.state.model_dump(mode="json"))
        self._emit("status", bench, status_view(view))

    def on_finished(self, rec: RunFinished) -> None:
        view = self.bench(rec.bench)
        if view.finished.get(rec.run_id) == rec:
            return
        view.finished[rec.run_id] = rec
        self._emit("run", rec.bench, self.row(rec.bench, rec.run_id))

    def on_runs(self, runs: RunList) -> None:
        for rec in runs.runs:
            self.on_finished(rec)

    def on_fit(self, report: FitReport) -> None:
        view = self.bench(report.bench)
        old = view.fits.get(report.run_id)
        if old is not None and old.final and not report.final:
            return  # a late claim never hides a result
        if old == report:
            return
        view.fits[report.run_id] = report
        self._emit("run", report.bench, self.row(report.bench, report.run_id))

    def row(self, bench: str, run_id: str) -> dict[str, Any]:
        view = self.bench(bench)
        report = view.fits.get(run_id)
        row = run_row(bench, run_id, view.finished.get(run_id),
                      None if report is None else fit_summary(report))
        row["fit_files"] = self._fit_files(run_id)
        return row

    def rows(self, bench: str) -> list[dict[str, Any]]:
        view = self.benches.get(bench)
        if view is None:
            return []
        run_ids = sorted(set(view.finished) | set(view.fits))
        return [self.row(bench, run_id) for run_id in run_ids]

    def snapshot(self, bench: str | None) -> dict[str, Any]:
        """Everything a page showing `bench` needs when it (re)connects."""
        if bench is None:
            nobody = {"bench": None, "alive": False, "status": None, "problems": [NO_DAQ],
                      "stale": None, "stale_since": None}
            return {"bench": None, "benches": self.bench_list(), "state": None,
                    "status": nobody, "runs": [], "history": None, "states": []}
        view = self.benches.get(bench) or BenchView(name=bench)  # a name asked for is not stored
        return {
            "bench": bench,
            "benches": self.bench_list(),
            "state": None if view.state is None else view.state.model_dump(mode="json"),
            "status": status_view(view),
            "runs": self.rows(bench),
            "history": view.history.as_event(bench),
            "states": [m.model_dump(mode="json") for m in view.states],
        }

    def flush(self) -> list[Event]:
        """Queued change events, then one decimated `samples` event per bench."""
        events, self._events = self._events, []
        for name, view in self.benches.items():
            pending = view.decimator.take()
            if pending is not None:
                view.history.extend(pending)
                events.append(Event("samples", name, pending.as_event(name)))
        return events
