"""`ident.physics.simulate_free` against closed forms: every force of the lab's carts."""

from __future__ import annotations

import numpy as np
import pytest

from ident.physics import NonlinearTerms, simulate_free
from ident.physics.chain import linear_free_response


def _extrema(x: np.ndarray) -> np.ndarray:
    k = np.flatnonzero((x[1:-1] - x[:-2]) * (x[2:] - x[1:-1]) < 0) + 1
    return x[k]


def test_two_cart_chain_with_zero_forces_is_the_exact_linear_response() -> None:
    lin = np.array([[200.0, 80.0, 60.0, 150.0, 0.2, 0.1]])
    z0 = np.array([[0.03, -0.01, 0.1, 0.0]])
    tau = 0.005 * np.arange(1200, dtype=np.float64)
    z = simulate_free(lin, z0, 0.005, tau.size, 2, NonlinearTerms(friction_m_s2=np.zeros((1, 2))))
    assert np.max(np.abs(z - linear_free_response(lin, z0, tau, 2))) < 1e-12


@pytest.mark.parametrize("static_ratio", [1.0, 1.4])
def test_coulomb_envelope_drops_by_2f_over_wn2_and_static_friction_stops_it_sooner(static_ratio: float) -> None:
    # undamped: each half cycle loses 2F/wn²; the cart sticks at the first extreme where the
    # spring pull wn²|x| is within the static level Fs
    wn, f, x0 = 12.0, 0.4, 0.05
    z = simulate_free(np.array([[wn, 0.0]]), np.array([[x0, 0.0]]), 0.002, 4000, 1,
                      NonlinearTerms(friction_m_s2=np.array([[f]]),
                                     static_friction_m_s2=np.array([[static_ratio * f]])))[0, :, 0]
    peaks = np.abs(_extrema(z))
    step = 2 * f / wn ** 2
    expected = x0 - step * np.arange(1, peaks.size + 1)
    assert np.max(np.abs(peaks - expected)) < 2e-5
    amps = x0 - step * np.arange(0, 100)
    stops = int(np.argmax(wn ** 2 * amps <= static_ratio * f))   # first extreme held by Fs
    assert abs(abs(z[-1]) - amps[stops]) < 2e-5
    assert np.all(z[-100:] == z[-1])


def test_a_cart_at_rest_stays_while_static_friction_holds_the_spring() -> None:
    # at rest at x0 = pull/wn² off its rest, kinetic 0.05 and static 0.1 m/s²: no pull below
    # the static level starts it (each stays put to the bit; a held cart left with a rounding
    # residue of velocity used to slip away under kinetic friction), pulls above it do
    wn, fk, fs = 10.0, 0.05, 0.1
    pulls = np.linspace(0.052, 0.14, 45)
    x0 = pulls / wn ** 2
    rows = pulls.size
    z = simulate_free(np.tile([wn, 0.02], (rows, 1)), np.column_stack([x0, np.zeros(rows)]), 0.005, 400, 1,
                      NonlinearTerms(friction_m_s2=np.full((rows, 1), fk),
                                     static_friction_m_s2=np.full((rows, 1), fs)))[:, :, 0]
    moved = np.max(np.abs(z - x0[:, None]), axis=1)
    assert np.all(moved[pulls < fs] < 1e-15)
    assert np.all(moved[pulls > fs] > 0.1 * x0[pulls > fs])


def test_dahl_friction_is_a_spring_at_small_amplitude_and_coulomb_at_large() -> None:
    wn, f, sigma = 10.0, 0.5, 300.0
    terms = NonlinearTerms(friction_m_s2=np.array([[f]]), presliding_per_s2=np.array([[sigma]]))
    # small amplitude (|w| ≪ F): the friction state follows σ·(x - x0), an extra spring
    # anchored where the motion began; the ring is at √(wn² + σ) about a shifted centre
    x_small = 1e-5
    z = simulate_free(np.array([[wn, 0.0]]), np.array([[x_small, 0.0]]), 0.001, 3000, 1, terms)[0, :, 0]
    centre = sigma * x_small / (wn ** 2 + sigma)
    crossings = np.flatnonzero(np.sign(z[1:] - centre) != np.sign(z[:-1] - centre))
    period = 2 * np.mean(np.diff(crossings)) * 0.001
    assert 2 * np.pi / period == pytest.approx(np.sqrt(wn ** 2 + sigma), rel=0.01)
    # large amplitude (F/σ ≪ x): the peaks drop by ≈ 2F/wn² per half cycle, as Coulomb's
    z = simulate_free(np.array([[wn, 0.0]]), np.array([[0.1, 0.0]]), 0.001, 3000, 1, terms)[0, :, 0]
    drops = -np.diff(np.abs(_extrema(z)))[:4]
    assert drops == pytest.approx(np.full(4, 2 * f / wn ** 2), rel=0.05)


