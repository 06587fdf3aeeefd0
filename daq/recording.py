"""The open run file of the service, with a full disk treated as an event, not a crash.

A write that fails with "no space" (ENOSPC, EDQUOT) or "file too large" (EFBIG) ends the
file being written (it stays as `<run_id>.mcap.part`, everything flushed so far in it) and
suspends recording; the live stream is not touched (it is published before anything is
written). The failure is logged once, naming the path and the run. The batches not yet
flushed, and every batch while suspended, are kept in memory (at most `backlog_samples`
samples; beyond, the oldest go). A new file is tried every `retry_s`; when one can be opened
(space came back) recording goes on in a continuation `<run_id>-p<k>.mcap.part`, which starts
with the kept batches (so nothing is lost when the disk was full for less than the backlog);
the suspended part is recovered at once into a finished file (`daq.recorder.recover_one`),
which says what it really holds: the MCAP writer may have pushed full chunks of the batches
we counted as unflushed, so the kept samples up to the part's last one are not written again,
and a gap (`disk_full`) is marked only if samples after it had to be dropped, from the part's
last sample to the first one kept. When the run ends, the continuation is finished under its
own name; a run that ends while the disk is still full leaves its part for recovery at the
next start, and its reason names the span not recorded.

Other write errors are not ours to hide: they propagate.
"""

from __future__ import annotations

import errno
import logging
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO

from daq.errors import DaqIOError
from daq.recorder import RunWriter, open_exclusive, recover_one
from schemas import run_file
from schemas.daq import DetectorStateMsg, GapInterval, RunFinished, RunMetadata, SampleBatch

log = logging.getLogger("daq.service")

#: errno values that mean "the disk (or quota) is full" rather than a broken file system.
FULL_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG})


def is_disk_full(exc: BaseException) -> bool:
    """True if `exc` (or what it was raised from) is a full-disk error."""
    while exc is not None:
        if isinstance(exc, OSError) and exc.errno in FULL_ERRNOS:
            return True
        exc = exc.__cause__  # type: ignore[assignment]
    return False


#: Most samples kept in memory while the disk is full (5 min at 1 kHz, about 10 MB).
BACKLOG_SAMPLES = 300_000


@dataclass
class _Suspended:
    """A run whose recording stopped on a full disk, and the batches kept meanwhile."""

    metadata: RunMetadata
    part: Path
    last_written_t_ns: int | None
    next_try_s: float
    backlog: deque[SampleBatch] = field(default_factory=deque)
    kept: int = 0
    dropped_after_t_ns: int | None = None   # the last sample dropped from the backlog

    def keep(self, batch: SampleBatch, limit: int) -> None:
        self.backlog.append(batch)
        self.kept += len(batch.t_ns)
        while self.kept > limit and len(self.backlog) > 1:
            old = self.backlog.popleft()
            self.kept -= len(old.t_ns)
            self.dropped_after_t_ns = old.t_ns[-1] if old.t_ns else self.dropped_after_t_ns


