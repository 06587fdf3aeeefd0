"""Which run a worker fits next: a pure state machine, no Zenoh, files or clocks.

The adapter (`ident.worker.service`) feeds it events — a run announced, a fit report or
claim seen, a worker up or down — and asks it two questions: "what should I claim now?"
(`next_claim`) and, after the claim has had time to reach the other workers, "did my
claim win?" (`claim_won`). See `ident.worker` for the exactly-once argument.

Rendezvous (highest-random-weight) hashing: the owner of a run among the alive workers
is the one with the highest `score(worker, run)`, a 64-bit hash of both names. Every
worker computes the same owner from the same set, and when a worker leaves only its own
runs move (to each run's next-highest scorer).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field

from schemas.daq import RunFinished
from schemas.fit import FitReport


@dataclass(frozen=True, order=True, slots=True)
class RunRef:
    """A run of a bench: the pair is unique across a lab."""

    bench: str
    run_id: str

    def __str__(self) -> str:
        return f"{self.bench}/{self.run_id}"


def score(worker: str, run: RunRef) -> int:
    """Rendezvous weight of `worker` for `run`: the first 8 bytes of blake2b, big-endian."""
    digest = hashlib.blake2b(f"{worker}\0{run.bench}\0{run.run_id}".encode(), digest_size=8)
    return int.from_bytes(digest.digest(), "big")


def owner(run: RunRef, workers: set[str] | frozenset[str]) -> str | None:
    """The alive worker that owns `run` (ties, which need a hash collision, go to the name)."""
    if not workers:
        return None
    return max(workers, key=lambda w: (score(w, run), w))


@dataclass
class RunState:
    """What a worker knows about one run."""

    finished: RunFinished | None = None
    final: FitReport | None = None
    claimants: set[str] = field(default_factory=set)
    order: int = 0


@dataclass
class Scheduler:
    """Runs, claims and alive workers as seen by worker `me`."""

    me: str
    alive: set[str] = field(default_factory=set)
    runs: dict[RunRef, RunState] = field(default_factory=dict)
    _counter: int = 0

    def __post_init__(self) -> None:
        self.alive.add(self.me)

    # -- events -----------------------------------------------------------------------
    def _state(self, run: RunRef) -> RunState:
        state = self.runs.get(run)
        if state is None:
            self._counter += 1
            state = self.runs[run] = RunState(order=self._counter)
        return state

    def run_announced(self, finished: RunFinished) -> RunRef:
        """A `finished` record (live, from history, from a `runs` query or a file scan)."""
        run = RunRef(finished.bench, finished.run_id)
        state = self._state(run)
        if state.finished is None:
            state.finished = finished
        return run

    def fit_seen(self, report: FitReport) -> RunRef:
        """A fit message on the bus or a report on disk: a claim or a final result."""
        run = RunRef(report.bench, report.run_id)
        state = self._state(run)
        if report.final:
            if state.final is None:
                state.final = report
            state.claimants.clear()
        elif report.status == "withdrawn":
            state.claimants.discard(report.worker)
        elif state.final is None:
            state.claimants.add(report.worker)
        return run

    def worker_up(self, worker: str) -> None:
        self.alive.add(worker)

    def worker_down(self, worker: str) -> list[RunRef]:
        """Forget a vanished worker and its claims; return the runs it had claimed."""
        if worker == self.me:
            return []
        self.alive.discard(worker)
        orphaned = []
        for run, state in self.runs.items():
            if worker in state.claimants:
                state.claimants.discard(worker)
                orphaned.append(run)
        return orphaned

    def withdraw(self, run: RunRef) -> None:
        """Drop my own claim (lost the tie-break, or the fit was abandoned)."""
        self._state(run).claimants.discard(self.me)

    # -- decisions ----------------------------------------------------------------------
    def is_done(self, run: RunRef) -> bool:
        state = self.runs.get(run)
        return state is not None and state.final is not None

    def live_claimants(self, run: RunRef) -> set[str]:
        state = self.runs.get(run)
        return set() if state is None else state.claimants & self.alive

    def pending(self) -> list[RunRef]:
        """Announced runs without a final report, oldest first."""
        waiting = [(s.order, r) for r, s in self.runs.items() if s.final is None and s.finished]
        return [run for _, run in sorted(waiting)]

    def next_claim(self) -> RunRef | None:
        """The oldest pending run that I own and nobody alive (me included) has claimed."""
        for run in self.pending():
            if owner(run, self.alive) == self.me and not self.live_claimants(run):
                return run
        return None

    def claim(self, run: RunRef) -> None:
        self._state(run).claimants.add(self.me)

    def claim_won(self, run: RunRef) -> bool:
        """After the settle window: am I the highest-scoring alive claimant of an unfitted run?

        Two workers whose views of the alive set differed for a moment may both claim;
        both see both claims after the window and apply this same rule, so one proceeds.
        """
        if self.is_done(run):
            return False
        claimants = self.live_claimants(run) | {self.me}
        return owner(run, claimants) == self.me

    def my_share(self) -> list[RunRef]:
        """Pending runs I own now (for progress and tests)."""
        return [run for run in self.pending() if owner(run, self.alive) == self.me]


__all__ = ["RunRef", "RunState", "Scheduler", "owner", "score"]
