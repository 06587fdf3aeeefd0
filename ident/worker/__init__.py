"""`ident worker`: fit every finished run of every bench, exactly once, over Zenoh.

Modules: `schedule` (pure: who fits what), `bus` (Zenoh adapter, callbacks only enqueue),
`runs_dir` (files), `service` (the loop), `fitproc` (fits in a child process, so a stop
cancels them cleanly), `pipeline` (the default fitter: simple ID with RK4 and Euler, PEM of order 2 or 4
published at once, then the diagnosis and the figures).

How a run is fitted exactly once
--------------------------------
Every worker holds a liveliness token `keys.ident_alive(name)` (declared once its fit
process is ready to take a job) and follows the others'
tokens (liveliness subscriber with history), so each knows the set A of alive workers;
a token disappears within milliseconds of a clean exit or a kill -9 on a LAN (the TCP
reset), or after the Zenoh lease (10 s) for a hung host.

1. Ownership by rendezvous hashing. The owner of run r is `argmax_{w in A} h(w, r)`
   (`schedule.owner`). All workers compute it from the same A, so they agree without
   talking; when a worker leaves, only its runs move, each to its next-highest scorer.
2. Done means a complete report exists. A run is skipped when an `ok`/`failed` report
   with nothing `pending` was seen on `runs/<run_id>/fit` (advanced subscriber with
   history: reports published before this worker started arrive too) or is stored in
   `<run_id>.fit/report.json` (written atomically before it is published; a stored report
   is republished, not refitted), or remembered by another alive worker: each answers a
   queryable on `keys.ALL_FITS` with every complete report it has seen and asks it at
   start, so a run fitted by a worker that is gone stays done while any witness lives. An
   early report (transfer functions published while the diagnosis runs, `pending` not
   empty) is not done: it counts as its worker's claim.
3. Claim, settle, check. Before fitting, the owner publishes a `fitting` claim on the
   run's fit key, handles events for `settle_s` (0.2 s by default; claims cross a LAN in
   milliseconds), then fits only if it is the highest-scoring alive claimant and no final
   report arrived. A worker never claims a run that another alive worker has claimed.
   Two workers whose views of A briefly differed (one just started) can both claim; both
   see both claims after the window and apply the same rule, so exactly one proceeds and
   the other publishes `withdrawn`.
4. Take-over. A claim is void once its worker's token is gone. When a worker dies
   mid-fit, the others drop its claims, recompute owners over the smaller A, and the new
   owner of each orphaned run claims and fits it. The dead worker published no complete
   report (it publishes only after writing report.json), so the run is completed once (if
   it died after its early report, the first stage is computed a second time). A worker
   that restarts recovers its state from history, the runs directory and each daq's
   `runs` queryable. SIGTERM/SIGINT make a worker leave at once, even mid-fit.

5. Fencing. A worker whose token vanished may not be gone: a process stopped (SIGSTOP) or
   cut off for longer than the lease comes back mid-fit. Each claim carries an epoch, one
   more than any claim seen for the run, so the take-over outranks the stale claim. Before
   publishing a final report a worker handles pending events, asks the other workers' fit
   queryables about that run (they answer with final reports and their claims in progress),
   and after a stall of its own loop first waits for its session to reconnect and catches
   up; it publishes only if no other worker's final report and no alive claim of a higher
   epoch was seen. A fenced result is dropped.
6. At least once. A run whose file cannot be had (no local file, the daq does not answer)
   is deferred, never failed for that: the claim is withdrawn and the run tried again when
   the daq's token comes back, or after `retry_s`. A final report counts only if its
   `run_digest` matches the daq's record of the run, so a forged report for a run (sent
   before the run existed, or naming another record) does not stop it being fitted.

Limits: the argument assumes claims and queries reach the other workers within `settle_s`
and the query timeout. Anyone who can publish on `cartlab/**` can still forge a report with
the right digest: a router with access control (docs) is what keeps forged records away.

Late start and restarts: finished records come from the daq's advanced publishers
(history), from the `runs` queryable of every alive daq (asked at start and whenever a
daq appears) and from a scan of `--runs-dir`.
"""

from ident.worker.schedule import RunRef, Scheduler, owner, score

__all__ = ["RunRef", "Scheduler", "owner", "score"]
