"""The reflection is written from the numbers: different results, different sentences."""

from __future__ import annotations

from ident.report.reflection import reflection
from schemas.fit import FitReport, ModeRec, PemFitRec, SimpleFitRec, TransferFunctionRec


def _tf(output: int, num: list[float], den: list[float]) -> TransferFunctionRec:
    return TransferFunctionRec(output=output, num=num, den=den)


def _single(case: str, wn: float, zeta: float, euler_zeta: float) -> FitReport:
    cart = 1 if case == "cart1" else 2
    simple = [SimpleFitRec(method=m, output=cart, tf=_tf(cart, [wn * wn], [1, 2 * z * wn, wn * wn]),
                           wn_rad_s=wn, zeta=z, gain=1.0, fit_percent=97.0)
              for m, z in (("rk4", zeta), ("euler", euler_zeta))]
    pem = PemFitRec(order=2, tfs=[_tf(cart, [wn * wn], [1, 2 * zeta * wn, wn * wn])],
                    modes=[ModeRec(wn_rad_s=wn, zeta=zeta)], fit_percent=[98.0], outputs=[cart])
    return FitReport(bench="b", run_id=f"r-{case}", worker="w", status="ok", case=case,  # type: ignore[arg-type]
                     sample_rate_hz=200.0, simple=simple, pem=pem)


def _both(w1: float, w2: float, dc2: float) -> FitReport:
    den = [1.0, 2.0, 250.0, 280.0, 12000.0]
    pem = PemFitRec(order=4, tfs=[_tf(1, [125.0, 150.0, 12000.0], den),
                                  _tf(2, [-64.0, -50.0, dc2 * 12000.0], den)],
                    modes=[ModeRec(wn_rad_s=w1, zeta=0.05), ModeRec(wn_rad_s=w2, zeta=0.04)],
                    fit_percent=[95.0, 92.0], outputs=[1, 2])
    return FitReport(bench="b", run_id="r-both", worker="w", status="ok", case="both", pem=pem)


def test_euler_bias_and_interlacing_are_stated_from_the_numbers() -> None:
    text = " ".join(reflection([_single("cart1", 11.1, 0.046, 0.071), _single("cart2", 11.25, 0.05, 0.05),
                                _both(8.3, 13.5, 0.0)]))
    assert "Explicit Euler returns ζ = 0.0710, +54.3 % against RK4" in text
    assert "Euler and RK4 agree on ζ within 0.0 %" in text
    assert "8.300 and 13.500 rad/s" in text and "lie between them" in text
    assert "DC gain is +0.000" in text


def test_frequencies_outside_the_modes_are_called_out() -> None:
    text = " ".join(reflection([_single("cart1", 14.0, 0.046, 0.046), _both(8.3, 13.5, 0.02)]))
    assert "do not all lie between them" in text
    assert "DC gain is +0.020" in text
    assert len(reflection([_single("cart1", 14.0, 0.046, 0.046), _both(8.3, 13.5, 0.02)])) == 2


def test_nothing_fitted_says_why() -> None:
    failed = FitReport(bench="b", run_id="r", worker="w", status="failed", reason="too short")
    (only,) = reflection([failed])
    assert "too short" in only and "None of the 1 run(s)" in only


def test_notes_name_failed_stages_and_runs_left_out() -> None:
    from ident.report.content import CaseResult, notes_blocks
    from ident.report.document import Para

    used = _single("cart1", 11.1, 0.046, 0.071).model_copy(
        update={"extra": {"stage_errors": {"simple": "number of samples: expected at least 20"}}})
    failed = FitReport(bench="b", run_id="r-bad", worker="w", status="failed", reason="no motion")
    (para,) = notes_blocks([CaseResult("cart1", used, {})], [failed])
    assert isinstance(para, Para)
    assert "the simple stage failed: number of samples" in para.text
    assert "`r-bad`: could not be fitted: no motion" in para.text
    assert notes_blocks([CaseResult("cart1", _single("cart1", 11.1, 0.046, 0.07), {})], []) == []
