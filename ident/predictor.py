"""The one-step-ahead predictor of a modal model in innovation form: arrays in, arrays out.

Discrete innovation form at the data's sample time Ts (zoh, with the fractional input delay
split over the sample interval):

    x[k+1] = Φ x[k] + Γ1 v[k-1] + Γ2 v[k] + K e[k],     y[k] = C x[k] + o + e[k],

v the input delayed by whole samples. The predictor is the same system driven by the
measured y: x̂[k+1] = F x̂[k] + Γ1 v[k-1] + Γ2 v[k] + K (y[k] - o), F = Φ - K C,
ŷ[k] = C x̂[k] + o. F is diagonalised once, so the predictor runs as n first-order complex
filters. Used by `Model.predict` and by the refinement in `ident.innovation`; it knows
nothing of either.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ident import modal
from ident.errors import IdentValueError

FloatArray = NDArray[np.float64]


def shift(x: FloatArray, samples: int) -> FloatArray:
    """x delayed by `samples` (advanced when negative), padded with the edge values."""
    if samples == 0:
        return x
    if samples > 0:
        return np.concatenate([np.full(min(samples, len(x)), x[0]), x[:-samples] if samples < len(x) else []])
    k = -samples
    return np.concatenate([x[k:], np.full(min(k, len(x)), x[-1])])


def discrete_inputs(a: FloatArray, b: FloatArray, ts: float, frac: float) -> tuple[FloatArray, FloatArray, FloatArray]:
    """(Φ, Γ1, Γ2) of x' = A x + B u held over a sample interval Ts whose input steps at the
    fraction `frac` of it: x[k+1] = Φ x[k] + Γ1 v[k-1] + Γ2 v[k] (A (n, n), B (n, 1))."""
    from scipy.linalg import expm  # deferred: keeps `import ident` fast
    n = a.shape[0]

    def phi_gamma(h: float) -> tuple[FloatArray, FloatArray]:
        aug = np.zeros((n + 1, n + 1))
        aug[:n, :n] = a * h
        aug[:n, n] = b[:, 0] * h
        e = expm(aug)
        return e[:n, :n], e[:n, n]

    phi, _ = phi_gamma(ts)
    phi_rest, gamma2 = phi_gamma((1.0 - frac) * ts)
    gamma1 = phi_rest @ phi_gamma(frac * ts)[1] if frac > 0 else np.zeros(n)
    return phi, gamma1, gamma2


def predict(sigma: FloatArray, omega: FloatArray, theta: FloatArray, offset: FloatArray, gain: FloatArray,
            u: FloatArray, y: FloatArray, ts: float, delay_s: float) -> FloatArray:
    """One-step predictions ŷ (N, n_out) of the innovation-form model (see the module docstring);
    `gain` is K (n, n_out), `delay_s` the input delay, `ts` the sample time (s)."""
    from scipy.signal import lfilter  # deferred: keeps `import ident` fast
    a, b, c, d = modal.state_space(sigma, omega, theta)
    if np.any(d):
        raise IdentValueError("relative degree", "≥ 1 (no feedthrough) for the predictor", "feedthrough")
    delay = delay_s / ts
    whole = int(np.floor(delay))
    frac = delay - whole
    v = shift(u, whole)
    phi, gamma1, gamma2 = discrete_inputs(a, b, ts, frac)
    f_mat = phi - gain @ c
    lam, vecs = np.linalg.eig(f_mat)
    vinv = np.linalg.inv(vecs)
    drive = (np.outer(shift(v, 1), vinv @ gamma1) + np.outer(v, vinv @ gamma2)
             + (y - offset) @ (vinv @ gain).T)
    states = np.column_stack([lfilter([0.0, 1.0], [1.0, -lam_i], drive[:, i]) for i, lam_i in enumerate(lam)])
    return np.asarray(np.real(states @ (c @ vecs).T) + offset)


__all__ = ["discrete_inputs", "predict", "shift"]
