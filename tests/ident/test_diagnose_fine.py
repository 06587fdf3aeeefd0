"""The final model refitted on a finer grid than the selection's work grid (`ident.diagnose.fine`):
its parameters are read off every sample (or one in d), not one in D.

The runs are drawn by the independent generator `testkit.effects` (its own physics and
integrator): two carts with Coulomb friction read through cart 1's encoder alone, whose truth
for cart 2 is f2 / k2. On the work grid (one sample in 2 and 7) cart 2's friction was 3.8-6.1
and 6.0 % off; the refit reads it within 5 %."""

from __future__ import annotations

import numpy as np
import pytest

from ident.diagnose import diagnose
from ident.diagnose.drift import drift_basis
from ident.diagnose.fine import FINE_SAMPLES, fine_decimation
from testkit.effects import judge, make_case


@pytest.mark.parametrize(("n", "decimation", "expected"),
                         [(10_000, 20, 4), (2_000, 4, 1), (400, 1, 1), (FINE_SAMPLES, 5, 1), (60_000, 120, 24),
                          (60_000, 20, 20)])
def test_the_finer_grid_holds_at_most_fine_samples_and_is_never_coarser(n: int, decimation: int,
                                                                        expected: int) -> None:
    d = fine_decimation(decimation, n)
    assert d == expected
    assert d <= decimation and (d == decimation or -(-n // d) <= FINE_SAMPLES)


def test_the_drift_basis_on_the_finer_grid_is_the_work_grids_at_its_samples() -> None:
    dt, decimation = 0.001, 6
    tau_fine = dt * np.arange(3001, dtype=np.float64)
    tau_work = tau_fine[::decimation]
    # the last fine sample lies past the last work sample: the knots follow the work grid's end
    work = drift_basis(tau_work, 0.8)
    fine = drift_basis(tau_fine, 0.8, end_s=float(tau_work[-1]))
    assert work is not None and fine is not None
    assert fine.shape[1] == work.shape[1]
    np.testing.assert_allclose(fine[::decimation][:tau_work.size], work, atol=1e-12)


@pytest.mark.parametrize("seed", [1069732537, 231569893])
def test_cart_two_friction_through_one_encoder_is_read_within_five_percent(seed: int) -> None:
    case = make_case(seed, "coulomb_friction", carts=2, encoders=1)
    report = diagnose(case.observed.t, case.observed.y, carts=case.observed.carts).report
    verdict = judge(case, report)
    assert verdict.cause == "coulomb_friction"
    assert all(e <= 0.05 for e in verdict.errors.values()), verdict.errors
    assert "refit on" in report.validation
