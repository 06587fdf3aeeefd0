"""Start values and bounds of every model, from the modal fit and the evidence.

Linear start (one mode per cart, `modal.fit_modes`): wn = √(ω_d² + σ²), ζ = σ/wn; the
state at τ = 0 from the modal coefficients, x0 = s + a, v0 = -σ a + ω_d b; two carts via
`chain.physical_from_modes` with the mode shapes r_j = Re(c_2j c̄_1j)/|c_1j|².
Effect starts come from the evidence (envelope step -> friction, envelope curvature ->
drag, frequency drift -> cubic, residual spectrum -> coupled mode). No I/O here.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ident.modal import ModalFit
from ident.physics.chain import physical_from_modes

FloatArray = NDArray[np.float64]


def linear_start(fit: ModalFit, carts: int) -> FloatArray:
    """Linear parameters | x0 | v0 | rest from a modal fit with `carts` modes."""
    wd, sig = fit.freqs, fit.decays
    wn = np.hypot(wd, sig)
    a = fit.amplitudes.real            # (n_out, m)
    b = -fit.amplitudes.imag
    x0 = fit.rest + a.sum(axis=1)
    v0 = (-sig[None, :] * a + wd[None, :] * b).sum(axis=1)
    if carts == 1:
        lin = np.array([wn[0], max(sig[0] / wn[0], 1e-4)])
    else:
        c = fit.amplitudes
        shapes = np.array([float(np.real(c[1, j] * np.conj(c[0, j])) / max(abs(c[0, j]) ** 2, 1e-30))
                           for j in range(2)])
        lin = physical_from_modes(wn, np.maximum(sig, 1e-4), shapes)
    return np.concatenate([lin, x0, v0, fit.rest])


def one_encoder_start(fit: ModalFit) -> FloatArray:
    """Two carts seen through cart 1 only: the symmetric chain with the fitted frequencies,
    whose mode shapes are r = x2/x1 = +1 (in phase) and -1; cart 2's state follows from the
    same modal amplitudes, x2 = Σ r_j x1_j; its rest is 0 (not observable: it only shifts
    x0_2)."""
    wn = np.sort(np.hypot(fit.freqs, fit.decays))
    order = np.argsort(np.hypot(fit.freqs, fit.decays))
    sig = np.maximum(fit.decays[order], 1e-4)
    wd = fit.freqs[order]
    a = fit.amplitudes[0, order].real
    b = -fit.amplitudes[0, order].imag
    r = np.array([1.0, -1.0])
    coupling = max(0.5 * (wn[1] ** 2 - wn[0] ** 2), 0.05 * wn[0] ** 2)
    g = float(2 * np.mean(sig))
    lin = np.array([wn[0] ** 2, coupling, coupling, wn[0] ** 2, g, g])
    x0 = np.array([fit.rest[0] + a.sum(), float(np.sum(r * a))])
    v1 = -sig * a + wd * b
    v0 = np.array([v1.sum(), float(np.sum(r * v1))])
    return np.concatenate([lin, x0, v0, [fit.rest[0], 0.0]])


def linear_starts(fit: ModalFit, carts: int) -> list[FloatArray]:
    """Start vectors to try: the modal mapping and, for two carts, a symmetric chain with
    the same two frequencies (a1 = a2 = wn1², b1 = b2 = (wn2² - wn1²)/2), which is always
    stable when the mode-shape mapping is not."""
    if carts == 2 and fit.amplitudes.shape[0] == 1:
        return [one_encoder_start(fit)]
    first = linear_start(fit, carts)
    if carts == 1:
        return [first]
    wn = np.sort(np.hypot(fit.freqs, fit.decays))
    sym = first.copy()
    coupling = max(0.5 * (wn[1] ** 2 - wn[0] ** 2), 0.05 * wn[0] ** 2)
    sym[:6] = [wn[0] ** 2, coupling, coupling, wn[0] ** 2, 2 * max(fit.decays.mean(), 1e-3),
               2 * max(fit.decays.mean(), 1e-3)]
    return [first, sym] if np.all(np.isfinite(first)) else [sym]


def linear_bounds(theta: FloatArray, carts: int) -> tuple[FloatArray, FloatArray]:
    """Bounds of the linear | x0 | v0 | rest block."""
    n_lin = 2 if carts == 1 else 6
    lower = np.full(n_lin + 3 * carts, -np.inf)
    upper = np.full(n_lin + 3 * carts, np.inf)
    if carts == 1:
        lower[:2] = [0.2 * theta[0], 0.0]
        upper[:2] = [5.0 * theta[0], 1.5]
    else:
        scale = float(np.max(theta[:4]))
        lower[:4] = 1e-4 * scale
        upper[:4] = 50.0 * scale
        lower[4:6] = 0.0
        upper[4:6] = 5.0 * np.sqrt(scale)
    return lower, upper


def linear_typical(theta: FloatArray, carts: int, amplitude: float) -> FloatArray:
    """Typical magnitudes for finite-difference steps."""
    n_lin = 2 if carts == 1 else 6
    wn = theta[0] if carts == 1 else float(np.sqrt(np.max(theta[:4])))
    lin = np.abs(theta[:n_lin]).copy()
    if carts == 1:
        lin[1] = max(lin[1], 0.01)
    else:
        lin[4:6] = np.maximum(lin[4:6], 0.01 * wn)
    return np.concatenate([lin, np.full(carts, amplitude), np.full(carts, amplitude * wn),
                           np.full(carts, amplitude)])
