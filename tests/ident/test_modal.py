"""`ident.modal` against closed forms: the input-output sections and the free-response fit."""

from __future__ import annotations

import numpy as np

from ident.modal import fit_modes, modal_prediction, section_states, step_basis


def test_zoh_section_states_of_a_unit_step_are_the_closed_form_step_basis() -> None:
    # a step held from sample 0 is exactly representable by a zoh: the discrete states must
    # equal p(τ), q(τ) of the continuous section at every sample
    sigma, omega, ts = 0.4, 9.0, 0.01
    t = ts * np.arange(600, dtype=np.float64)
    states = section_states(sigma, omega, ts, 0.0, np.ones(t.size))
    exact = step_basis(t, 0.0, np.array([sigma]), np.array([omega]))
    assert np.max(np.abs(states[0] - exact[:, 1])) < 1e-12
    assert np.max(np.abs(states[1] - exact[:, 2])) < 1e-12


def test_fit_modes_recovers_two_damped_modes_from_a_noisy_free_response() -> None:
    rng = np.random.default_rng(11)
    tau = 0.005 * np.arange(2000, dtype=np.float64)
    freqs, decays = np.array([6.0, 17.0]), np.array([0.15, 0.6])
    a = np.array([[0.02, -0.01], [0.015, 0.012]])        # (n_out, m) cosine amplitudes
    b = np.array([[0.004, 0.003], [-0.006, 0.001]])
    rest = np.array([0.001, -0.002])
    y = np.repeat(rest[None, :], tau.size, axis=0)
    for j in range(2):
        env = np.exp(-decays[j] * tau)[:, None]
        y += env * (np.cos(freqs[j] * tau)[:, None] * a[:, j] + np.sin(freqs[j] * tau)[:, None] * b[:, j])
    noise = 2e-5 * rng.standard_normal(y.shape)
    fit = fit_modes(tau, y + noise, np.array([5.7, 17.6]))
    order = np.argsort(fit.freqs)
    assert np.allclose(fit.freqs[order], freqs, rtol=2e-3)
    assert np.allclose(fit.decays[order], decays, rtol=3e-2)
    assert np.allclose(fit.rest, rest, atol=2e-5)
    assert np.max(np.abs(modal_prediction(fit, tau) - y)) < 1e-4
    assert abs(fit.sse / y.size - 4e-10) < 1e-10            # the residual is the noise
