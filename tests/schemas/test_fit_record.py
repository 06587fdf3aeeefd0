"""`schemas.fit.FitReport`: what a claim, an early result and a complete result are."""

from __future__ import annotations

import pytest

from schemas import SchemaError
from schemas.fit import FitReport, ModeRec, PemFitRec, TransferFunctionRec


def _report(**fields: object) -> FitReport:
    return FitReport(**{"bench": "b1", "run_id": "r1", "worker": "w1", "status": "ok", **fields})  # type: ignore[arg-type]


def test_complete_report_round_trips_through_json() -> None:
    pem = PemFitRec(order=2, tfs=[TransferFunctionRec(output=1, num=[123.4], den=[1.0, 1.03, 123.4],
                                                      text="(123.4) / (s^2 + 1.03 s + 123.4)")],
                    modes=[ModeRec(wn_rad_s=11.1, zeta=0.046)], fit_percent=[93.1], outputs=[1])
    report = _report(case="cart1", release_time_s=0.503, pem=pem, figures=["pem.png", "pem.svg"])
    again = FitReport.from_json_bytes(report.to_json_bytes())
    assert again == report and again.final and again.has_results


@pytest.mark.parametrize(("fields", "final", "has_results"), [
    ({"status": "fitting"}, False, False),
    ({"status": "withdrawn"}, False, False),
    ({"status": "ok", "pending": ["diagnosis", "figures"]}, False, True),
    ({"status": "ok"}, True, True),
    ({"status": "failed", "reason": "no motion"}, True, True),
])
def test_claims_early_and_complete_results_are_told_apart(fields: dict[str, object], final: bool,
                                                          has_results: bool) -> None:
    report = _report(**fields)
    assert (report.final, report.has_results) == (final, has_results)


def test_failed_needs_a_reason_and_only_ok_may_be_pending() -> None:
    with pytest.raises(ValueError, match="expected a reason"):
        _report(status="failed")
    with pytest.raises(ValueError, match="expected pending stages only on an ok report"):
        _report(status="fitting", pending=["diagnosis"])


@pytest.mark.parametrize(("field", "bad"), [("bench", ".."), ("run_id", "a/b"), ("worker", "*"),
                                            ("run_id", "../../etc")])
def test_names_that_become_keys_and_paths_are_checked(field: str, bad: str) -> None:
    with pytest.raises(ValueError, match="expected 1-128 characters"):
        _report(**{field: bad})


def test_a_payload_with_an_unsafe_bench_is_refused() -> None:
    payload = _report().to_json_bytes().replace(b'"b1"', b'"../up"')
    with pytest.raises(SchemaError, match="bench"):
        FitReport.from_json_bytes(payload)


def test_transfer_function_needs_coefficients() -> None:
    with pytest.raises(ValueError, match="expected non-empty num and den"):
        TransferFunctionRec(output=1, num=[], den=[1.0])
