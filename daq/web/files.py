"""Run files the page links to, resolved inside the runs directory and nowhere else.

| URL name | file |
|---|---|
| `mcap` of run `R` | `<runs-dir>/R.mcap` |
| fit file `F` of run `R` | `<runs-dir>/R.fit/F` (`report.json`, figures) |

Every name is checked with `schemas.keys.check_name` (one chunk of `[A-Za-z0-9_.-]`, never
`.`/`..`), and the resolved path (symlinks followed) must still lie inside the runs
directory and be a regular file: nothing outside it can be read.
"""

from __future__ import annotations

from pathlib import Path

from schemas import keys
from schemas.run_file import FIT_SUFFIX as FIT_DIR_SUFFIX
from schemas.run_file import run_file_name

#: File kinds listed as a run's figures and documents.
LISTED_SUFFIXES = (".png", ".svg", ".pdf", ".json", ".html", ".md", ".csv")


class RunFileError(FileNotFoundError):
    """A run file that is not there or may not be served; the message says which."""


def _inside(runs_dir: Path, path: Path) -> Path:
    root = runs_dir.resolve()
    resolved = path.resolve()
    if not resolved.is_relative_to(root):
        raise RunFileError(f"run file: expected a path inside the runs directory, got {path.name!r}")
    if not resolved.is_file():
        raise RunFileError(f"run file: expected an existing file, got no file {path.name!r}")
    return resolved


def mcap_path(runs_dir: Path, run_id: str) -> Path:
    """The finished MCAP file of `run_id` (raises `RunFileError` or `SchemaError`)."""
    name = run_file_name(keys.check_name("run_id", run_id))
    return _inside(runs_dir, runs_dir / name)


def fit_dir(runs_dir: Path, run_id: str) -> Path:
    return runs_dir / (keys.check_name("run_id", run_id) + FIT_DIR_SUFFIX)


def fit_file_path(runs_dir: Path, run_id: str, name: str) -> Path:
    """A file of `run_id`'s fit folder (raises `RunFileError` or `SchemaError`)."""
    return _inside(runs_dir, fit_dir(runs_dir, run_id) / keys.check_name("file", name))


def list_fit_files(runs_dir: Path, run_id: str) -> list[str]:
    """Names of the servable files in `run_id`'s fit folder, sorted; [] when absent."""
    folder = fit_dir(runs_dir, run_id)
    if not folder.is_dir():
        return []
    names = []
    for entry in sorted(folder.iterdir()):
        if entry.suffix.lower() in LISTED_SUFFIXES and entry.is_file():
            try:
                fit_file_path(runs_dir, run_id, entry.name)
            except (RunFileError, ValueError):
                continue
            names.append(entry.name)
    return names
