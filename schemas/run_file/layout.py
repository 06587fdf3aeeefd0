"""The layout of a runs directory: every file and folder name is built here and nowhere else.

| file | what |
|---|---|
| `<run_id>.mcap.part` | a run being written (or left by a crash) |
| `<run_id>.mcap` | a finished run: never overwritten, never deleted |
| `<run_id>-r<k>.mcap` | data recovered from a `.part` whose finished name was taken |
| `<run_id>.fit/report.json` | the fit report (and figures) beside the run file |
| `quarantine/<name>` | a `.part` nothing could be read from, moved aside (never deleted) |

Names only: no file is opened here.
"""

from __future__ import annotations

from pathlib import Path
from typing import Final

from schemas import topics
from schemas.errors import SchemaError

RUN_SUFFIX: Final = topics.RUN_SUFFIX
PART_SUFFIX: Final = topics.PART_SUFFIX
#: Folder of a run's fit report and figures, beside its MCAP file (written by `ident`).
FIT_SUFFIX: Final = ".fit"
#: The fit report's file name inside that folder.
REPORT_NAME: Final = "report.json"
#: Sub-folder of a runs directory for `.part` files nothing could be read from.
QUARANTINE_DIR: Final = "quarantine"
#: Suffix of a recovery being written (renamed to a free `.mcap` name when sealed).
RECOVERING_SUFFIX: Final = ".mcap.recovering"


def run_file_name(run_id: str) -> str:
    return f"{run_id}{RUN_SUFFIX}"


def final_path(runs_dir: Path, run_id: str) -> Path:
    return Path(runs_dir) / run_file_name(run_id)


def part_path(runs_dir: Path, run_id: str) -> Path:
    return Path(runs_dir) / f"{run_id}{PART_SUFFIX}"


def fit_dir_of(run_file: Path) -> Path:
    """`<dir>/<run_id>.fit` beside `<dir>/<run_id>.mcap`."""
    return run_file.with_name(run_id_of(run_file) + FIT_SUFFIX)


def run_id_of(path: Path) -> str:
    """The run id a run file or part is named after (`R.mcap`, `R.mcap.part` → `R`)."""
    name = Path(path).name
    for suffix in (PART_SUFFIX, RECOVERING_SUFFIX, RUN_SUFFIX):
        if name.endswith(suffix):
            return name[: -len(suffix)]
    raise SchemaError("run file name", f"<run_id>{RUN_SUFFIX} or <run_id>{PART_SUFFIX}", repr(name))


def recovered_run_id(runs_dir: Path, run_id: str) -> str:
    """A run id whose `.mcap` does not exist yet: `run_id` itself, else `run_id-r1`, `-r2`, …"""
    candidate, k = run_id, 0
    while final_path(runs_dir, candidate).exists() or final_path(runs_dir, candidate).is_symlink():
        k += 1
        candidate = f"{run_id}-r{k}"
    return candidate


def quarantine_path(runs_dir: Path, name: str) -> Path:
    """A free path under `<runs_dir>/quarantine/` for the file called `name`."""
    folder = Path(runs_dir) / QUARANTINE_DIR
    candidate, k = folder / name, 0
    while candidate.exists() or candidate.is_symlink():
        k += 1
        candidate = folder / f"{name}.{k}"
    return candidate


__all__ = ["FIT_SUFFIX", "PART_SUFFIX", "QUARANTINE_DIR", "RECOVERING_SUFFIX", "REPORT_NAME", "RUN_SUFFIX",
           "final_path", "fit_dir_of", "part_path", "quarantine_path", "recovered_run_id", "run_file_name",
           "run_id_of"]
