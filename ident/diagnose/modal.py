"""Modal fits of a free response by variable projection, and spectral peak picking.

Free response of a linear system with m lightly damped modes, per output i:

    y_i(τ) = s_i + Σ_j e^{-σ_j τ} (a_ij cos ω_j τ + b_ij sin ω_j τ),   τ ≥ 0 (s),

linear in (s_i, a_ij, b_ij), nonlinear in (ω_j rad/s, σ_j 1/s). Variable projection: the
linear coefficients are solved by least squares inside the residual, so the optimiser only
sees 2m parameters. Used for start values, the release window and the coupled-mode
candidate; the physical fits are in `ident.diagnose.fitting`. No I/O here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.optimize
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


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
