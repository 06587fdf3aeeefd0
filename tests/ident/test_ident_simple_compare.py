"""The simple physical identification (RK4/Euler), compare's fit % and resid's tests."""

from __future__ import annotations

import numpy as np
import pytest

from ident.comparison import compare, fit_percent, resid, residual_test
from ident.data import IdData
from ident.errors import IdentValueError
from ident.physics.steppers import euler_coulomb
from ident.releases import with_found_release
from ident.simple import fit_simple
from testkit.ident_synth import cart1_run, step


@pytest.mark.parametrize("fs", [50.0, 200.0])
def test_rk4_simple_fit_recovers_the_cart_with_unknown_release(fs: float) -> None:
    run = cart1_run(fs, seed=21)
    data = IdData(run.t, step(run.t, run.release_time_s - 0.12), run.y)
    fit = fit_simple(data, "rk4")
    assert fit.wn == pytest.approx(run.wn[0], rel=1e-3)
    assert fit.zeta == pytest.approx(run.zeta[0], rel=0.02)
    assert fit.gain == pytest.approx(1.0, abs=2e-3)
    assert abs(fit.release_time_s - run.release_time_s) < 1e-3
    floor = fit_percent(run.y, run.y_clean)[0]
    assert fit.fit_percent[0] >= 99.5 and fit.fit_percent[0] >= floor - 0.01
    assert compare(fit, data) == pytest.approx(list(fit.fit_percent))
    assert fit.std_errors["wn"] < 1e-3 * fit.wn and fit.success


def test_euler_overestimates_damping_less_with_substeps() -> None:
    run = cart1_run(50.0, seed=22)
    data = with_found_release(run.t, run.y)
    coarse = fit_simple(data, "euler").zeta / run.zeta[0] - 1
    fine = fit_simple(data, "euler", substeps=10).zeta / run.zeta[0] - 1
    assert coarse > 0.5  # Euler's growing amplitude is absorbed as extra damping
    assert 0 < fine < coarse / 5


def test_dry_friction_fit_on_a_coulomb_run() -> None:
    t = np.arange(0.0, 8.0, 1 / 50)
    wn, zeta, f, t_r = 7.3, 0.02, 0.25, 0.8
    rng = np.random.default_rng(23)
    clean = euler_coulomb(wn, zeta, f, 0.15, t, t_r, substeps=200)
    data = IdData(t, step(t, 1.0), clean + 1e-4 * rng.standard_normal(t.size))
    linear = fit_simple(data, "euler", substeps=20)
    dry = fit_simple(data, "euler", substeps=20, friction=True)
    assert dry.friction == pytest.approx(f, rel=0.05)
    assert dry.wn == pytest.approx(wn, rel=2e-3)
    assert dry.fit_percent[0] > linear.fit_percent[0] + 1.0
    with pytest.raises(IdentValueError, match="'euler' when friction=True"):
        fit_simple(data, "rk4", friction=True)


def test_fit_percent_is_matlab_compare_per_output() -> None:
    y = np.column_stack([np.arange(10.0), np.ones(10) + np.arange(10.0) ** 2])
    y_hat = y + np.column_stack([np.full(10, 0.5), np.zeros(10)])
    expected = 100 * (1 - np.linalg.norm(np.full(10, 0.5)) / np.linalg.norm(y[:, 0] - y[:, 0].mean()))
    assert fit_percent(y, y_hat) == pytest.approx([expected, 100.0])


def test_resid_passes_white_residuals_and_fails_coloured_ones() -> None:
    rng = np.random.default_rng(24)
    n = 2000
    u = np.where(np.arange(n) > 300, 0.15, 0.0)
    white = residual_test(rng.standard_normal(n), u)
    assert white.white and white.independent and white.autocorrelation[0] == pytest.approx(1.0)
    coloured = np.convolve(rng.standard_normal(n), np.ones(5), mode="same")
    assert not residual_test(coloured, u).white
    correlated = 0.5 * (u - u.mean()) / u.std() + 0.1 * rng.standard_normal(n)
    assert not residual_test(correlated, u).independent


def test_resid_of_a_good_simple_fit_is_white() -> None:
    run = cart1_run(50.0, seed=25)
    data = IdData(run.t, step(run.t, 1.0), run.y)
    (test,) = resid(fit_simple(data, "rk4"), data)
    assert test.white and test.auto_bound == pytest.approx(2.5758 / np.sqrt(run.t.size), rel=1e-4)


def test_rk4_simple_fit_can_hold_a_known_release() -> None:
    run = cart1_run(200.0, seed=26)
    data = IdData(run.t, step(run.t, run.release_time_s), run.y, release_time_s=run.release_time_s)
    fit = fit_simple(data, "rk4", fit_release=False)
    assert fit.release_time_s == run.release_time_s and "release_time_s" not in fit.std_errors
    assert fit.wn == pytest.approx(run.wn[0], rel=1e-3) and fit.covariance.shape == (4, 4)
    with pytest.raises(IdentValueError, match="known release"):
        fit_simple(IdData(run.t, step(run.t, 1.0), run.y), "rk4", fit_release=False)
