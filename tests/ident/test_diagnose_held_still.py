"""Issue 14 row 1: a cart held exactly still (a clean one-cart `sim://` run recorded on two
channels) has no fit %; the diagnosis drops it before fitting, and its record validates and
round-trips."""

from __future__ import annotations

import numpy as np
import pytest

from ident.diagnose.run import diagnose
from ident.errors import IdentValueError
from schemas.diagnosis import DiagnosisReport


def test_a_cart_that_never_moves_gives_a_valid_record_not_a_crash() -> None:
    rng = np.random.default_rng(14)
    t = np.arange(0.0, 8.0, 0.005)
    wn, zeta, release = 11.1, 0.03, 0.5
    after = np.clip(t - release, 0.0, None)
    x1 = np.where(t < release, 0.0, 0.15 * (1 - np.exp(-zeta * wn * after) * np.cos(wn * np.sqrt(1 - zeta**2) * after)))
    y = np.column_stack([x1 + rng.normal(0.0, 2e-5, t.size), np.zeros(t.size)])   # cart 2: exactly 0
    # the still column is dropped before fitting (ident.diagnose.still): a one-cart record
    result = diagnose(t, y, step_m=0.15)
    report = result.report
    again = DiagnosisReport.from_json_bytes(report.to_json_bytes())
    assert again == report
    assert report.carts == 1 and "output 2 never moves" in report.validation
    assert np.isfinite(report.baseline.fit_percent) and report.baseline.fit_percent > 90.0
    assert report.baseline.fit_percent_per_output == [report.baseline.fit_percent]
    assert all(np.isfinite(c.fit_percent) for c in report.candidates)
    # two carts asked of it: refused, saying why, not a chain fitted through a pinned cart
    with pytest.raises(IdentValueError, match="output 2 never moves"):
        diagnose(t, y, carts=2, step_m=0.15)
