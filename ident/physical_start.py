"""PEM's physical start: the modes of the carts' physical model that explains a free response.

The subspace start (`ident.subspace`) can hand PEM any poles, stable or not. This start is
always the modes of a real cart or a real chain, built by the one physics (`ident.physics`):

1. the spectral peaks ω_j (rad/s) of the free response y (N, n_out) after the release
   (`ident.physics.spectral_peaks`) and one decay σ (1/s) common to the modes (exact for
   dampers proportional to the masses, the lab's usual case): the σ whose modal basis
   (`ident.modal.project`, linear least squares) leaves the least residual, by a bounded
   1-D search on log σ, which also gives the complex amplitude of every output per mode
   (a full modal fit would cost as much as PEM itself);
2. one mode per cart, or a single output: each mode is a `SingleCart` with
   wn_j = √(σ_j² + ω_j²), ζ_j = σ_j / wn_j (ζ floored at `MIN_ZETA`: a start is stable);
3. two modes seen by two outputs: the mode shapes r_j = Re(a_2j / a_1j) and the undamped
   frequencies give the mass-normalised chain (`ident.physics.chain.physical_from_modes`,
   clipped to positive springs and dampers), i.e. a `TwoCartChain` with m1 = 1;
4. the start is that model's modes (`modes_of` its state matrix): σ = ζ wn, ω = wn √(1 - ζ²).

Pure numerics on arrays; no I/O. Start values only: PEM refines them.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from ident.modal import project
from ident.physics import Mode, SingleCart, TwoCartChain, spectral_peaks
from ident.physics.chain import physical_from_modes

FloatArray = NDArray[np.float64]

#: Smallest damping ratio of a start (a start on the stability boundary has no decay to fit).
MIN_ZETA = 1e-3
#: Samples the decay search uses (about): every k-th sample, unfiltered. The modal basis is
#: evaluated at the kept instants, so nothing is approximated, as long as the fastest mode
#: stays below the kept samples' Nyquist frequency (k ≤ 0.8 π / (ω_max Ts)).
SEARCH_SAMPLES = 1000


def physical_start(y: FloatArray, ts: float, n_modes: int,
                   peaks: FloatArray | None = None) -> tuple[FloatArray, FloatArray] | None:
    """(σ (m,), ω (m,)) ascending in ω, of the physical model fitted to the free response
    `y` (N, n_out) sampled every `ts` s; None when the record shows fewer than `n_modes`
    peaks or the modal fit fails. `peaks` (rad/s): the record's spectral peaks when the
    caller has them already (`spectral_peaks(y, ts, n_modes, fill=False)`)."""
    y2 = y.reshape(len(y), -1)
    if peaks is None:
        peaks = spectral_peaks(y2, ts, n_modes, fill=False)
    if peaks.size < n_modes:
        return None
    # every k-th sample: the search needs the envelope and the shapes, not every sample
    k = max(1, min(len(y2) // SEARCH_SAMPLES, int(0.8 * np.pi / (float(peaks.max()) * ts))))
    tau = ts * np.arange(0, len(y2), k, dtype=np.float64)
    try:
        sigma, amplitudes = _common_decay(tau, y2[::k], peaks)
    except (ValueError, np.linalg.LinAlgError):
        return None
    decays = np.full(n_modes, sigma)
    if n_modes == 2 and y2.shape[1] == 2 and np.all(np.abs(amplitudes[0]) > 0.0):
        modes = _chain(peaks, decays, amplitudes).modes()
    else:
        modes = [_cart(float(w), float(s)).modes()[0] for w, s in zip(peaks, decays, strict=True)]
    return _poles(modes)


def _common_decay(tau: FloatArray, y: FloatArray, freqs: FloatArray) -> tuple[float, NDArray[np.complex128]]:
    """The decay σ (1/s) shared by modes at `freqs` that best explains `y` (N, n_out), on
    ζ = σ/ω_min in [1e-4, 0.5], and the amplitudes a_ij - i b_ij (n_out, m) at that σ."""
    def cost(log_sigma: float) -> float:
        resid = project(tau, y, freqs, np.full(freqs.size, np.exp(log_sigma)))[1]
        return float(np.sum(resid * resid))

    low = float(np.log(1e-4 * freqs.min()))
    high = float(np.log(0.5 * freqs.min()))
    grid = np.linspace(low, high, 9)
    best = int(np.argmin([cost(g) for g in grid]))
    log_sigma = _golden(cost, grid[max(best - 1, 0)], grid[min(best + 1, grid.size - 1)])
    coef = project(tau, y, freqs, np.full(freqs.size, np.exp(log_sigma)))[0]
    return float(np.exp(log_sigma)), np.asarray(coef[1::2].T - 1j * coef[2::2].T, dtype=np.complex128)


def _golden(f: Callable[[float], float], a: float, b: float, iterations: int = 14) -> float:
    """Minimiser of a unimodal `f` on [a, b] by golden-section search (bracket × 0.618 a step)."""
    ratio = (np.sqrt(5.0) - 1.0) / 2.0
    c, d = b - ratio * (b - a), a + ratio * (b - a)
    fc, fd = f(c), f(d)
    for _ in range(iterations):
        if fc < fd:
            b, d, fd = d, c, fc
            c = b - ratio * (b - a)
            fc = f(c)
        else:
            a, c, fc = c, d, fd
            d = a + ratio * (b - a)
            fd = f(d)
    return 0.5 * (a + b)


def carts_at_peaks(peaks: FloatArray, zeta: float) -> tuple[FloatArray, FloatArray]:
    """(σ, ω) of one `SingleCart` per damped frequency in `peaks` (rad/s) with damping `zeta`:
    wn = ω_p / √(1 - ζ²), so that the cart rings at the peak."""
    wn = np.asarray(peaks, dtype=np.float64) / np.sqrt(1.0 - zeta * zeta)
    return _poles([SingleCart.from_modal(float(w), zeta).modes()[0] for w in wn])


def _cart(omega: float, sigma: float) -> SingleCart:
    wn = float(np.hypot(sigma, omega))
    return SingleCart.from_modal(wn, max(sigma / wn, MIN_ZETA))


def _chain(freqs: FloatArray, decays: FloatArray, amplitudes: NDArray[np.complex128]) -> TwoCartChain:
    """The chain (m1 = 1 kg) whose modes have these frequencies, decays and shapes."""
    undamped = np.hypot(freqs, decays)
    shapes = np.real(amplitudes[1] / amplitudes[0])
    a1, b1, b2, a2, g1, g2 = physical_from_modes(undamped, np.maximum(decays, MIN_ZETA * undamped), shapes)
    m2 = b1 / b2                                   # k2 = b1·m1 = b2·m2
    return TwoCartChain(m1=1.0, m2=m2, k1=a1, k2=b1, k3=a2 * m2, c1=g1, c2=g2 * m2)


def _poles(modes: list[Mode]) -> tuple[FloatArray, FloatArray]:
    poles = sorted((m.pole for m in modes), key=lambda p: p.imag)
    return (np.array([-p.real for p in poles], dtype=np.float64),
            np.array([p.imag for p in poles], dtype=np.float64))
