"""Run ids: `r<UTC date>-<UTC time>-<nnn>`, unique in the runs directory, sorting in start order,
safe as a key chunk and a file stem."""

from __future__ import annotations

from collections.abc import Callable
from datetime import datetime

from daq.errors import DaqError
from schemas import keys

MAX_SUFFIX = 1000


def new_run_id(bench: str, now: datetime, taken: Callable[[str], bool]) -> str:
    """The first free id for a run starting at `now` (`taken(run_id)` says whether it exists)."""
    stem = f"r{now:%Y%m%d-%H%M%S}"
    for n in range(MAX_SUFFIX):
        candidate = f"{stem}-{n:03d}"
        if not taken(candidate):
            return keys.check_name("run_id", candidate)
    raise DaqError(f"no free run id for {bench} at {stem}: expected fewer than {MAX_SUFFIX} runs per second")
