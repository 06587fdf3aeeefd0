"""`ident.diagnose` drops, before fitting, an output that never moves (issue 14).

A pinned or unplugged cart's column reads one value (or one value but a glitch, or NaN): it
has no fit % (a zero denominator gave -inf) and must not be fitted as a cart. The record
here is a clean one-cart ring (the closed-form step response of m x'' + c x' + k x = k r)
beside such a column; the diagnosis must be the one of the moving column alone.
"""

from __future__ import annotations

import numpy as np
import pytest

from ident.diagnose import diagnose
from ident.errors import IdentValueError

RATE_HZ = 200.0


def ring(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """t (N,) and a released cart's position (N,): rest at 0, step of 0.15 m at 1 s."""
    rng = np.random.default_rng(seed)
    wn, zeta = rng.uniform(9.0, 14.0), rng.uniform(0.02, 0.08)
    t = np.arange(0.0, 8.0, 1.0 / RATE_HZ, dtype=np.float64)
    tau = np.clip(t - 1.0, 0.0, None)
    wd = wn * np.sqrt(1.0 - zeta**2)
    x = 0.15 * (1.0 - np.exp(-zeta * wn * tau) * (np.cos(wd * tau) + zeta * wn / wd * np.sin(wd * tau)))
    return t, x + rng.normal(0.0, 2e-5, t.size)


def still_columns(n: int) -> dict[str, np.ndarray]:
    glitch = np.full(n, 0.003)
    glitch[n // 3] = 0.01
    return {"constant": np.zeros(n), "one glitch": glitch, "NaN": np.full(n, np.nan)}


@pytest.fixture(scope="module")
def alone() -> tuple[np.ndarray, np.ndarray, float]:
    t, x = ring(4)
    return t, x, diagnose(t, x).report.baseline.fit_percent


@pytest.mark.parametrize("kind", ["constant", "one glitch", "NaN"])
@pytest.mark.parametrize("still_first", [False, True])
def test_an_output_that_never_moves_is_dropped_before_fitting(alone: tuple[np.ndarray, np.ndarray, float],
                                                                kind: str, still_first: bool) -> None:
    t, x, fit_alone = alone
    still = still_columns(t.size)[kind]
    y = np.column_stack([still, x] if still_first else [x, still])
    result = diagnose(t, y)
    report = result.report
    assert report.carts == 1 and result.y.shape == (result.t.size, 1)
    assert len(report.baseline.fit_percent_per_output) == 1
    assert report.baseline.fit_percent == pytest.approx(fit_alone, abs=1e-9)   # as if it were not there
    still_number = 1 if still_first else 2
    expected = "has no finite readings" if kind == "NaN" else "never moves"
    assert f"output {still_number} {expected}" in report.validation


@pytest.mark.parametrize("kind", ["constant", "one glitch", "NaN"])
def test_a_record_with_no_output_that_moves_is_refused_naming_what_it_found(kind: str) -> None:
    t, _ = ring(5)
    columns = still_columns(t.size)
    with pytest.raises(IdentValueError, match=r"expected motion in at least one output.*output 1 "):
        diagnose(t, np.column_stack([columns[kind], columns["constant"]]))


def test_two_carts_asked_of_a_record_whose_second_cart_never_moves_are_refused() -> None:
    t, x = ring(6)
    with pytest.raises(IdentValueError, match=r"carts.*expected 2 outputs that move.*output 2 never moves"):
        diagnose(t, np.column_stack([x, np.zeros(t.size)]), carts=2)
