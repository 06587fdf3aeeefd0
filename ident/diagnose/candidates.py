"""The fits of `diagnose`: the linear baseline and every extension, on the same samples.

`Problem` holds the work samples of the window (τ from the window start, y, the training
mask: even work samples). The baseline starts from a modal fit (`starts`); each extension
starts from the baseline and its effect's evidence (envelope step -> friction, envelope
curvature -> drag, frequency drift -> cubic, residual peak -> coupled mode, the measured
lattice -> quantization), within physically sensible bounds. No I/O here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ident.diagnose import starts
from ident.diagnose.evidence import EvidenceResult
from ident.diagnose.fitting import FitResult, evaluate, fit
from ident.diagnose.modal import fit_modes, project, spectral_peaks
from ident.diagnose.models import EFFECTS, ModelSpec

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Problem:
    """Work samples of the window: `tau` (N,) s, `y` (N, carts) m, `dt` s, `train` (N,)."""

    tau: FloatArray
    y: FloatArray
    dt: float
    train: NDArray[np.bool_]
    carts: int
    amplitude: float


def fit_baseline(prob: Problem, fixed: dict[int, float]) -> FitResult:
    peaks = spectral_peaks(prob.y, prob.dt, prob.carts)
    modal = fit_modes(prob.tau, prob.y, peaks)
    spec = ModelSpec("none", prob.carts, fixed)
    best: FitResult | None = None
    for theta0 in starts.linear_starts(modal, prob.carts):
        lower, upper = starts.linear_bounds(theta0, prob.carts)
        typical = starts.linear_typical(theta0, prob.carts, prob.amplitude)
        result = fit(spec, theta0, lower, upper, typical, prob.dt, prob.y, prob.train, max_nfev=80)
        if best is None or result.sse_train < best.sse_train:
            best = result
    assert best is not None
    return best


def fit_candidates(prob: Problem, base: FitResult, ev: EvidenceResult, fixed: dict[int, float],
                    wn_modes: FloatArray) -> dict[str, FitResult]:
    lower0, upper0 = starts.linear_bounds(base.theta, prob.carts)
    typical0 = starts.linear_typical(base.theta, prob.carts, prob.amplitude)
    wn = float(wn_modes[0])
    out: dict[str, FitResult] = {}
    for effect in EFFECTS:
        spec = ModelSpec(effect, prob.carts, fixed)
        if effect == "quantization":
            if ev.lattice is not None:
                out[effect] = _fit_staircase(spec, prob, base, ev)
            continue
        extra0, lo, hi, typ = _effect_start(effect, prob, base, ev, wn_modes, wn)
        lower, upper = np.concatenate([lower0, lo]), np.concatenate([upper0, hi])
        typical = np.concatenate([typical0, typ])
        theta0 = np.concatenate([base.theta, extra0])
        if effect == "coulomb_friction":
            out[effect] = _fit_friction(spec, prob, theta0, lower, upper, typical, ev)
        else:
            out[effect] = fit(spec, theta0, lower, upper, typical, prob.dt, prob.y, prob.train,
                              max_nfev=40)
    return out


def _fit_friction(spec: ModelSpec, prob: Problem, theta0: FloatArray, lower: FloatArray,
                     upper: FloatArray, typical: FloatArray, ev: EvidenceResult) -> FitResult:
    """Friction fits in two stages, from two starts.

    The linear fit has put the extra loss into viscous damping, and where a frictional cart
    stops depends discontinuously on the parameters; so each start is first fitted on the
    large-amplitude part of the run (until the half-cycle peaks fall below 30 % of the
    first), where the cost is smooth, then on every training sample. Starts: the baseline
    damping and the damping implied by the envelope ratio (one cart).
    """
    n_cut = _large_amplitude_samples(prob, ev)
    candidates = [theta0]
    if prob.carts == 1 and ev.envelope_ratio < 1.0:
        half_period = np.pi / theta0[0]
        zeta_env = -np.log(max(ev.envelope_ratio, 1e-3)) / half_period / theta0[0]
        alt = theta0.copy()
        alt[1] = float(np.clip(zeta_env, 1e-4, 0.9 * theta0[1]))
        candidates.append(alt)
    best: FitResult | None = None
    for start in candidates:
        first = fit(spec, start, lower, upper, typical, prob.dt, prob.y[:n_cut], prob.train[:n_cut])
        result = fit(spec, first.theta, lower, upper, typical, prob.dt, prob.y, prob.train)
        if best is None or result.sse_train < best.sse_train:
            best = result
    assert best is not None
    return best


def _large_amplitude_samples(prob: Problem, ev: EvidenceResult) -> int:
    """Work samples up to a quarter period after the last peak above 30 % of the first."""
    amps = ev.extrema[:, 1]
    n = prob.tau.size
    if amps.size < 4:
        return n
    last = float(ev.extrema[np.flatnonzero(amps >= 0.3 * amps[0])[-1], 0])
    quarter = 0.25 * (ev.extrema[-1, 0] - ev.extrema[0, 0]) / max(amps.size - 1, 1) * 2
    return int(min(n, max(np.searchsorted(prob.tau, last + quarter), 40)))


BLURS = (0.01, 0.03, 0.06, 0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.45)


def _fit_staircase(spec: ModelSpec, prob: Problem, base: FitResult, ev: EvidenceResult) -> FitResult:
    """The linear model read through the measured lattice (q and offset from the data).

    The linear parameters are refitted through the smoothed staircase at decreasing blur
    (0.3, 0.15, 0.08 quanta; each from the previous), so that they are not the baseline's,
    tuned to the training samples' rounding errors; then the blur is chosen on a grid.
    """
    assert ev.lattice is not None
    q, off = ev.lattice.quantum_m, ev.lattice.offset_m
    q_std = q * 1e-3 / max(ev.lattice.levels, 1)
    n = base.theta.size
    lower, upper = starts.linear_bounds(base.theta, prob.carts)
    typical = starts.linear_typical(base.theta, prob.carts, prob.amplitude)
    lower, upper = np.concatenate([lower, np.full(3, -np.inf)]), np.concatenate([upper, np.full(3, np.inf)])
    typical = np.concatenate([typical, [q, q, 0.1]])
    theta = np.concatenate([base.theta, [q, off, 0.3]])
    for blur in (0.3, 0.15, 0.08):
        fixed = {**spec.fixed, n: q, n + 1: off, n + 2: blur}
        staged = ModelSpec(spec.effect, spec.carts, fixed)
        theta = fit(staged, theta, lower, upper, typical, prob.dt, prob.y, prob.train, max_nfev=20).theta
    best: FitResult | None = None
    for lin in (theta[:n], base.theta):
        for blur in BLURS:
            std = np.concatenate([base.std, [q_std, 0.0, 0.0]])
            result = evaluate(spec, np.concatenate([lin, [q, off, blur]]), prob.dt, prob.y, prob.train, std)
            if best is None or result.sse_train < best.sse_train:
                best = result
    assert best is not None
    return best


def _effect_start(effect: str, prob: Problem, base: FitResult, ev: EvidenceResult,
                  wn_modes: FloatArray, wn: float) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """(start, lower, upper, typical) of the effect parameters."""
    c, amp = prob.carts, prob.amplitude
    # bounds: effects no larger than stopping the cart within a cycle or shifting the
    # frequency by ~25 % at the largest amplitude (beyond that the model is not linear-ish)
    if effect == "coulomb_friction":
        f_max = wn * wn * amp
        f0 = float(np.clip(0.5 * ev.envelope_step_m * wn * wn, 1e-3 * f_max, 0.5 * f_max))
        return (np.full(c, f0), np.zeros(c), np.full(c, f_max), np.full(c, 0.01 * f_max))
    if effect == "quadratic_drag":
        d_max = 10.0 / amp
        d0 = float(np.clip(0.75 * ev.drag_beta_per_m, 0.01 / amp, 0.5 * d_max))
        return np.array([d0]), np.zeros(1), np.array([d_max]), np.array([0.1 / amp])
    if effect == "cubic_stiffness":
        k_max = 0.7 * wn * wn / (amp * amp)
        k0 = float(np.clip(ev.cubic_start_per_m2_s2, -0.5 * k_max, 0.5 * k_max))
        return (np.array([k0]), np.array([-k_max]), np.array([k_max]), np.array([0.01 * k_max]))
    # coupled_mode: the residual's strongest peak away from the baseline modes
    # a SECOND resonance: kept on its side of the baseline modes, at least 25 % away, so it
    # cannot turn into a beat with the main mode that mimics an amplitude-dependent envelope
    res = prob.y - base.prediction
    w3 = float(spectral_peaks(res, prob.dt, 1, exclude=wn_modes, exclude_rel=0.3)[0])
    s3 = 0.01 * w3
    coef, _ = project(prob.tau, res, np.array([w3]), np.array([s3]))
    a3, b3 = coef[1], coef[2]
    nyq_hz = 0.5 / prob.dt
    f_lo, f_hi = float(np.min(wn_modes)) / (2 * np.pi), float(np.max(wn_modes)) / (2 * np.pi)
    above = w3 / (2 * np.pi) > f_hi
    band = (1.25 * f_hi, 0.98 * nyq_hz) if above else (0.05, 0.8 * f_lo)
    start = np.concatenate([[float(np.clip(w3 / (2 * np.pi), *band)),
                             min(s3, 0.15 * 2 * np.pi * band[0])], a3, b3])
    # a resonance, not a transient: damping ratio at most 0.3 (σ ≤ 0.3·2π f at the lowest f)
    lower = np.concatenate([[band[0], 0.0], np.full(2 * c, -np.inf)])
    upper = np.concatenate([[band[1], 0.3 * 2 * np.pi * band[0]], np.full(2 * c, np.inf)])
    typical = np.concatenate([[w3 / (2 * np.pi), 0.1 * w3], np.full(2 * c, 0.01 * amp)])
    return start, lower, upper, typical
