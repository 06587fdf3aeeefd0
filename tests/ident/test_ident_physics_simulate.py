"""Hand-derived transfer functions against RK4 of their ODEs; simulator convergence orders."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from ident.errors import IdentValueError
from ident.physics import SingleCart, TwoCartChain
from ident.physics.steppers import euler, euler_coulomb, linear_step_map, linear_step_response, rk4

CHAIN = dict(m1=0.833, m2=1.098, k1=31.2, k2=60.4, k3=76.5, c1=0.150, c2=0.290)


def _tf_step(num: np.ndarray, den: np.ndarray, t: np.ndarray) -> np.ndarray:
    return signal.lti(num, den).step(T=t)[1]


def test_single_cart_tf_step_matches_rk4_of_its_ode() -> None:
    cart = SingleCart(m=0.727, c=0.553, k=39.0)
    t = np.linspace(0.0, 5.0, 501)

    def ode(_: float, x: np.ndarray) -> np.ndarray:  # m x'' + c x' + k x = k r, r = 1
        return np.array([x[1], (cart.k * 1.0 - cart.c * x[1] - cart.k * x[0]) / cart.m])

    x = rk4(ode, np.zeros(2), t, substeps=4)[:, 0]
    (num, den), = cart.tf_coefficients()
    assert np.max(np.abs(_tf_step(num, den, t) - x)) < 1e-8
    assert np.max(np.abs(cart.step_response(t, 0.0, 1.0) - x)) < 1e-8
    assert cart.wn == pytest.approx(np.sqrt(39.0 / 0.727))
    assert cart.zeta == pytest.approx(0.553 / (2 * np.sqrt(39.0 * 0.727)))


@pytest.mark.parametrize("structure", ["release", "anchor", "force"])
def test_two_cart_tfs_match_rk4_of_newtons_equations(structure: str) -> None:
    chain = TwoCartChain(**CHAIN, structure=structure)  # type: ignore[arg-type]
    t = np.linspace(0.0, 4.0, 801)

    def ode(_: float, s: np.ndarray) -> np.ndarray:
        return np.concatenate([s[2:], chain.acceleration(s[:2], s[2:], 1.0)])

    x = rk4(ode, np.zeros(4), t, substeps=8)[:, :2]
    for j, (num, den) in enumerate(chain.tf_coefficients()):
        assert np.max(np.abs(_tf_step(num, den, t) - x[:, j])) < 1e-7 * max(1.0, np.max(np.abs(x[:, j])))


def test_lab_case_3_settles_at_the_pull_with_cart_2_at_rest() -> None:
    chain = TwoCartChain(**CHAIN)
    assert chain.input_vector == pytest.approx([(31.2 + 60.4), -60.4])
    assert chain.dc_gains() == pytest.approx([1.0, 0.0], abs=1e-12)
    (num1, den), (num2, _) = chain.tf_coefficients()
    assert len(den) - len(num1) == 2 and len(den) - len(num2) == 2
    assert num2[-1] == 0.0  # cart 2: zero at s = 0
    anchor = TwoCartChain(**CHAIN, structure="anchor")
    assert len(den) - len(anchor.tf_coefficients()[1][0]) == 4
    assert anchor.dc_gains()[1] > 0.1  # an anchor input leaves cart 2 displaced


def test_bad_physical_parameters_are_named() -> None:
    with pytest.raises(IdentValueError, match="m: expected a positive"):
        SingleCart(m=0.0, c=0.1, k=1.0)
    with pytest.raises(IdentValueError, match="structure"):
        TwoCartChain(**CHAIN, structure="magnet")  # type: ignore[arg-type]


def _oscillator_error(method: str, h: float) -> float:
    wn, zeta = 7.3, 0.05
    t = np.arange(0.0, 2.0 + h / 2, h)

    def ode(_: float, x: np.ndarray) -> np.ndarray:
        return np.array([x[1], -2 * zeta * wn * x[1] - wn * wn * (x[0] - 1.0)])

    x = (rk4 if method == "rk4" else euler)(ode, np.zeros(2), t)[:, 0]
    exact = SingleCart.from_modal(wn, zeta).step_response(t, 0.0, 1.0)
    return float(np.max(np.abs(x - exact)))


def test_rk4_error_falls_16_fold_and_euler_2_fold_when_the_step_halves() -> None:
    rk4_ratio = _oscillator_error("rk4", 0.01) / _oscillator_error("rk4", 0.005)
    euler_ratio = _oscillator_error("euler", 0.0005) / _oscillator_error("euler", 0.00025)
    assert rk4_ratio == pytest.approx(16.0, rel=0.08)
    assert euler_ratio == pytest.approx(2.0, rel=0.05)


@pytest.mark.parametrize("method", ["rk4", "euler"])
def test_linear_step_map_is_the_same_numbers_as_stepping(method: str) -> None:
    cart = SingleCart.from_modal(7.0, 0.05)
    ss = cart.state_space()
    t = np.arange(0.0, 3.0, 0.02)
    t_r = 0.513

    def ode(_: float, x: np.ndarray) -> np.ndarray:
        return ss.A @ x + ss.B[:, 0] * 0.15

    grid = np.concatenate([[t_r], t[t >= t_r]])
    stepped = (rk4 if method == "rk4" else euler)(ode, np.zeros(2), grid)[1:]
    fast = linear_step_response(ss.A, ss.B, t, t_r, 0.15, method)  # type: ignore[arg-type]
    assert np.max(np.abs(fast[t >= t_r] - stepped)) < 1e-12
    assert not np.any(fast[t < t_r])
    phi, gamma = linear_step_map(ss.A, ss.B, 0.01, method)  # type: ignore[arg-type]
    assert phi.shape == (2, 2) and gamma.shape == (2, 1)


def _coulomb_exact(wn: float, zeta: float, f: float, r: float, t: np.ndarray) -> np.ndarray:
    """Exact piecewise solution from rest at 0: each half-cycle is a linear oscillator about
    r ∓ f/wn² that comes to rest after π/ω_d; stick when |wn² (x - r)| ≤ f."""
    sigma, wd = zeta * wn, wn * np.sqrt(1 - zeta ** 2)
    out = np.zeros_like(t)
    x0, t0 = 0.0, 0.0
    while True:
        pull = wn * wn * (r - x0)
        if abs(pull) <= f:
            out[t >= t0] = x0
            return out
        centre = r - np.sign(pull) * f / wn ** 2
        seg = (t >= t0) & (t < t0 + np.pi / wd)
        tau = t[seg] - t0
        out[seg] = centre + (x0 - centre) * np.exp(-sigma * tau) * (np.cos(wd * tau) + sigma / wd * np.sin(wd * tau))
        x0 = centre + (x0 - centre) * np.exp(-sigma * np.pi / wd) * -1.0
        t0 += np.pi / wd


def test_euler_coulomb_sticks_and_converges_to_the_exact_solution() -> None:
    wn, zeta, f, r = 7.3, 0.02, 0.5, 0.15
    t = np.arange(0.0, 6.0, 0.01)
    exact = _coulomb_exact(wn, zeta, f, r, t)
    coarse = euler_coulomb(wn, zeta, f, r, t, 0.0, substeps=50)
    fine = euler_coulomb(wn, zeta, f, r, t, 0.0, substeps=400)
    assert np.max(np.abs(fine - exact)) < np.max(np.abs(coarse - exact))
    assert np.max(np.abs(fine - exact)) < 2e-3
    # it stops for good inside the friction band around r and stays there
    assert abs(fine[-1] - r) <= f / wn ** 2
    assert np.ptp(fine[t > 5.0]) == 0.0
