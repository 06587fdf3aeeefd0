"""`RunAnalysis` -> `schemas.fit.FitReport` (the record the worker publishes and writes)."""

from __future__ import annotations

from datetime import UTC, datetime

import numpy as np

from ident.fitrun.analysis import RunAnalysis
from schemas.fit import (
    FitReport,
    FitTimings,
    ModeRec,
    PemFitRec,
    SimpleFitRec,
    TransferFunctionRec,
)


def tf_text(num: list[float], den: list[float]) -> str:
    """`G(s)` as one line, e.g. `(126.4) / (s^2 + 1.02 s + 126.4)`."""
    return f"({poly_text(num)}) / ({poly_text(den)})"


def poly_text(coefficients: list[float], digits: int = 4) -> str:
    """A polynomial in `s`, highest power first, with `digits` significant digits."""
    order = len(coefficients) - 1
    terms: list[str] = []
    for i, c in enumerate(coefficients):
        power = order - i
        if c == 0.0:
            continue
        magnitude = abs(c)
        value = "" if power > 0 and np.isclose(magnitude, 1.0, rtol=1e-9) else f"{magnitude:.{digits}g}"
        var = "" if power == 0 else ("s" if power == 1 else f"s^{power}")
        body = " ".join(p for p in (value, var) if p)
        if terms:
            terms.append(f"{'-' if c < 0 else '+'} {body}")
        else:
            terms.append(f"{'-' if c < 0 else ''}{body}")
    return " ".join(terms) or "0"


def finite_or_none(value: float | None) -> float | None:
    """`value`, or None when unknown (records refuse NaN and infinities)."""
    return None if value is None or not np.isfinite(value) else float(value)


def _tf_rec(output: int, num: list[float], den: list[float]) -> TransferFunctionRec:
    num_f = [float(x) for x in num]
    den_f = [float(x) for x in den]
    return TransferFunctionRec(output=output, num=num_f, den=den_f, text=tf_text(num_f, den_f))


def simple_records(analysis: RunAnalysis) -> list[SimpleFitRec]:
    records = []
    for r in analysis.simple:
        num, den = r.tf_coefficients
        records.append(SimpleFitRec(method=r.method, output=r.output, tf=_tf_rec(r.output, num, den),
                                    wn_rad_s=r.wn_rad_s, zeta=r.zeta, gain=r.gain,
                                    fit_percent=r.fit_percent,
                                    coulomb_accel_m_s2=finite_or_none(r.coulomb_accel_m_s2),
                                    wn_std=finite_or_none(r.wn_std),
                                    zeta_std=finite_or_none(r.zeta_std),
                                    release_time_s=finite_or_none(r.release_time_s),
                                    converged=r.converged))
    return records


def pem_record(analysis: RunAnalysis) -> PemFitRec | None:
    model = analysis.pem
    if model is None:
        return None
    tfs = [_tf_rec(cart, list(num), list(den))
           for cart, (num, den) in zip(analysis.outputs, model.tf_coefficients())]
    modes = [ModeRec(wn_rad_s=float(m.wn), zeta=float(m.zeta), wn_std=finite_or_none(m.wn_std),
                     zeta_std=finite_or_none(m.zeta_std)) for m in model.modes]
    release = model.release_time_s
    return PemFitRec(order=model.order, tfs=tfs, modes=modes,
                     fit_percent=[float(f) for f in model.fit_percent],
                     outputs=list(analysis.outputs),
                     dc_gain=[float(g) for g in np.atleast_1d(model.dc_gain)],
                     release_time_s=None if release is None else finite_or_none(release),
                     noise_model="innovation" if "innovation" in model.method else "oe",
                     converged=bool(model.success), stable=model.stable,
                     message="" if model.stable else model.message)


def to_fit_report(analysis: RunAnalysis, *, bench: str, run_id: str, worker: str,
                  figures: list[str], timings: FitTimings, software_version: str) -> FitReport:
    reason = analysis.failed_reason
    t = analysis.data.t
    return FitReport(
        bench=bench, run_id=run_id, worker=worker, status="failed" if reason else "ok",
        reason=reason, case=analysis.case, release_time_s=analysis.release_time_s,
        sample_rate_hz=float(1.0 / analysis.data.sample_time()),
        duration_s=float(t[-1] - t[0]), simple=simple_records(analysis),
        pem=pem_record(analysis), diagnosis=analysis.diagnosis,
        envelope=analysis.envelope, figures=figures,
        timings=timings, fitted_utc=datetime.now(UTC).isoformat(timespec="seconds"),
        software_version=software_version, notes=list(analysis.data.notes),
        extra={"stage_errors": dict(analysis.errors)} if analysis.errors else {})


__all__ = ["finite_or_none", "pem_record", "poly_text", "simple_records", "tf_text", "to_fit_report"]
