"""Continuous-time modal models (pure numpy/scipy): the one home of modal structure and fits.

Two uses of the same sum of damped modes, -σ_i ± jω_i (wn_i² = σ_i² + ω_i²):

* **Input-output structure** (PEM, `ident.varpro`, `ident.predictor`): second-order
  sections in companion form and their linear-in-parameters bases.
* **Free responses** (`ModalFit`, `fit_modes`; the diagnosis's start values, release window
  and coupled-mode candidate): y_i(τ) = s_i + Σ_j e^{-σ_j τ}(a_ij cos ω_j τ + b_ij sin ω_j τ),
  τ ≥ 0 (s), linear in (s_i, a_ij, b_ij), nonlinear in (ω_j rad/s, σ_j 1/s), fitted by
  variable projection so the optimiser only sees 2m parameters.

No I/O here; the physical fits are in `ident.diagnose.fitting`.

Input-output structure
----------------------
A linear model with m oscillatory modes is written as a sum of second-order sections in
companion form, one per mode i:

    G_j(s) = D_j + Σ_i (c0_ij + c1_ij s) / (s² + 2σ_i s + wn_i²),   output j.

State space: A = blkdiag([[0, 1], [-wn_i², -2σ_i]]), B = (0, 1, 0, 1, …)ᵀ,
C_j = (c0_1j, c1_1j, …), D_j. Given the modes (the nonlinear parameters), every output is
LINEAR in (D_j, c0_ij, c1_ij) and in an output offset, so these are solved by least squares
inside the nonlinear fit (variable projection): only σ_i, ω_i (and the release time) are
iterated on, a well-conditioned continuous parametrisation at any sampling rate — unlike
discrete polynomial coefficients with poles crowding z = 1.

Basis responses (columns) for a unit step at τ = t - t_r (0 for τ < 0):
    direct:   1,
    p_i(τ) = (1 - e^{-σ τ}(cos ωτ + (σ/ω) sin ωτ)) / wn²     (state 1 of section i),
    q_i(τ) = e^{-σ τ} sin(ωτ) / ω                             (state 2 = p_i').

Structural constraints are linear in the coefficients (Markov parameters):
relative degree ≥ r ⇔ D = 0 and C A^k B = 0 for k = 0 … r-2; DC gain G(0) = D + Σ c0_i/wn_i².
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


def n_coefficients(n_modes: int) -> int:
    """Linear coefficients per output: D and (c0, c1) per mode."""
    return 1 + 2 * n_modes


def step_basis(t: FloatArray, release_time_s: float, sigma: FloatArray,
               omega: FloatArray) -> FloatArray:
    """Responses to a unit step at `release_time_s`, shape (N, 1 + 2m): [1, p_1, q_1, …]·H(τ)."""
    first = int(np.searchsorted(t, release_time_s, side="left"))
    tau = t[first:] - release_time_s
    out = np.zeros((t.shape[0], 1 + 2 * len(sigma)))
    out[first:, 0] = 1.0
    for i, (s, w) in enumerate(zip(sigma, omega, strict=True)):
        decay = np.exp(-s * tau)
        cos_wt = np.cos(w * tau)
        sin_wt = np.sin(w * tau)
        out[first:, 1 + 2 * i] = (1.0 - decay * (cos_wt + (s / w) * sin_wt)) / (s * s + w * w)
        out[first:, 2 + 2 * i] = decay * sin_wt / w
    return out


def section_matrices(sigma: float, omega: float) -> tuple[FloatArray, FloatArray]:
    """Companion section A_i = [[0, 1], [-wn², -2σ]], B_i = [0, 1]ᵀ."""
    wn2 = sigma * sigma + omega * omega
    return np.array([[0.0, 1.0], [-wn2, -2.0 * sigma]]), np.array([0.0, 1.0])


def _phi_gamma(a_sec: FloatArray, b_sec: FloatArray, h: float) -> tuple[FloatArray, FloatArray]:
    """Φ(h) = e^{A h}, Γ(h) = ∫_0^h e^{Aσ} dσ B, from the expm of [[A, B], [0, 0]] h."""
    from scipy.linalg import expm  # deferred: keeps `import ident` fast
    aug = np.zeros((3, 3))
    aug[:2, :2] = a_sec * h
    aug[:2, 2] = b_sec * h
    e = expm(aug)
    return e[:2, :2], e[:2, 2]


def section_states(sigma: float, omega: float, ts: float, frac: float, v: FloatArray) -> list[FloatArray]:
    """Both states of one section, from rest, for input v (N,) held over each sample and
    delayed by frac·Ts (0 ≤ frac < 1), exactly.

    Over [t_k, t_k+1) the input is v[k-1] for frac·Ts, then v[k]:
    x[k+1] = Φ x[k] + Γ1 v[k-1] + Γ2 v[k], Φ = Φ(Ts), Γ1 = Φ((1-f)Ts) Γ(f Ts), Γ2 = Γ((1-f)Ts).
    State r is row r of adj(zI - Φ) (Γ1 z⁻¹ + Γ2) / det(zI - Φ), run by `lfilter`.
    """
    from scipy.signal import lfilter  # deferred: keeps `import ident` fast
    a_sec, b_sec = section_matrices(sigma, omega)
    phi, _ = _phi_gamma(a_sec, b_sec, ts)
    phi_rest, gamma2 = _phi_gamma(a_sec, b_sec, (1.0 - frac) * ts)
    gamma1 = phi_rest @ _phi_gamma(a_sec, b_sec, frac * ts)[1] if frac > 0 else np.zeros(2)
    den = np.array([1.0, -np.trace(phi), np.linalg.det(phi)])
    # adj(zI - Φ) = [[z - Φ11, Φ01], [Φ10, z - Φ00]]; row r times g, as coefficients of (z, 1)
    rows = (lambda g: np.array([g[0], phi[0, 1] * g[1] - phi[1, 1] * g[0]]),
            lambda g: np.array([g[1], phi[1, 0] * g[0] - phi[0, 0] * g[1]]))
    states = []
    for row in rows:
        num = np.concatenate([[0.0], row(gamma2), [0.0]]) + np.concatenate([[0.0, 0.0], row(gamma1)])
        states.append(lfilter(num, den, v))
    return states


def input_basis(u: FloatArray, ts: float, sigma: FloatArray, omega: FloatArray) -> FloatArray:
    """Responses to an arbitrary input `u` (N,), held constant over each sample (zoh), from rest
    at a zero input (one already on at the first sample was switched on there:
    `ident.data.input_jumps`): column 0 is `u` (direct term), then the two states of each
    section (`section_states` with no delay). Shape (N, 1 + 2m)."""
    columns = [u]
    for s, w in zip(sigma, omega, strict=True):
        columns.extend(section_states(float(s), float(w), ts, 0.0, u))
    return np.column_stack(columns)


def constraint_rows(sigma: FloatArray, omega: FloatArray, relative_degree: int,
                    dc_gain: float | None) -> tuple[FloatArray, FloatArray]:
    """Linear constraints `G θ = h` on θ = (D, c0_1, c1_1, …) for one output.

    Rows: D = 0 when relative_degree ≥ 1; C A^k B = 0 for k = 0 … relative_degree - 2;
    D + Σ c0_i / wn_i² = dc_gain when given.
    """
    m = len(sigma)
    rows: list[FloatArray] = []
    rhs: list[float] = []
    if relative_degree >= 1:
        rows.append(np.eye(1, 1 + 2 * m, 0)[0])
        rhs.append(0.0)
    vectors = [section_matrices(float(s), float(w)) for s, w in zip(sigma, omega, strict=True)]
    powers = [b.copy() for _, b in vectors]
    for _ in range(relative_degree - 1):
        row = np.zeros(1 + 2 * m)
        for i, v in enumerate(powers):
            row[1 + 2 * i: 3 + 2 * i] = v
        rows.append(row / max(1.0, float(np.max(np.abs(row)))))
        rhs.append(0.0)
        powers = [a @ v for (a, _), v in zip(vectors, powers, strict=True)]
    if dc_gain is not None:
        row = np.zeros(1 + 2 * m)
        row[0] = 1.0
        for i, (s, w) in enumerate(zip(sigma, omega, strict=True)):
            row[1 + 2 * i] = 1.0 / (s * s + w * w)
        rows.append(row)
        rhs.append(float(dc_gain))
    if not rows:
        return np.zeros((0, 1 + 2 * m)), np.zeros(0)
    return np.array(rows), np.array(rhs)


def constrained_parametrisation(rows: FloatArray, rhs: FloatArray,
                                size: int) -> tuple[FloatArray, FloatArray]:
    """θ = θ_p + N β spanning {θ : rows θ = rhs}; returns (θ_p (size,), N (size, size - rank))."""
    if rows.shape[0] == 0:
        return np.zeros(size), np.eye(size)
    _, singular, vt = np.linalg.svd(rows)
    rank = int(np.sum(singular > 1e-12 * singular[0]))
    null = vt[rank:].T
    particular = np.linalg.lstsq(rows, rhs, rcond=None)[0]
    return np.asarray(particular, dtype=np.float64), np.asarray(null, dtype=np.float64)


def state_space(sigma: FloatArray, omega: FloatArray,
                theta: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """(A, B, C, D) of the modal model; `theta` (n_out, 1 + 2m) rows (D, c0_1, c1_1, …)."""
    m = len(sigma)
    A = np.zeros((2 * m, 2 * m))
    B = np.zeros((2 * m, 1))
    for i, (s, w) in enumerate(zip(sigma, omega, strict=True)):
        a_sec, b_sec = section_matrices(float(s), float(w))
        A[2 * i:2 * i + 2, 2 * i:2 * i + 2] = a_sec
        B[2 * i:2 * i + 2, 0] = b_sec
    return A, B, np.asarray(theta[:, 1:], dtype=np.float64), np.asarray(theta[:, :1], dtype=np.float64)


def tf_coefficients(sigma: FloatArray, omega: FloatArray, theta_row: FloatArray,
                    relative_degree: int) -> tuple[FloatArray, FloatArray]:
    """(num, den) of G_j(s), highest power first; leading numerator terms that the
    relative-degree constraint makes zero are removed exactly."""
    sections = [np.array([1.0, 2.0 * s, s * s + w * w]) for s, w in zip(sigma, omega, strict=True)]
    den = np.array([1.0])
    for sec in sections:
        den = np.polymul(den, sec)
    num = theta_row[0] * den
    for i in range(len(sections)):
        others = np.array([1.0])
        for k, sec in enumerate(sections):
            if k != i:
                others = np.polymul(others, sec)
        num = np.polyadd(num, np.polymul([theta_row[2 + 2 * i], theta_row[1 + 2 * i]], others))
    num = np.concatenate([np.zeros(len(den) - len(num)), num])
    return num[relative_degree:] if relative_degree > 0 else num, den


# Free responses: modal fits by variable projection.


@dataclass(frozen=True)
class ModalFit:
    """`freqs` ω_j (rad/s, damped), `decays` σ_j (1/s), `rest` s_i (n_out,),
    `amplitudes` complex a_ij - i b_ij (n_out, m), `sse` residual sum of squares."""

    freqs: FloatArray
    decays: FloatArray
    rest: FloatArray
    amplitudes: NDArray[np.complex128]
    sse: float
    residual: FloatArray


def _basis(tau: FloatArray, freqs: FloatArray, decays: FloatArray) -> FloatArray:
    cols = [np.ones_like(tau)]
    for w, s in zip(freqs, decays):
        env = np.exp(-s * tau)
        cols += [env * np.cos(w * tau), env * np.sin(w * tau)]
    return np.column_stack(cols)


def project(tau: FloatArray, y: FloatArray, freqs: FloatArray, decays: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Linear coefficients (1 + 2m, n_out) and residual (N, n_out) for given modes."""
    basis = _basis(tau, freqs, decays)
    coef = np.asarray(np.linalg.lstsq(basis, y, rcond=None)[0], dtype=np.float64)
    return coef, np.asarray(y - basis @ coef, dtype=np.float64)


