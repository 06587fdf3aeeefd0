"""PEM's physical start against closed-form modes of a cart and of a two-cart chain."""

from __future__ import annotations

import numpy as np
import pytest

from ident.physical_start import carts_at_peaks, physical_start

TS = 0.005


def _free(a: np.ndarray, z0: np.ndarray, n: int, carts: int) -> np.ndarray:
    """Exact positions (n, carts) of z' = A z from z0, by the matrix exponential's eigenvectors."""
    lam, vec = np.linalg.eig(a)
    coef = np.linalg.solve(vec, z0.astype(complex))
    tau = TS * np.arange(n, dtype=np.float64)
    z = (vec[:carts] @ (coef[:, None] * np.exp(lam[:, None] * tau[None, :]))).real.T
    return np.asarray(z, dtype=np.float64)


@pytest.mark.parametrize(("wn", "zeta"), [(6.0, 0.01), (14.0, 0.05), (30.0, 0.12)])
def test_one_cart_start_is_sigma_zeta_wn_and_omega_wn_sqrt_1_minus_zeta2(wn: float, zeta: float) -> None:
    rng = np.random.default_rng(3)
    a = np.array([[0.0, 1.0], [-wn ** 2, -2.0 * zeta * wn]])
    y = _free(a, np.array([0.03, 0.0]), 2000, 1) + 1e-5 * rng.standard_normal((2000, 1))
    start = physical_start(y, TS, 1)
    assert start is not None
    sigma, omega = start
    # a start, not a fit: the windowed spectrum's peak of a decaying ring sits up to ~ζ²
    # below ω (1.3 % at ζ = 0.12); the decay is searched with that frequency
    assert omega[0] == pytest.approx(wn * np.sqrt(1.0 - zeta ** 2), rel=max(1e-3, zeta ** 2))
    assert sigma[0] == pytest.approx(zeta * wn, rel=max(0.03, 3 * zeta ** 2))


@pytest.mark.parametrize(("m", "k", "c"), [(1.0, 200.0, 0.4), (0.6, 90.0, 0.1)])
def test_symmetric_chain_start_has_the_modes_k_over_m_and_3k_over_m(m: float, k: float, c: float) -> None:
    # k1 = k2 = k3 = k, m1 = m2 = m, dampers c to ground: proportional damping, so the modes
    # are exactly wn1² = k/m (in phase), wn2² = 3k/m (opposed), each with ζ_j = c / (2 m wn_j)
    kt = np.array([[2 * k, -k], [-k, 2 * k]]) / m
    a = np.block([[np.zeros((2, 2)), np.eye(2)], [-kt, -np.eye(2) * c / m]])
    y = _free(a, np.array([0.04, 0.0, 0.0, 0.0]), 2400, 2)
    start = physical_start(y, TS, 2)
    assert start is not None
    sigma, omega = start
    wn = np.sqrt(np.array([k / m, 3 * k / m]))
    zeta = c / (2 * m * wn)
    assert sigma == pytest.approx(zeta * wn, rel=0.02)
    assert omega == pytest.approx(wn * np.sqrt(1 - zeta ** 2), rel=1e-3)


def test_unequal_chain_start_has_the_roots_of_det_k_minus_w2_m() -> None:
    # undamped chain: wn² are the roots of m1 m2 w⁴ - (m1 (k2 + k3) + m2 (k1 + k2)) w² + det K
    m1, m2, k1, k2, k3 = 1.2, 0.7, 150.0, 60.0, 0.0
    kk = np.array([[k1 + k2, -k2], [-k2, k2 + k3]])
    a = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.diag([1 / m1, 1 / m2]) @ kk, np.zeros((2, 2))]])
    y = _free(a, np.array([0.02, -0.01, 0.0, 0.0]), 3000, 2)
    b = m1 * (k2 + k3) + m2 * (k1 + k2)
    det = (k1 + k2) * (k2 + k3) - k2 ** 2
    w2 = np.sort(np.roots([m1 * m2, -b, det]).real)
    start = physical_start(y, TS, 2)
    assert start is not None
    sigma, omega = start
    assert omega == pytest.approx(np.sqrt(w2), rel=1e-3)
    assert np.all(sigma > 0.0) and np.all(sigma < 0.01 * omega)   # a start is stable, barely damped


def test_carts_at_peaks_ring_at_the_peaks() -> None:
    sigma, omega = carts_at_peaks(np.array([5.0, 12.0]), 0.1)
    assert omega == pytest.approx([5.0, 12.0], rel=1e-12)
    assert sigma == pytest.approx(0.1 * np.array([5.0, 12.0]) / np.sqrt(0.99), rel=1e-12)


def test_a_record_without_enough_peaks_gives_no_start() -> None:
    assert physical_start(np.zeros((500, 1)), TS, 2) is None
