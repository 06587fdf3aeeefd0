"""Subspace start values (free-response Hankel, PO-MOESP) and the zoh d2c by matrix logarithm."""

from __future__ import annotations

import numpy as np
import pytest

from ident.data import IdData
from ident.errors import IdentValueError
from ident.physics import TwoCartChain, modes_of
from ident.prediction_error import pem
from ident.subspace import free_response_poles, moesp, oscillatory_modes
from ident.zoh import c2d_zoh, d2c_zoh
from testkit.ident_synth import cart2_run, step


def test_d2c_inverts_c2d() -> None:
    ss = TwoCartChain(0.833, 1.098, 31.2, 60.4, 76.5, 0.150, 0.290).state_space()
    for ts in (0.02, 0.005):
        phi, gamma = c2d_zoh(ss.A, ss.B, ts)
        a, b = d2c_zoh(phi, gamma, ts)
        assert np.allclose(a, ss.A, atol=1e-8 * np.max(np.abs(ss.A)))
        assert np.allclose(b, ss.B, atol=1e-8 * np.max(np.abs(ss.B)))


def test_d2c_refuses_poles_on_the_negative_real_axis() -> None:
    with pytest.raises(IdentValueError, match="negative real axis"):
        d2c_zoh(np.array([[-0.5]]), np.array([[1.0]]), 0.01)


@pytest.mark.parametrize("fs", [50.0, 200.0])
def test_moesp_then_d2c_finds_both_modes_of_two_carts(fs: float) -> None:
    run = cart2_run(fs, seed=31)
    a, b, c, d = moesp(step(run.t, run.release_time_s), run.y, 4)
    a_c, _ = d2c_zoh(a, b, 1 / fs)
    modes = modes_of(a_c)
    assert [m.wn for m in modes] == pytest.approx(run.wn, rel=1e-3)
    assert [m.zeta for m in modes] == pytest.approx(run.zeta, rel=0.05)
    assert c.shape == (2, 4) and d.shape == (2, 1)


def test_free_response_poles_with_decimation_at_200_hz() -> None:
    run = cart2_run(200.0, seed=32)
    after = run.t > run.release_time_s + 0.05
    poles = free_response_poles(run.y[after], 1 / 200, (5, 7), step=7)
    for candidate in poles:
        found = oscillatory_modes(candidate, 2, 0.8 * np.pi / (7 / 200))
        assert found is not None
        sigma, omega = found
        assert np.hypot(sigma, omega) == pytest.approx(run.wn, rel=1e-3)


def test_pem_with_a_general_input_uses_the_recorded_input() -> None:
    # a force pulse and its reversal on cart 1 (as the ECP-210's motor does), noisy outputs
    chain = TwoCartChain(0.833, 1.098, 31.2, 60.4, 76.5, 0.150, 0.290, structure="force")
    ss = chain.state_space()
    t = np.arange(0.0, 6.0, 0.01)
    u = np.where((t >= 0.5) & (t < 3.0), 2.0, 0.0)
    phi, gamma = c2d_zoh(ss.A, ss.B, 0.01)
    x = np.zeros(4)
    y = np.zeros((t.size, 2))
    for k in range(t.size):
        y[k] = ss.C @ x
        x = phi @ x + gamma[:, 0] * u[k]
    rng = np.random.default_rng(33)
    model = pem(IdData(t, u, y + 1e-5 * rng.standard_normal(y.shape)), 4)
    assert [m.wn for m in model.modes] == pytest.approx([m.wn for m in chain.modes()], rel=1e-3)
    assert min(model.fit_percent) > 99.0
    assert model.release_time_s is None
    assert model.dc_gain == pytest.approx(chain.dc_gains(), rel=1e-2)