def fit_modes(tau: FloatArray, y: FloatArray, freq_starts: FloatArray,
              decay_starts: FloatArray | None = None) -> ModalFit:
    """Variable-projection fit of m = len(freq_starts) modes to `y` (N, n_out) on `tau` (N,)."""
    import scipy.optimize  # deferred: keeps `import ident` fast
    m = len(freq_starts)
    nyq = np.pi / max(float(np.median(np.diff(tau))), 1e-9)
    best: ModalFit | None = None
    factors = (0.02, 0.2) if decay_starts is None else (None,)
    for factor in factors:
        decays0 = (np.asarray(decay_starts) if factor is None
                   else factor * np.asarray(freq_starts) / (2 * np.pi))
        x0 = np.concatenate([freq_starts, np.maximum(decays0, 1e-4)])
        lower = np.concatenate([np.full(m, 1e-3), np.full(m, -0.05)])
        upper = np.concatenate([np.full(m, nyq), np.full(m, np.inf)])
        x0 = np.clip(x0, lower + 1e-9, upper - 1e-9)

        def res(x: FloatArray) -> FloatArray:
            return project(tau, y, x[:m], x[m:])[1].ravel()

        sol = scipy.optimize.least_squares(res, x0, bounds=(lower, upper), x_scale="jac",
                                           max_nfev=200)
        coef, resid = project(tau, y, sol.x[:m], sol.x[m:])
        sse = float(np.sum(resid ** 2))
        if best is None or sse < best.sse:
            amps = coef[1::2].T - 1j * coef[2::2].T
            best = ModalFit(sol.x[:m].copy(), sol.x[m:].copy(), coef[0].copy(), amps, sse, resid)
    assert best is not None
    return best


def modal_prediction(fit: ModalFit, tau: FloatArray) -> FloatArray:
    """The fitted free response (N, n_out) at `tau` (N,) s (any τ, also before the fit data)."""
    out = np.repeat(fit.rest[None, :], tau.size, axis=0)
    for j, (w, s) in enumerate(zip(fit.freqs, fit.decays)):
        env = np.exp(-s * tau)[:, None]
        a, b = fit.amplitudes[:, j].real, -fit.amplitudes[:, j].imag
        out = out + env * (np.cos(w * tau)[:, None] * a[None, :] + np.sin(w * tau)[:, None] * b[None, :])
    return np.asarray(out, dtype=np.float64)