def test_a_constant_force_input_moves_the_rest_by_g_u_over_wn2() -> None:
    wn, zeta, g = 8.0, 0.3, 2.0
    n = 3000
    u = np.ones((n, 1))
    z = simulate_free(np.array([[wn, zeta]]), np.zeros((1, 2)), 0.002, n, 1,
                      NonlinearTerms(input_gain=np.array([[[g]]])), u)[0, :, 0]
    assert z[-1] == pytest.approx(g / wn ** 2, rel=1e-6)
    # the step response of wn²/(s² + 2ζwn s + wn²) scaled by g/wn², exactly (ZOH of a step)
    tau = 0.002 * np.arange(n, dtype=np.float64)
    free = linear_free_response(np.array([[wn, zeta]]), np.array([[-g / wn ** 2, 0.0]]), tau, 1)[0, :, 0]
    assert np.max(np.abs(z - (g / wn ** 2 + free))) < 1e-9


def test_the_held_carts_motion_drives_the_free_cart_through_the_spring() -> None:
    # x'' = -wn² x + β u(t), u = a sin(Ωt): the steady forced amplitude is β a / (wn² - Ω²)
    wn, zeta, beta, a, omega = 10.0, 0.2, 40.0, 0.003, 4.0
    dt, n = 0.002, 10000
    u = (a * np.sin(omega * dt * np.arange(n)))[:, None]
    z = simulate_free(np.array([[wn, zeta]]), np.zeros((1, 2)), dt, n, 1,
                      NonlinearTerms(input_gain=np.array([[[beta]]])), u)[0, :, 0]
    expected = beta * a / np.hypot(wn ** 2 - omega ** 2, 2 * zeta * wn * omega)
    assert np.max(np.abs(z[-2000:])) == pytest.approx(expected, rel=2e-3)


@pytest.mark.parametrize("kappa", [2e4, -2e4])
def test_cubic_spring_shifts_the_frequency_as_the_energy_balance_says(kappa: float) -> None:
    # x'' = -wn² x - κ x³: to first order ω² = wn² + (3/4) κ A² at amplitude A
    wn, amp = 10.0, 0.02
    z = simulate_free(np.array([[wn, 0.0]]), np.array([[amp, 0.0]]), 0.001, 5000, 1,
                      NonlinearTerms(cubic_per_m2_s2=np.array([[kappa]])))[0, :, 0]
    crossings = np.flatnonzero(np.sign(z[1:]) != np.sign(z[:-1]))
    omega = np.pi / (np.mean(np.diff(crossings)) * 0.001)
    assert omega ** 2 == pytest.approx(wn ** 2 + 0.75 * kappa * amp ** 2, rel=0.01)
    # energy is conserved: the peaks stay at ±A
    assert np.max(np.abs(z)) == pytest.approx(amp, rel=1e-3)


def test_quadratic_drag_follows_the_half_cycle_energy_law() -> None:
    # x'' = -wn² x - d v|v|, light drag (d A ≪ 1): each half cycle loses (4/3) d A²
    wn, d, amp = 10.0, 0.2, 0.05
    z = simulate_free(np.array([[wn, 0.0]]), np.array([[amp, 0.0]]), 0.001, 800, 1,
                      NonlinearTerms(drag_per_m=np.array([[d]])))[0, :, 0]
    drop = amp - abs(_extrema(z)[0])
    assert drop == pytest.approx(4.0 / 3.0 * d * amp ** 2, rel=0.02)
