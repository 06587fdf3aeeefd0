"""What the linear baseline gets wrong: residual and envelope evidence, and start values.

Computed on the work samples of the fitted window (`tau` (N,) s, `y` and the baseline
prediction `y_hat` (N, carts) m) for the main (largest-motion) output:

- whiteness: fraction of residual autocorrelations at lags 1..20 outside ±2.58/√N;
- residual spectrum: its peak, relative to the baseline frequency; a second frequency is a
  residual peak away from harmonics of the baseline modes;
- peak envelope: half-cycle extrema A_j of |y - rest| regressed as a constant ratio
  (A_{j+1} = ρ A_j), a constant step (A_{j+1} = A_j - δ), amplitude-dependent
  (A_{j+1} = A_j - β A_j²) and the Coulomb+viscous law A_{j+1} = ρ A_j - δ with
  δ = 2 f / wn² (gives the friction start value f = δ wn²/2);
- frequency drift: (π / half-period)² against the half-cycle amplitude², slope = 3κ/4 for a
  cubic spring κ (Duffing, first order) -> the cubic start value;
- rest: how long the run ends motionless and how far from the fitted rest position;
- the measurement lattice (`lattice.find_lattice`).
No I/O here.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ident.diagnose.lattice import Lattice
from ident.physics.measures import noise_std as _noise_std
from ident.physics.measures import spectral_peaks, spectrum

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class EvidenceResult:
    residual_rms_m: float
    noise_std_m: float
    whiteness_fraction_outside: float
    residual_is_white: bool
    residual_peak_hz: float
    residual_peak_to_baseline_ratio: float
    envelope_shape: str
    envelope_peaks: int
    envelope_step_m: float
    envelope_ratio: float
    drag_beta_per_m: float
    frequency_drift_per_m2: float
    cubic_start_per_m2_s2: float
    rest_offset_m: float
    stuck_for_s: float
    lattice: Lattice | None
    second_frequency_hz: float | None
    extrema: FloatArray       # (K, 2): time (s, from window start) and |y - rest| (m)
    #: lattices too faint to be named from the positions alone, for the model to weigh
    lattice_proposals: tuple[Lattice, ...] = ()


def noise_std(residual: FloatArray) -> float:
    """White-noise scale (m) of a residual: the one estimate of `ident.physics.measures`."""
    return float(_noise_std(residual)[0])


def collect(tau: FloatArray, y: FloatArray, y_hat: FloatArray, rest: FloatArray,
            wn_modes: FloatArray, lattice: Lattice | None) -> EvidenceResult:
    """Evidence from the baseline fit (see module docstring)."""
    main = int(np.argmax(np.ptp(y, axis=0)))
    dt = float(tau[1] - tau[0])
    res = y[:, main] - y_hat[:, main]
    sigma = max(noise_std(res), 1e-12)
    n = res.size
    r0 = res - res.mean()
    acf = np.array([np.dot(r0[:-k], r0[k:]) for k in range(1, 21)]) / max(float(np.dot(r0, r0)), 1e-300)
    outside = float(np.mean(np.abs(acf) > 2.58 / np.sqrt(n)))
    wn = float(wn_modes[0])
    peak = float(spectral_peaks(res[:, None], dt, 1)[0])
    dev = y[:, main] - rest[main]
    extrema = _half_cycle_extrema(tau, dev, sigma)
    env = _envelope(extrema[:, 1])
    drift, cubic0 = _frequency_drift(tau, dev, sigma, wn)
    stuck = _stuck_for(y[:, main], sigma, lattice)
    second = _second_frequency(res, dt, wn_modes)
    return EvidenceResult(
        residual_rms_m=float(np.sqrt(np.mean(res ** 2))), noise_std_m=sigma,
        whiteness_fraction_outside=outside, residual_is_white=outside <= 0.1,
        residual_peak_hz=peak / (2 * np.pi), residual_peak_to_baseline_ratio=peak / wn,
        envelope_shape=env[0], envelope_peaks=int(extrema.shape[0]), envelope_step_m=env[1],
        envelope_ratio=env[2], drag_beta_per_m=env[3], frequency_drift_per_m2=drift,
        cubic_start_per_m2_s2=cubic0, rest_offset_m=float(y[-1, main] - rest[main]),
        stuck_for_s=stuck * dt, lattice=lattice, second_frequency_hz=second, extrema=extrema)


def _half_cycle_extrema(tau: FloatArray, dev: FloatArray, sigma: float) -> FloatArray:
    """(time, |dev|) of the largest |dev| between consecutive sign changes of dev."""
    sign = np.sign(dev)
    cross = np.flatnonzero(sign[1:] * sign[:-1] < 0) + 1
    bounds = np.concatenate([[0], cross, [dev.size]])
    out = []
    floor = max(6.0 * sigma, 0.01 * float(np.max(np.abs(dev))))
    for a, b in itertools.pairwise(bounds):
        if b - a < 2:
            continue
        k = a + int(np.argmax(np.abs(dev[a:b])))
        if abs(dev[k]) > floor and 0 < k < dev.size - 1:
            out.append((tau[k], abs(dev[k])))
    return np.asarray(out, dtype=np.float64).reshape(-1, 2)


def _envelope(amp: FloatArray) -> tuple[str, float, float, float]:
    """(shape, δ m, ρ, β 1/m) from successive half-cycle extrema."""
    if amp.size < 4:
        return "undetermined", 0.0, 1.0, 0.0
    a, b = amp[:-1], amp[1:]
    rho = float(np.dot(a, b) / np.dot(a, a))
    sse_ratio = float(np.sum((b - rho * a) ** 2))
    step = float(np.mean(a - b))
    sse_step = float(np.sum((b - (a - step)) ** 2))
    beta = float(np.dot(a - b, a ** 2) / np.dot(a ** 2, a ** 2))
    sse_drag = float(np.sum((b - (a - beta * a ** 2)) ** 2))
    design = np.column_stack([a, -np.ones_like(a)])
    rho2, delta = np.linalg.lstsq(design, b, rcond=None)[0]
    shapes = {"constant_ratio": sse_ratio, "constant_step": sse_step, "amplitude_dependent": sse_drag}
    shape = min(shapes, key=lambda k: shapes[k])
    return shape, float(max(delta, 0.0)), float(min(rho2, 1.0)), max(beta, 0.0)


def _frequency_drift(tau: FloatArray, dev: FloatArray, sigma: float, wn: float) -> tuple[float, float]:
    """Slope of (ω/wn) against A² (1/m²) and the cubic start κ = (4/3) d(ω²)/d(A²)."""
    sign = np.sign(dev)
    idx = np.flatnonzero(sign[1:] * sign[:-1] < 0)
    if idx.size < 5:
        return 0.0, 0.0
    t0 = tau[idx] - dev[idx] * (tau[idx + 1] - tau[idx]) / (dev[idx + 1] - dev[idx])
    half = np.diff(t0)
    amps = np.array([np.max(np.abs(dev[a:b + 1])) for a, b in itertools.pairwise(idx)])
    keep = (amps > 10 * sigma) & (half > 0.3 * np.pi / wn) & (half < 3 * np.pi / wn)
    if keep.sum() < 4 or np.ptp(amps[keep] ** 2) <= 0:
        return 0.0, 0.0
    w2 = (np.pi / half[keep]) ** 2
    slope, _ = np.polyfit(amps[keep] ** 2, w2, 1)
    return float(slope / (2 * wn * wn)), float(4.0 * slope / 3.0)


def _stuck_for(y: FloatArray, sigma: float, lattice: Lattice | None) -> int:
    """Number of final samples within the noise (or one quantum) of the last value."""
    tol = 4.0 * sigma + (lattice.quantum_m if lattice is not None else 0.0)
    away = np.flatnonzero(np.abs(y - np.median(y[-5:])) > tol)
    return int(y.size - 1 - away[-1]) if away.size else int(y.size)


def _second_frequency(res: FloatArray, dt: float, wn_modes: FloatArray) -> float | None:
    """A residual spectral peak (Hz) ≥ 10× the median level, away from baseline harmonics."""
    w, p = spectrum(res[:, None], dt)
    harmonics = np.concatenate([k * wn_modes for k in range(1, 6)])
    near = np.any(np.abs(w[:, None] - harmonics[None, :]) < 0.12 * harmonics[None, :], axis=1)
    allowed = (~near) & (w > 0.3 * float(wn_modes[0]))
    if not np.any(allowed):
        return None
    i = int(np.argmax(np.where(allowed, p, 0.0)))
    if p[i] < 10.0 * float(np.median(p[w > 0])):
        return None
    return float(w[i] / (2 * np.pi))
