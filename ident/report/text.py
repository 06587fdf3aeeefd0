"""A `FitReport` as plain text, for the terminal (`ident fit`). Renders only."""

from __future__ import annotations

from ident.fitrun.records import tf_text
from schemas.fit import FitReport, PemFitRec, SimpleFitRec


def _pm(value: float, std: float | None, fmt: str) -> str:
    return f"{value:{fmt}}" + ("" if std is None else f" ± {std:.2g}")


def _mode_line(i: int, wn: float, zeta: float, wn_std: float | None, zeta_std: float | None) -> str:
    return (f"  mode {i}: wn = {_pm(wn, wn_std, '.4f')} rad/s, "
            f"zeta = {_pm(zeta, zeta_std, '.5f')}")


def _head(label: str, release: float | None, converged: bool) -> str:
    return (f"[{label}] " + ("input as recorded" if release is None else f"release time {release:.4f} s")
            + ("" if converged else "  (NOT CONVERGED)"))


def _simple_lines(fit: SimpleFitRec) -> list[str]:
    return [_head(f"simple {fit.method}", fit.release_time_s, fit.converged),
            _mode_line(1, fit.wn_rad_s, fit.zeta, fit.wn_std, fit.zeta_std),
            f"  x{fit.output}: G(s) = {tf_text(fit.tf.num, fit.tf.den)}",
            f"      fit {fit.fit_percent:.2f} %, DC gain {fit.gain:.4g}"
            + ("" if fit.coulomb_accel_m_s2 is None else f", dry friction {fit.coulomb_accel_m_s2:.4g} m/s²")]


def _pem_lines(pem: PemFitRec) -> list[str]:
    label = f"pem order {pem.order}" + (" (innovation form)" if pem.noise_model == "innovation" else "")
    lines = [_head(label, pem.release_time_s, pem.converged)]
    if not pem.stable:
        lines.append(f"  WARNING: {pem.message or 'unstable estimate (zeta <= 0): not a model of the carts'}")
    lines += [_mode_line(i, m.wn_rad_s, m.zeta, m.wn_std, m.zeta_std)
              for i, m in enumerate(pem.modes, 1)]
    gains = pem.dc_gain or [float("nan")] * len(pem.tfs)
    for tf, fit, gain in zip(pem.tfs, pem.fit_percent, gains, strict=True):
        lines.append(f"  x{tf.output}: G(s) = {tf_text(tf.num, tf.den)}")
        lines.append(f"      fit {fit:.2f} %, DC gain {gain:.4g}")
    return lines


def format_fit_report(report: FitReport, source: str = "") -> str:
    """The report's transfer functions, modes, fit % and notes, one method per block."""
    head = f"{source or report.run_id}: "
    if report.status == "failed":
        return head + f"failed: {report.reason}"
    rate = "" if report.sample_rate_hz is None else f"{report.sample_rate_hz:.4g} Hz, "
    span = "" if report.duration_s is None else f"{report.duration_s:.2f} s, "
    lines = [head + f"{rate}{span}case {report.case}"]
    lines += [f"  note: {note}" for note in report.notes]
    lines += [f"  {stage} failed: {msg}" for stage, msg in report.extra.get("stage_errors", {}).items()]
    for fit in report.simple:
        lines += _simple_lines(fit)
    if report.pem is not None:
        lines += _pem_lines(report.pem)
    if report.diagnosis is not None:
        diagnosis = report.diagnosis
        lines.append(f"[diagnosis] cause {diagnosis.cause}, "
                     f"{diagnosis.gain_points:+.2f} fit-% points held out")
    return "\n".join(lines)


__all__ = ["format_fit_report"]