class Recording:
    """The service's run file: start, samples, states, finish; survives a full disk."""

    def __init__(self, runs_dir: Path, flush_interval_s: float, clock: Callable[[], float],
                 opener: Callable[[Path], BinaryIO] = open_exclusive, retry_s: float = 1.0,
                 on_recovered: Callable[[RunFinished], None] | None = None,
                 backlog_samples: int = BACKLOG_SAMPLES) -> None:
        self.runs_dir = runs_dir
        self.flush_interval_s = flush_interval_s
        self.clock = clock
        self.opener = opener
        self.retry_s = retry_s
        self.on_recovered = on_recovered
        self.backlog_samples = backlog_samples
        self.writer: RunWriter | None = None
        self._unflushed: list[SampleBatch] = []   # written since the writer's last flush
        self.suspended: _Suspended | None = None
        self.disk_full_events = 0
        self._pieces = 0
        self._gaps: list[GapInterval] = []

    # -- run lifecycle ------------------------------------------------------------------------
    def start(self, metadata: RunMetadata) -> None:
        self._pieces, self._gaps, self._unflushed = 0, [], []
        try:
            self.writer = RunWriter(self.runs_dir, metadata, self.clock(), self.flush_interval_s,
                                    opener=self.opener)
        except (DaqIOError, OSError) as exc:
            if not is_disk_full(exc):
                raise
            self._suspend(metadata, run_file.part_path(self.runs_dir, metadata.run_id), None, exc)

    def samples(self, batch: SampleBatch) -> None:
        if self.writer is None and self.suspended is not None:
            self.suspended.keep(batch, self.backlog_samples)
            self._try_resume()
            return
        if self.writer is not None:
            self._write(batch)

    def _write(self, batch: SampleBatch) -> None:
        writer = self.writer
        assert writer is not None
        flushes = writer.flush_count
        self._unflushed.append(batch)
        self._guard(lambda w: w.write_samples(batch, self.clock()))
        if self.writer is not None and writer.flush_count != flushes:
            self._unflushed = []   # the flush inside the write pushed this batch and the earlier ones

    def state(self, msg: DetectorStateMsg) -> None:
        if self.writer is not None:
            self._guard(lambda w: w.write_state(msg, self.clock()))

    def flush(self, now_s: float, always: bool = False) -> None:
        writer = self.writer
        if writer is not None:
            flushes = writer.flush_count
            self._guard(lambda w: w.flush(now_s) if always else w.maybe_flush(now_s))
            if self.writer is not None and writer.flush_count != flushes:
                self._unflushed = []

    def finish(self, metadata: RunMetadata, finished: RunFinished) -> RunFinished:
        """Seal the run (or its continuation); returns the record to announce."""
        writer, self.writer = self.writer, None
        suspended, self.suspended = self.suspended, None
        if writer is None:
            if suspended is None:
                return finished
            reason = (f"disk full: recording stopped at {suspended.part.name}; {_unrecorded(suspended)}; "
                      "its part is recovered at the next start")
            log.error("run %s ended while the disk is still full (%s)", metadata.run_id, suspended.part)
            return finished.model_copy(update={"status": "aborted", "reason": reason})
        if self._pieces == 0:
            try:
                writer.finish(metadata, finished)
            except (DaqIOError, OSError) as exc:
                if not is_disk_full(exc):
                    raise
                self._disk_full_log(writer.path, metadata.run_id, exc)
                writer.abandon_quietly()
                return finished.model_copy(update={"status": "aborted", "reason": "disk full when finishing; "
                                                   "the part is recovered at the next start"})
            return finished
        return self._finish_piece(writer, metadata, finished)

    def abandon(self) -> None:
        if self.writer is not None:
            self.writer.abandon_quietly()
            self.writer = None

    # -- the full-disk path ---------------------------------------------------------------------
    def _guard(self, action: Callable[[RunWriter], None]) -> None:
        writer = self.writer
        assert writer is not None
        try:
            action(writer)
        except (DaqIOError, OSError) as exc:
            if not is_disk_full(exc):
                raise
            self.writer = None
            writer.abandon_quietly()
            unflushed, self._unflushed = self._unflushed, []
            last = next((b.t_ns[0] for b in unflushed if b.t_ns), None)
            self._suspend(writer.metadata, writer.path, writer.last_t_ns if last is None else last, exc)
            assert self.suspended is not None
            for kept in unflushed:   # what the part may not hold is written again after the gap
                self.suspended.keep(kept, self.backlog_samples)

    def _suspend(self, metadata: RunMetadata, part: Path, last_t_ns: int | None, exc: BaseException) -> None:
        self.disk_full_events += 1
        self._disk_full_log(part, metadata.run_id, exc)
        self.suspended = _Suspended(metadata, part, last_t_ns, self.clock() + self.retry_s)

    @staticmethod
    def _disk_full_log(path: Path, run_id: str, exc: BaseException) -> None:
        log.error("disk full writing %s (run %s): %s; the live stream goes on, recording resumes "
                  "when space returns", path, run_id, exc)

    def _try_resume(self) -> None:
        suspended = self.suspended
        assert suspended is not None
        now = self.clock()
        if now < suspended.next_try_s or not suspended.backlog:
            return
        piece_id = f"{run_file.run_id_of(suspended.part)}-p{self._pieces + 2}"
        # the gap as far as the kept batches tell (the new file's start metadata; a crash of
        # the continuation leaves at least that); made exact below once the part is recovered
        provisional = self._overflow_gap(suspended, None)
        gaps = [*self._gaps, *([provisional] if provisional is not None else [])]
        counters = suspended.metadata.counters.model_copy(
            update={"gap_intervals": [*suspended.metadata.counters.gap_intervals, *gaps]})
        metadata = suspended.metadata.model_copy(update={"run_id": piece_id, "counters": counters})
        try:
            self.writer = RunWriter(self.runs_dir, metadata, now, self.flush_interval_s, opener=self.opener)
        except (DaqIOError, OSError) as exc:
            if not is_disk_full(exc):
                raise
            # the try may have left a header-only file of ours: not data, and in the next try's way
            run_file.part_path(self.runs_dir, piece_id).unlink(missing_ok=True)
            suspended.next_try_s = now + self.retry_s
            return
        self._pieces += 1
        self.suspended = None
        in_part = self._recover(suspended.part)
        exact = self._overflow_gap(suspended, in_part)
        self._gaps = [*self._gaps, *([exact] if exact is not None else [])]
        log.warning("space is back: run %s goes on in %s (the %d samples kept meanwhile first%s)",
                    suspended.metadata.run_id, self.writer.path.name, suspended.kept,
                    f"; the backlog overflowed: samples {exact.start_t_ns / 1e9:.3f}-{exact.end_t_ns / 1e9:.3f} s "
                    "(device clock) lost, the gap marked" if exact is not None else "")
        for kept in _after(suspended.backlog, in_part):   # the part's samples are not written twice
            if self.writer is None:   # full again: the rest stays in the new suspension's backlog
                assert self.suspended is not None
                self.suspended.keep(kept, self.backlog_samples)
            else:
                self._write(kept)

    @staticmethod
    def _overflow_gap(suspended: _Suspended, in_part: int | None) -> GapInterval | None:
        """The samples lost to an overflowing backlog: from the last sample the part holds
        (`in_part`, from its recovery; else the last known written) to the first sample kept
        after it. None when nothing was dropped beyond what the part holds."""
        dropped = suspended.dropped_after_t_ns
        if dropped is None or (in_part is not None and dropped <= in_part):
            return None
        first_kept = next((t for b in suspended.backlog for t in b.t_ns if in_part is None or t > in_part), None)
        if first_kept is None:
            return None
        start = in_part if in_part is not None else (suspended.last_written_t_ns or suspended.metadata.first_t_ns)
        return GapInterval(start_t_ns=start, end_t_ns=first_kept, reason="disk_full")

    def _recover(self, part: Path) -> int | None:
        """Recover the cut part into a finished file; returns its last sample's time (ns), None
        when it holds none or could not be recovered."""
        if not part.exists():
            return None
        done = recover_one(part)
        if done.finished is not None and self.on_recovered is not None:
            self.on_recovered(done.finished.model_copy(update={
                "reason": f"recording stopped on a full disk; {done.finished.reason or ''}"[:500]}))
        return done.last_t_ns if done.outcome == "recovered" else None

    def _finish_piece(self, writer: RunWriter, metadata: RunMetadata, finished: RunFinished) -> RunFinished:
        piece_id = writer.run_id
        counters = metadata.counters.model_copy(
            update={"gap_intervals": [*metadata.counters.gap_intervals, *self._gaps]})
        piece_meta = metadata.model_copy(update={"run_id": piece_id, "counters": counters})
        first, last = writer.first_t_ns, writer.last_t_ns
        piece = finished.model_copy(update={
            "run_id": piece_id, "file": run_file.run_file_name(piece_id), "n_samples": writer.n_samples,
            "duration_s": ((last - first) / 1e9) if first is not None and last is not None else 0.0,
            "counters": counters,
            "reason": (f"continues run {metadata.run_id} after a full disk (gap marked)"
                       + (f"; {finished.reason}" if finished.reason else ""))[:500]})
        writer.finish(piece_meta, piece)
        return piece


