"""The diagnosis' sentence names what was fitted (`ident.diagnose.explain`)."""

from __future__ import annotations

import numpy as np

from ident.diagnose import diagnose
from ident.diagnose.explain import explanation
from testkit.effects import make_case


def test_a_second_mode_is_named_at_its_fitted_frequency() -> None:
    """A mode that decays within a period leaves no peak in the residual's spectrum; the
    sentence had then quoted the spectrum's peak, a slow drift's (red team `none` seed 702: "near
    0.0854 Hz" for a fitted 5.71 Hz mode)."""
    case = make_case(20261128, "coupled_mode", carts=1)
    out = diagnose(case.observed.t, case.observed.y, carts=1)
    mode = next(e for e in out.report.effects if e.effect == "coupled_mode").parameters["mode_hz"]
    blind = out.report.model_copy(update={"evidence": out.report.evidence.model_copy(
        update={"second_frequency_hz": None, "residual_peak_hz": 0.0854})})
    lin = np.array([out.report.corrected_linear["wn_rad_s"], out.report.corrected_linear["zeta"]])
    text = explanation(blind, lin)   # (wn, ζ): the linear block of the baseline's parameters
    assert f"near {mode:.3g} Hz" in text, text
