"""PEM with an innovation-form noise model: a disturbed cart (process noise)."""

from __future__ import annotations

import numpy as np
import pytest

from ident.comparison import residual_test
from ident.data import IdData
from ident.errors import IdentValueError
from ident.prediction_error import pem
from testkit.ident_synth import cart1_run, step


def _disturbed_run(fs: float, seed: int) -> tuple[IdData, float, float, float]:
    """Cart 1 plus a random force (white acceleration, exact zoh through the cart's own
    dynamics, written here from wn, ζ) plus 0.1 mm measurement noise; u steps 0.12 s early."""
    run = cart1_run(fs, noise=0.0)
    wn, zeta = float(run.wn[0]), float(run.zeta[0])
    from scipy.linalg import expm

    aug = np.zeros((3, 3))
    aug[:2, :2] = np.array([[0.0, 1.0], [-wn * wn, -2 * zeta * wn]]) / fs
    aug[1, 2] = 1.0 / fs
    e = expm(aug)
    rng = np.random.default_rng(seed)
    x = np.zeros(2)
    disturbance = np.zeros(run.t.size)
    for k, w in enumerate(0.02 * np.sqrt(fs / 50) * rng.standard_normal(run.t.size)):
        disturbance[k] = x[0]
        x = e[:2, :2] @ x + e[:2, 2] * w
    y = run.y[:, 0] + disturbance + 1e-4 * rng.standard_normal(run.t.size)
    return IdData(run.t, step(run.t, run.release_time_s - 0.12), y), wn, zeta, run.release_time_s


@pytest.mark.parametrize("fs", [50.0, 200.0])
def test_innovation_form_whitens_the_prediction_errors_of_a_disturbed_cart(fs: float) -> None:
    data, wn, zeta, release = _disturbed_run(fs, seed=51)
    oe = pem(data, 2)
    model = pem(data, 2, noise_model="innovation")
    assert model.K is not None and np.any(model.K)
    errors = data.y - model.predict(data.u, data.y)
    assert residual_test(errors[:, 0], data.u).white
    assert not residual_test((data.y - oe.predict(data.u, data.y))[:, 0], data.u).white
    assert model.modes[0].wn == pytest.approx(wn, rel=1e-3)
    assert model.modes[0].zeta == pytest.approx(zeta, rel=0.02)
    assert abs((model.release_time_s or 0.0) - release) < 1e-3
    # the noise model gives honest (larger) standard errors than the white-noise assumption
    assert model.modes[0].zeta_std > 3 * oe.modes[0].zeta_std
    ad, _, c, _, k = model.discrete()
    assert k.shape == (2, 1) and np.all(np.abs(np.linalg.eigvals(ad - k @ c)) < 1.0)


def test_white_noise_leaves_a_small_innovation_gain() -> None:
    run = cart1_run(50.0, seed=52)
    data = IdData(run.t, step(run.t, 0.5), run.y)
    oe = pem(data, 2)
    model = pem(data, 2, noise_model="innovation")
    assert model.modes[0].wn == pytest.approx(oe.modes[0].wn, rel=3e-5)
    one_step = data.y - model.predict(data.u, data.y)
    assert 0.94 * np.std(oe.residuals) < np.std(one_step) <= np.std(oe.residuals) * (1 + 1e-9)
    assert model.K is not None and np.max(np.abs(model.K)) < 0.1


def test_unknown_noise_model_is_named() -> None:
    run = cart1_run(50.0)
    with pytest.raises(IdentValueError, match="noise_model"):
        pem(IdData(run.t, step(run.t, 0.5), run.y), 2, noise_model="arx")  # type: ignore[arg-type]
