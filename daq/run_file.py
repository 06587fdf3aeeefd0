"""Run files for people: a run as arrays, its summary, and its exports (CSV, JSON, MAT).

Reading goes through `schemas.run_file` (the one damage-tolerant reader with its limits): a
file killed mid-write yields every complete chunk (`complete` is then False).

Time base of exports: `time_s = (t_ns - t_ns[0]) / 1e9`, the device clock (unwrapped) in
seconds from the run's first sample; `release_time_s` is on that same base.

Every export carries the run's metadata (`export_metadata`: release time, pulled cart, lab
case, run id, bench, calibration, UTC of the first sample, the full `RunMetadata` as JSON):
the CSV as `# key: value` comment lines before its column header (pandas `comment="#"`,
MATLAB `readtable(..., "CommentStyle", "#")`, `ident.load` read it; `ident.load` also takes
the release time and pulled cart from it), the MAT file as a struct `metadata`, the JSON
export under `metadata`.
"""

from __future__ import annotations

import csv
import io
import json
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from daq.errors import DaqIOError, DaqValueError
from schemas import SchemaError, run_file


@dataclass(frozen=True)
class RunData(run_file.RunContents):
    """A run file as read by `schemas.run_file` (its fields), on daq's time base: seconds from
    the run's first sample."""

    @property
    def time_s(self) -> npt.NDArray[np.float64]:
        """Seconds from the run's first sample (shape (N,))."""
        if self.t_ns.size == 0:
            return np.zeros(0)
        return (self.t_ns - self.t_ns[0]).astype(np.float64) / 1e9

    @property
    def release_time_s(self) -> float | None:
        """The release on the `time_s` base (from the metadata's device-time release)."""
        meta = self.metadata
        if meta is None or meta.release_t_ns is None or self.t_ns.size == 0:
            return meta.release_time_s if meta is not None else None
        return (meta.release_t_ns - int(self.t_ns[0])) / 1e9

    @property
    def n_channels(self) -> int:
        return int(self.pos_m.shape[1])


def load_run(path: Path) -> RunData:
    """A run file (finished or truncated) as arrays and records."""
    try:
        read = run_file.read_run(Path(path))
    except SchemaError as exc:
        raise DaqValueError(f"run file {path}", "records of the cartlab schemas within the reader's "
                            "limits", str(exc)) from exc
    except OSError as exc:
        raise DaqIOError(f"cannot read run file {path}: {exc}") from exc
    if read.n_records == 0:
        raise DaqValueError(f"run file {path}", "an MCAP file written by daq", "no readable records")
    return RunData(**{f.name: getattr(read, f.name) for f in fields(read)})


def run_info(run: RunData, path: Path) -> dict[str, Any]:
    """A JSON-able summary: metadata, counters, sample count, time span, release time."""
    meta = run.metadata
    time_s = run.time_s
    return {
        "file": Path(path).name,
        "complete": run.complete,
        "n_samples": int(run.t_ns.size),
        "n_channels": run.n_channels,
        "duration_s": float(time_s[-1]) if time_s.size else 0.0,
        "release_time_s": run.release_time_s,
        "status": run.finished.status if run.finished else None,
        "metadata": meta.model_dump(mode="json") if meta else None,
    }


#: Scalar fields of `RunMetadata` copied into every export (the rest is in `metadata_json`).
_EXPORTED_FIELDS = ("run_id", "bench", "pulled_cart", "lab_case", "dialect", "port", "counts_per_m",
                    "n_channels", "rate_hz", "device_model", "firmware", "detector_method",
                    "pre_trigger_s", "trigger", "software_version", "started_utc", "ended_utc")


def export_metadata(run: RunData) -> dict[str, str | float | int | None]:
    """Flat metadata of an export: `release_time_s` (on `time_s`), the scalar run fields,
    `first_sample_utc` (ISO 8601, from the stream's UTC offset) and `metadata_json`."""
    meta = run.metadata
    out: dict[str, str | float | int | None] = {
        "format": "cartlab run export", "time_base": "time_s = seconds from the run's first sample "
        "(device clock)", "release_time_s": run.release_time_s, "n_samples": int(run.t_ns.size)}
    if meta is None:
        return out
    dumped = meta.model_dump(mode="json")
    out.update({name: dumped.get(name) for name in _EXPORTED_FIELDS})
    if meta.utc_offset_ns is not None and run.t_ns.size:
        from datetime import UTC, datetime

        first_ns = int(run.t_ns[0]) + meta.utc_offset_ns
        stamp = datetime.fromtimestamp(first_ns // 1_000_000_000, UTC).replace(
            microsecond=(first_ns % 1_000_000_000) // 1000)
        out["first_sample_utc"] = stamp.isoformat(timespec="microseconds")
    out["metadata_json"] = meta.model_dump_json()
    return out


def export_columns(run: RunData) -> dict[str, npt.NDArray[np.float64]]:
    """The exported columns by name: `time_s`, `pos1_m`[, `pos2_m`][, `target`, `duty`: the
    rig's drive as the device sent it, for a stream that has one]."""
    columns = {"time_s": run.time_s, "pos1_m": run.pos_m[:, 0]}
    if run.n_channels == 2:
        columns["pos2_m"] = run.pos_m[:, 1]
    if run.drive is not None:
        columns["target"], columns["duty"] = run.drive[:, 0], run.drive[:, 1]
    return columns


def export_csv(run: RunData) -> str:
    """`# key: value` metadata lines, then the `export_columns` with full float precision."""
    out = io.StringIO()
    for key, value in export_metadata(run).items():
        out.write(f"# {key}: {'' if value is None else value}\n")
    writer = csv.writer(out, lineterminator="\n")
    columns = export_columns(run)
    writer.writerow(list(columns))
    for row in zip(*(c.tolist() for c in columns.values())):
        writer.writerow([repr(x) for x in row])
    return out.getvalue()


def export_json(run: RunData, path: Path) -> str:
    body = run_info(run, path)
    body.update({name: column.tolist() for name, column in export_columns(run).items()})
    return json.dumps(body)


def export_mat(run: RunData, out_path: Path) -> None:
    """MATLAB file with the `export_columns` (each N x 1), `release_time_s` (NaN if unknown) and a
    struct `metadata` (`export_metadata`; unknown numbers NaN, unknown text empty)."""
    from scipy.io import savemat  # lazy: scipy costs seconds to import

    release = run.release_time_s
    numeric = {"release_time_s", "pulled_cart", "counts_per_m", "n_channels", "rate_hz", "pre_trigger_s",
               "n_samples"}
    struct = {key: (float("nan") if key in numeric else "") if value is None else value
              for key, value in export_metadata(run).items()}
    data: dict[str, Any] = {name: column[:, None] for name, column in export_columns(run).items()}
    data.update({"release_time_s": float("nan") if release is None else release, "metadata": struct})
    savemat(str(out_path), data)
