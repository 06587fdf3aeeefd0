"""Which run a worker fits next: a pure state machine, no Zenoh, files or clocks.

The adapter (`ident.worker.service`) feeds it events — a run announced, a fit report or
claim seen, a worker up or down — and asks it two questions: "what should I claim now?"
(`next_claim`) and, after the claim has had time to reach the other workers, "did my
claim win?" (`claim_won`), and before a final report goes out, "am I fenced?" (`fenced`).
See `ident.worker` for the exactly-once argument.

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
    """What a worker knows about one run.

    `claims` maps each claimant to its claim's epoch; `top_epoch` is the highest epoch ever
    seen for the run (a vanished worker's claim still counts there, so a take-over outranks
    it). `unverified` holds final reports that do not (yet) match the daq's record.
    `not_before` defers a run whose file could not be had (a transient failure).
    """

    finished: RunFinished | None = None
    final: FitReport | None = None
    claims: dict[str, int] = field(default_factory=dict)
    top_epoch: int = 0
    order: int = 0
    unverified: list[FitReport] = field(default_factory=list)
    not_before: float = 0.0

    @property
    def claimants(self) -> set[str]:
        return set(self.claims)


#: Most unverified final reports kept per run (a flood of forgeries cannot grow memory).
MAX_UNVERIFIED = 4


def verified(report: FitReport, finished: RunFinished | None) -> bool:
    """A final report counts for a run only if it names the daq's record of that run."""
    return finished is not None and report.run_digest == finished.digest()


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
            for report in state.unverified:
                self._final(state, report)
            state.unverified.clear()
        return run

    def fit_seen(self, report: FitReport) -> RunRef:
        """A fit message on the bus or a report on disk: a claim or a final result."""
        run = RunRef(report.bench, report.run_id)
        state = self._state(run)
        if report.final:
            self._final(state, report)
        elif report.status == "withdrawn":
            state.claims.pop(report.worker, None)
        elif state.final is None:
            state.claims[report.worker] = report.epoch
            state.top_epoch = max(state.top_epoch, report.epoch)
        return run

    def _final(self, state: RunState, report: FitReport) -> None:
        if state.finished is None:
            if len(state.unverified) < MAX_UNVERIFIED:
                state.unverified.append(report)
            return
        if not verified(report, state.finished):
            return   # not for the run the daq recorded (forged, or stale): not done
        if state.final is None:
            state.final = report
        state.claims.clear()

    def worker_up(self, worker: str) -> None:
        self.alive.add(worker)

    def worker_down(self, worker: str) -> list[RunRef]:
        """Forget a vanished worker and its claims; return the runs it had claimed."""
        if worker == self.me:
            return []
        self.alive.discard(worker)
        orphaned = []
        for run, state in self.runs.items():
            if worker in state.claims:
                del state.claims[worker]
                orphaned.append(run)
        return orphaned

    def withdraw(self, run: RunRef) -> None:
        """Drop my own claim (lost the tie-break, or the fit was abandoned)."""
        self._state(run).claims.pop(self.me, None)

    def defer(self, run: RunRef, until: float) -> None:
        """Drop my claim and leave the run alone until `until` (caller's clock): its file
        could not be had for now (the daq is away); it is retried, never failed for that."""
        state = self._state(run)
        state.claims.pop(self.me, None)
        state.not_before = until

    def retry_now(self, bench: str) -> None:
        """The daq of `bench` is back: its deferred runs may be tried at once."""
        for run, state in self.runs.items():
            if run.bench == bench:
                state.not_before = 0.0

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

    def next_claim(self, now: float = 0.0) -> RunRef | None:
        """The oldest pending run that I own, nobody alive (me included) has claimed, and that
        is not deferred past `now`."""
        for run in self.pending():
            if (owner(run, self.alive) == self.me and not self.live_claimants(run)
                    and self.runs[run].not_before <= now):
                return run
        return None

    def claim(self, run: RunRef) -> int:
        """Claim `run`; returns the claim's epoch (one more than any seen for the run)."""
        state = self._state(run)
        state.top_epoch += 1
        state.claims[self.me] = state.top_epoch
        return state.top_epoch

    def claim_won(self, run: RunRef) -> bool:
        """After the settle window: is my claim the highest (epoch, score) among the alive
        claimants of an unfitted run?

        Two workers whose views of the alive set differed for a moment may both claim;
        both see both claims after the window and apply this same rule, so one proceeds.
        """
        return not self.is_done(run) and self.fenced(run) is None

    def fenced(self, run: RunRef) -> str | None:
        """Why I must not publish a final report for `run` now (None: I may).

        Another worker's final report was seen, or an alive worker holds a claim that
        outranks mine (a higher epoch; at equal epochs, the higher rendezvous score).
        """
        state = self._state(run)
        if state.final is not None and state.final.worker != self.me:
            return f"{state.final.worker} already published its final report"
        mine = state.claims.get(self.me, 0)
        for worker in self.live_claimants(run) - {self.me}:
            theirs = state.claims[worker]
            if (theirs, score(worker, run), worker) > (mine, score(self.me, run), self.me):
                return f"{worker}'s claim (epoch {theirs}) outranks mine (epoch {mine})"
        return None

    def my_share(self) -> list[RunRef]:
        """Pending runs I own now (for progress and tests)."""
        return [run for run in self.pending() if owner(run, self.alive) == self.me]


__all__ = ["MAX_UNVERIFIED", "RunRef", "RunState", "Scheduler", "owner", "score", "verified"]
