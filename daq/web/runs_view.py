"""Rows of the page's run list, built from a `RunFinished` and a `FitReport`.

A row carries what the table shows (status, release time, identified `wn`, `zeta`, fit %,
diagnosed cause and gain, or why the fit failed) and the names of the files it links to;
the server turns names into URLs under its runs directory. Pure: no I/O.
"""

from __future__ import annotations

from pathlib import PurePosixPath
from typing import Any

from schemas import keys
from schemas.daq import RunFinished
from schemas.diagnosis import DiagnosisReport
from schemas.errors import SchemaError
from schemas.fit import FitReport


def diagnosis_summary(diagnosis: DiagnosisReport | None) -> dict[str, Any] | None:
    """The diagnosis' headline cause and its gain in fit-% points, every accepted effect with
    its gain and whether it is material, and the baseline and extended fit %.

    The headline is the report's `cause` (its largest material effect); `none` (nothing
    material: e.g. a clean run whose only effect is a real but immaterial quantization) is
    shown as no cause (None), never as the immaterial effect. The gain is the headline
    effect's own gain when the report lists its effects, else the report's total gain.
    """
    if diagnosis is None:
        return None
    cause = None if diagnosis.cause == "none" else diagnosis.cause
    own = [e.gain_points for e in diagnosis.effects if e.effect == cause]
    return {
        "cause": cause,
        "gain_points": None if cause is None else (own[0] if own else diagnosis.gain_points),
        "effects": [{"effect": e.effect, "gain_points": e.gain_points, "material": e.material}
                    for e in diagnosis.effects],
        "baseline_fit_percent": diagnosis.baseline.fit_percent,
        "extended_fit_percent": diagnosis.extended.fit_percent,
        "explanation": diagnosis.explanation,
    }


def safe_file_name(name: str) -> str | None:
    """The last path component of `name` if it is a safe file name, else None."""
    base = PurePosixPath(str(name).replace("\\", "/")).name
    try:
        return keys.check_name("file", base)
    except SchemaError:
        return None


def tf_view(tf: Any) -> dict[str, Any]:
    """A transfer function `G(s) = num(s) / den(s)` (highest power first) for the run view."""
    return {"output": tf.output, "num": list(tf.num), "den": list(tf.den)}


def fit_summary(report: FitReport) -> dict[str, Any]:
    """What the run list and the run view show of a fit report (JSON-ready)."""
    simple = [{"method": s.method, "output": s.output, "wn_rad_s": s.wn_rad_s, "zeta": s.zeta,
               "fit_percent": s.fit_percent, "tf": tf_view(s.tf)} for s in report.simple]
    pem = None
    if report.pem is not None:
        pem = {"order": report.pem.order, "outputs": report.pem.outputs,
               "wn_rad_s": [m.wn_rad_s for m in report.pem.modes],
               "zeta": [m.zeta for m in report.pem.modes],
               "fit_percent": report.pem.fit_percent,
               "tfs": [tf_view(tf) for tf in report.pem.tfs]}
    figures = [n for n in (safe_file_name(f) for f in report.figures) if n is not None]
    return {
        "status": report.status,
        "reason": report.reason,
        "worker": report.worker,
        "case": report.case,
        "release_time_s": report.release_time_s,
        "simple": simple,
        "pem": pem,
        "diagnosis": diagnosis_summary(report.diagnosis),
        "figures": figures,
    }


def run_row(bench: str, run_id: str, finished: RunFinished | None,
            fit: dict[str, Any] | None) -> dict[str, Any]:
    """One row of the run list (JSON-ready)."""
    release = None if finished is None else finished.release_time_s
    if release is None and fit is not None:
        release = fit["release_time_s"]
    status = None if finished is None else finished.status
    return {
        "bench": bench,
        "run_id": run_id,
        "status": status,
        # an aborted run (daq stopped mid-run, lost port) is shown as such, never as a fit
        "fit_shown": status != "aborted",
        "reason": None if finished is None else finished.reason,
        "release_time_s": release,
        "duration_s": None if finished is None else finished.duration_s,
        "n_samples": None if finished is None else finished.n_samples,
        "file": None if finished is None else safe_file_name(finished.file),
        "fit": fit,
    }
