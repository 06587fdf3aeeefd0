"""The onset of a release from a still hold: a piecewise-polynomial least-squares fit. Pure.

The hand lets go at t0; from rest, the cart's position is then
`x(t) = x0 + ½ a (t - t0)² + b (t - t0)³ + …` (spring force step; the cubic term carries
damping and the first change of the force). The threshold crossing comes 10–40 ms late, so
t0 is back-dated by least squares on the samples around the crossing with the piecewise model
`y(t) = x0 + Σ_k c_k max(t - t0, 0)^k`: linear in (x0, c_k) for a given t0, t0 found by a grid
search (coarse at the sample period, then fine). The hold samples before t0 pin x0; the
samples after pin the curvature. Used by `daq.detector`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt


@dataclass(frozen=True, slots=True)
class OnsetFit:
    t0_s: float
    accel_m_s2: float
    rms_m: float


def fit_onset(t: npt.NDArray[np.float64], y: npt.NDArray[np.float64], powers: Sequence[int],
              trigger_offset_s: float = 0.0, spring: tuple[float, float] | None = None,
              hand_motion: bool = False) -> OnsetFit | None:
    """Least-squares onset of `y = x0 + Σ c_k max(t - t0, 0)^k` (shapes (N,)).

    With `hand_motion` the hand's own smooth motion enters on both sides of t0, `v0 τ + h τ²`
    (τ = t - t0): a hand that holds a cart still trembles (7-12 Hz, tens of µm) and lets it go
    with the tremor's velocity, position and velocity continuous; only the acceleration jumps.
    A quadratic follows a tremor over a quarter of its cycle: the caller fits from that long
    before t0 (`daq.hold_dating.HAND_LOOKBACK_S`).

    t0 is searched on [t[0], t[-1]] by a grid at the median sample spacing, then refined on a
    grid 50× finer around the best point. Returns t0 (+ `trigger_offset_s`), `a = 2 c_2` and
    the residual RMS, or None when there are too few samples.

    With `spring` = (σ, ω) (1/s, rad/s) known (a release confirmed by its ringing) the motion
    after t0 is the spring's from rest instead of a polynomial: `y = x0 + a r1(τ) + b r2(τ)`,
    r1 the response to a constant force (`r1'' (0) = 1`), r2 to one that changes linearly
    (`daq.joined.hand_response` run forwards): over the 40-70 ms fitted, (ωτ)² reaches
    ~0.5 and τ², τ³ would date a release from a hold ~1 ms late at 1 kHz.
    """
    before = 3 if hand_motion else 1      # columns of the motion before t0: 1 (x0), τ, τ²
    if t.size < len(powers) + before + 2:
        return None
    step = float(np.median(np.diff(t)))
    if not step > 0:
        return None
    coarse = np.arange(t[0], t[-1], step)
    best = _best_onset(t, y, powers, coarse, spring, hand_motion)
    fine = np.linspace(best - step, best + step, 101)
    best = _best_onset(t, y, powers, fine, spring, hand_motion)
    coefs, rms = _solve_at(t, y, powers, np.array([best]), spring, hand_motion)
    span = float(t[-1] - t[0])
    if spring is not None:
        return OnsetFit(best + trigger_offset_s, float(coefs[0, before]) / span ** 2, float(rms[0]))
    accel = 2.0 * float(coefs[0, before + list(powers).index(2)]) / span ** 2
    return OnsetFit(best + trigger_offset_s, accel, float(rms[0]))


def _best_onset(t: npt.NDArray[np.float64], y: npt.NDArray[np.float64], powers: Sequence[int],
                candidates: npt.NDArray[np.float64], spring: tuple[float, float] | None,
                hand_motion: bool) -> float:
    _, rms = _solve_at(t, y, powers, candidates, spring, hand_motion)
    return float(candidates[int(np.argmin(rms))])


def _solve_at(t: npt.NDArray[np.float64], y: npt.NDArray[np.float64], powers: Sequence[int],
              candidates: npt.NDArray[np.float64], spring: tuple[float, float] | None = None,
              hand_motion: bool = False) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Batched linear least squares for every candidate t0: coefficients (G, H+P) and RMS (G,),
    H the columns before t0 (x0; with `hand_motion` also τ and τ²), P those after it.

    τ is scaled by the window span (τ/T) for conditioning: c_k(unscaled) = c_k / T^k.
    """
    span = float(t[-1] - t[0])
    signed = (t[None, :] - candidates[:, None]) / span                 # (G, N)
    tau = np.maximum(signed, 0.0)
    columns = [np.ones_like(tau)] + ([signed, signed ** 2] if hand_motion else [])
    if spring is None:
        columns += [tau ** p for p in powers]
    else:   # the spring's response from rest, τ in units of the span (so r1 ≈ τ²/2, r2 ≈ τ³/6)
        sigma, omega = spring[0] * span, spring[1] * span
        columns += _from_rest(tau, sigma, omega)
    design = np.stack(columns, axis=2)                                  # (G, N, H+P)
    design_t = design.transpose(0, 2, 1)                                # (G, H+P, N)
    normal = design_t @ design                                          # batched BLAS, not einsum
    rhs = design_t @ y                                                  # (G, H+P)
    ridge = 1e-12 * np.eye(normal.shape[1])
    coefs = np.asarray(np.linalg.solve(normal + ridge, rhs[..., None])[..., 0], dtype=np.float64)   # (G, H+P)
    residual = y[None, :] - (design @ coefs[..., None])[..., 0]
    rms: npt.NDArray[np.float64] = np.sqrt(np.mean(residual ** 2, axis=1))
    return coefs, rms


def _from_rest(tau: npt.NDArray[np.float64], sigma: float, omega: float) -> tuple[npt.NDArray[np.float64], ...]:
    """r1, r2 (shapes of `tau` ≥ 0): x'' + 2σx' + (σ²+ω²)x = 1 (resp. τ) from rest at τ = 0."""
    om2 = sigma ** 2 + omega ** 2
    env = np.exp(-sigma * tau)
    cos, sin = np.cos(omega * tau), np.sin(omega * tau)
    r1 = (1.0 - env * (cos + sigma / omega * sin)) / om2
    # particular τ/Ω² - 2σ/Ω⁴; homogeneous chosen for r2(0) = r2'(0) = 0
    a = 2.0 * sigma / om2 ** 2
    b = (2.0 * sigma ** 2 / om2 ** 2 - 1.0 / om2) / omega
    r2 = tau / om2 - 2.0 * sigma / om2 ** 2 + env * (a * cos + b * sin)
    return r1, r2
