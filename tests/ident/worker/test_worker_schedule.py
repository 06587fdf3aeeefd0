"""The pure scheduler: ownership by rendezvous hashing, claims, take-over."""

from __future__ import annotations

import random

from ident.worker.schedule import RunRef, Scheduler, owner
from schemas.daq import RunFinished
from schemas.fit import FitReport


def _finished(run_id: str, bench: str = "b1") -> RunFinished:
    return RunFinished(bench=bench, run_id=run_id, status="complete", file=f"{run_id}.mcap",
                       n_samples=100, release_time_s=0.5, duration_s=1.0)


def _report(run_id: str, worker: str, status: str, bench: str = "b1", epoch: int = 0) -> FitReport:
    return FitReport(bench=bench, run_id=run_id, worker=worker, status=status,  # type: ignore[arg-type]
                     reason="x" if status == "failed" else None, epoch=epoch,
                     run_digest=_finished(run_id, bench).digest())


def test_owners_agree_and_only_the_leavers_runs_move() -> None:
    rng = random.Random(7)
    runs = [RunRef(f"b{rng.randint(1, 3)}", f"r{i}") for i in range(300)]
    workers = {"w1", "w2", "w3"}
    before = {run: owner(run, workers) for run in runs}
    counts = {w: sum(1 for o in before.values() if o == w) for w in workers}
    assert all(60 < c < 140 for c in counts.values()), counts   # roughly even shares
    after = {run: owner(run, workers - {"w2"}) for run in runs}
    moved = [run for run in runs if before[run] != after[run]]
    assert moved and all(before[run] == "w2" for run in moved)
    assert all(after[run] in {"w1", "w3"} for run in runs)


def _two_schedulers(n_runs: int) -> tuple[Scheduler, Scheduler, list[RunRef]]:
    a, b = Scheduler("wa"), Scheduler("wb")
    refs = []
    for s in (a, b):
        s.worker_up("wa")
        s.worker_up("wb")
    for i in range(n_runs):
        refs.append(a.run_announced(_finished(f"r{i}")))
        b.run_announced(_finished(f"r{i}"))
    return a, b, refs


def test_each_run_goes_to_exactly_one_of_two_workers() -> None:
    a, b, refs = _two_schedulers(40)
    assert set(a.my_share()) | set(b.my_share()) == set(refs)
    assert not set(a.my_share()) & set(b.my_share())
    run = a.next_claim()
    assert run is not None and run in a.my_share() and b.next_claim() != run
    a.claim(run)                                   # in progress (e.g. being diagnosed)
    assert a.next_claim() != run


def test_a_claim_blocks_others_and_dies_with_its_worker() -> None:
    a, b, refs = _two_schedulers(20)
    run_of_b = b.my_share()[0]
    b.claim(run_of_b)
    a.fit_seen(_report(run_of_b.run_id, "wb", "fitting"))
    a_alone = Scheduler("wa")
    a_alone.run_announced(_finished(run_of_b.run_id))
    assert a_alone.next_claim() == run_of_b       # alone, it would take it
    assert a.next_claim() != run_of_b
    orphaned = a.worker_down("wb")
    assert orphaned == [run_of_b]
    assert set(a.my_share()) == set(refs)          # every unfitted run is now a's


def test_simultaneous_claims_resolve_to_one_winner() -> None:
    a, b, refs = _two_schedulers(30)
    for run in refs:
        a.claim(run)
        b.claim(run)
        a.fit_seen(_report(run.run_id, "wb", "fitting", epoch=1))   # both saw no claim before:
        b.fit_seen(_report(run.run_id, "wa", "fitting", epoch=1))   # both claim epoch 1
        assert a.claim_won(run) != b.claim_won(run)


def test_final_reports_end_a_run_and_withdrawals_release_it() -> None:
    a, _b, refs = _two_schedulers(10)
    for run in refs:
        a.fit_seen(_report(run.run_id, "wb", "ok"))
    assert a.pending() == [] and a.next_claim() is None
    c = Scheduler("wc")
    c.worker_up("wd")
    run_id = next(f"rx{i}" for i in range(100) if owner(RunRef("b1", f"rx{i}"), c.alive) == "wc")
    run = c.run_announced(_finished(run_id))
    c.fit_seen(_report(run_id, "wd", "fitting"))
    assert c.next_claim() is None                  # claimed by another alive worker
    c.fit_seen(_report(run_id, "wd", "withdrawn"))
    assert c.live_claimants(run) == set() and c.next_claim() == run


def test_a_take_over_outranks_the_stale_claim_of_a_worker_that_comes_back() -> None:
    a, b, _ = _two_schedulers(20)
    run = b.my_share()[0]
    epoch_b = b.claim(run)                          # b claims, then is stopped past the lease
    a.fit_seen(_report(run.run_id, "wb", "fitting", epoch=epoch_b))
    a.worker_down("wb")
    assert a.next_claim() == run
    epoch_a = a.claim(run)
    assert epoch_a == epoch_b + 1 and a.claim_won(run)
    b.fit_seen(_report(run.run_id, "wa", "fitting", epoch=epoch_a))   # b resumes and syncs
    assert b.fenced(run) is not None and a.fenced(run) is None
    b.fit_seen(_report(run.run_id, "wa", "ok", epoch=epoch_a))
    assert "already published" in (b.fenced(run) or "")


def test_a_final_report_counts_only_for_the_record_the_daq_made() -> None:
    a, _, refs = _two_schedulers(3)
    run = refs[0]
    forged = FitReport(bench="b1", run_id=run.run_id, worker="mallory", status="ok")
    a.fit_seen(forged)
    a.fit_seen(forged.model_copy(update={"run_digest": "0" * 16}))
    assert not a.is_done(run) and run in a.pending()
    early = Scheduler("wa")                          # a report before the run was announced
    early.fit_seen(_report("r9", "wb", "ok"))
    early.fit_seen(forged.model_copy(update={"run_id": "r9"}))
    assert not early.is_done(RunRef("b1", "r9"))
    early.run_announced(_finished("r9"))
    assert early.is_done(RunRef("b1", "r9")) and early.runs[RunRef("b1", "r9")].final.worker == "wb"  # type: ignore[union-attr]


def test_a_deferred_run_waits_until_its_daq_is_back() -> None:
    a = Scheduler("wa")
    run = a.run_announced(_finished("r1"))
    a.claim(run)
    a.defer(run, until=100.0)
    assert a.next_claim(now=50.0) is None and a.next_claim(now=100.0) == run
    a.retry_now("b1")
    assert a.next_claim(now=0.0) == run
