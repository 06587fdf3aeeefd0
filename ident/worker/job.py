"""What a fitter gets and gives: `FitJob` in, `FitOutcome` out (`Fitter` is the callable).

A fitter is a plain module-level function (`ident.worker.pipeline.fit_run` by default), so
it pickles by reference into the worker's fit process (`ident.worker.fitproc`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from ident.worker.fitproc import FitOutcome
from schemas.daq import RunFinished


@dataclass(frozen=True)
class FitJob:
    """One run to fit: its finished record, the local MCAP, and where figures go."""

    finished: RunFinished
    run_file: Path
    fit_dir: Path
    worker: str


#: A fitter returns the complete report, or `Pending` (first results + the slow rest).
Fitter = Callable[[FitJob], FitOutcome]

__all__ = ["FitJob", "Fitter"]