def _after(batches: deque[SampleBatch], t_ns: int | None) -> list[SampleBatch]:
    """The batches' samples later than `t_ns` (all of them when None), as batches."""
    if t_ns is None:
        return list(batches)
    out = []
    for batch in batches:
        if not batch.t_ns or batch.t_ns[-1] <= t_ns:
            continue
        k = next(i for i, t in enumerate(batch.t_ns) if t > t_ns)
        out.append(batch if k == 0 else _tail(batch, k))
    return out


def _tail(batch: SampleBatch, k: int) -> SampleBatch:
    """`batch` from its sample k on."""
    update = {"t_ns": batch.t_ns[k:], "pos1_m": batch.pos1_m[k:]}
    for name in ("pos2_m", "raw1", "raw2"):
        values = getattr(batch, name, None)
        if values is not None:
            update[name] = values[k:]
    return batch.model_copy(update=update)


def _unrecorded(suspended: _Suspended) -> str:
    """What the run loses when it ends while the disk is full: the samples kept in memory and
    any dropped before them, from after the part's last flush."""
    kept = [t for b in suspended.backlog for t in b.t_ns]
    since = suspended.last_written_t_ns
    span = (f"from {since / 1e9:.3f} s" if since is not None else "") + (f" to {kept[-1] / 1e9:.3f} s" if kept else "")
    dropped = "" if suspended.dropped_after_t_ns is None else " (and earlier ones dropped from a full backlog)"
    return f"samples {span.strip()} (device clock) not recorded: {len(kept)} kept in memory{dropped}"


__all__ = ["BACKLOG_SAMPLES", "FULL_ERRNOS", "Recording", "is_disk_full"]
