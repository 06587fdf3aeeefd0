"""The worker's files: where a run's MCAP is, where its `<run_id>.fit/` goes, atomic writes.

Layout under a runs directory (what `daq run --runs-dir D` writes, one or several benches):

    D/<run_id>.mcap            a run of any bench, or
    D/<bench>/<run_id>.mcap    when benches share a directory tree
    D/<run_id>.fit/            report.json and figures, beside the run file
    D/<bench>/<run_id>.fit/    for runs fetched over Zenoh (not on this machine)

This module reads only the `RunFinished` metadata record of a run file (through
`schemas.run_file`, which owns the layout and the reader); loading samples is `ident.io`'s job.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

from schemas import run_file, topics
from schemas.daq import RunFinished
from schemas.fit import FitReport
from schemas.run_file import FIT_SUFFIX, REPORT_NAME


def find_run_file(runs_dir: Path | None, bench: str, file_name: str) -> Path | None:
    """The local run file of `bench` named `file_name` (from `RunFinished.file`), or None.

    A file whose own finished record names another bench is not this run; a file without
    one (damaged, or still being recovered) is taken, and its fit will say what is wrong.
    """
    if runs_dir is None:
        return None
    name = Path(file_name).name
    for candidate in (runs_dir / name, runs_dir / bench / name):
        if candidate.is_file():
            finished = read_finished(candidate)
            # Benches may share a directory and run ids are per bench: check the owner.
            if finished is None or finished.bench == bench:
                return candidate
    return None


def fit_dir_for(runs_dir: Path, bench: str, run_id: str, run_file: Path | None) -> Path:
    """Where the fit of a run goes: beside a local run file, else under `<runs_dir>/<bench>/`."""
    parent = run_file.parent if run_file is not None else runs_dir / bench
    return parent / f"{run_id}{FIT_SUFFIX}"


def read_report(fit_dir: Path) -> FitReport | None:
    """The final report stored in `fit_dir`, or None when absent or unreadable."""
    path = fit_dir / REPORT_NAME
    try:
        report = FitReport.from_json_bytes(path.read_bytes())
    except (OSError, ValueError):
        return None
    return report if report.final else None


def write_atomic(path: Path, data: bytes) -> None:
    """Write `data` to `path` through a temporary file and a rename (never half a file)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_report(fit_dir: Path, report: FitReport) -> Path:
    path = fit_dir / REPORT_NAME
    write_atomic(path, report.model_dump_json(indent=2).encode())
    return path


def read_finished(run_file_path: Path) -> RunFinished | None:
    """The `RunFinished` metadata record of an MCAP run file, or None (none, or unreadable:
    a damaged file is reported by its fit, not here)."""
    return run_file.read_finished(run_file_path)


def scan_runs(runs_dir: Path) -> Iterator[tuple[Path, RunFinished]]:
    """Every finished run file under `runs_dir` (one level of bench folders), oldest first."""
    if not runs_dir.is_dir():
        return
    files = [*runs_dir.glob(f"*{topics.RUN_SUFFIX}"), *runs_dir.glob(f"*/*{topics.RUN_SUFFIX}")]
    for path in sorted(files, key=lambda p: (p.stat().st_mtime, p.name)):
        finished = read_finished(path)
        if finished is not None:
            yield path, finished


__all__ = ["FIT_SUFFIX", "REPORT_NAME", "find_run_file", "fit_dir_for", "read_finished",
           "read_report", "scan_runs", "write_atomic", "write_report"]
