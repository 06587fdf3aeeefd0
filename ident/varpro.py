"""Continuous-time output-error fit by variable projection (pure numpy/scipy).

Model (see `ident.modal`): y_j(t) = o_j + U·Σ_c θ_jc φ_c(t; t_r, σ, ω) + e_j(t), with e white.
The nonlinear parameters p = (t_r, σ_1 … σ_m, ω_1 … ω_m) (t_r only for a step input) are
iterated on by `scipy.optimize.least_squares`; for each p the linear ones (o_j, θ_j, under
the linear structural constraints θ_j = θ_p + N β_j) are the least-squares solution, so the
cost is the projected residual ‖P⊥(p) (y - U Φ θ_p)‖² (Golub & Pereyra). Outputs are
weighted by 1/σ_j (their noise std), which makes this the maximum-likelihood estimate for
independent white output noise, i.e. the prediction-error estimate with noise model H = 1.

With the initial state estimated (`Problem.initial_velocity`, a flicked cart: let go moving at a
known release t_r, as MATLAB pem's InitialState='estimate'), each output also gets the free
response of every mode from zero position and unit velocity at t_r, q_i(τ) = e^{-σ_i τ}
sin(ω_i τ)/ω_i (the basis's own state-2 columns), with free coefficients v_ij (m/s): the
velocities of the modes at the release. Those columns span what the s-terms c1_i of the
numerator do on a free response, so the two cannot be told apart from the data; the step's
c1_i are then set to 0 and the initial velocities carry them. The release is not iterated on
(a free trajectory can be started at any of its points): `fixed_release_s` is required, and
the samples before it (the hand's, which no model here describes) carry no cost.

The Jacobian is taken by finite differences of the projected residual in these continuous
parameters (at most 1 + 2m columns); it is well conditioned at any sampling rate because
nothing here is a discrete polynomial coefficient. Covariance: s²(JᵀJ)⁻¹ with J the
central-difference Jacobian at the optimum (the exact profile Jacobian, so these are the
marginal covariances of p with the linear parameters estimated).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ident import modal

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Problem:
    """Arrays of one fit. `u` is used only when `step` is False (general-input basis)."""

    t: FloatArray
    y: FloatArray
    weights: FloatArray
    amplitude: float
    step: bool
    u: FloatArray
    ts: float
    relative_degree: tuple[int, ...]
    dc_gain: tuple[float | None, ...]
    fit_offset: bool = True
    fixed_release_s: float | None = None
    initial_velocity: bool = False


@dataclass(frozen=True)
class Solution:
    """Nonlinear parameters, linear coefficients and the fit's numerical facts."""

    release_time_s: float
    sigma: FloatArray
    omega: FloatArray
    theta: FloatArray          # (n_out, 1 + 2m): D, c0_1, c1_1, … per unit input
    offset: FloatArray         # (n_out,)
    residuals: FloatArray      # (N, n_out), unweighted, m
    covariance: FloatArray     # of the free nonlinear parameters
    free_release: bool
    cost: float
    nfev: int
    success: bool
    message: str
    velocity: FloatArray | None = None   # (n_out, m) m/s per mode at the release (initial state estimated)


def _split(problem: Problem, p: FloatArray) -> tuple[float, FloatArray, FloatArray]:
    if problem.step and problem.fixed_release_s is None:
        t_r, rest = float(p[0]), p[1:]
    else:
        t_r, rest = (problem.fixed_release_s or 0.0), p
    m = len(rest) // 2
    return t_r, rest[:m], rest[m:]


def basis(problem: Problem, t_r: float, sigma: FloatArray, omega: FloatArray) -> FloatArray:
    """Basis responses for the problem's input, scaled to its amplitude, (N, 1 + 2m)."""
    if problem.step:
        return problem.amplitude * modal.step_basis(problem.t, t_r, sigma, omega)
    return modal.input_basis(problem.u, problem.ts, sigma, omega)


def solve_linear(problem: Problem, t_r: float, sigma: FloatArray,
                 omega: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """(theta (n_out, 1+2m), offset (n_out,), residuals (N, n_out)) for fixed modes."""
    theta, offset, residuals, _ = solve_linear_state(problem, t_r, sigma, omega)
    return theta, offset, residuals


def solve_linear_state(problem: Problem, t_r: float, sigma: FloatArray, omega: FloatArray
                       ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray | None]:
    """`solve_linear` and the initial velocities (n_out, m) m/s (None unless estimated)."""
    phi = basis(problem, t_r, sigma, omega)
    n, n_out = problem.y.shape
    size = phi.shape[1]
    m = len(sigma)
    free_response = modal.step_basis(problem.t, t_r, sigma, omega)[:, 2::2] if problem.initial_velocity else None
    theta = np.zeros((n_out, size))
    offset = np.zeros(n_out)
    velocity = np.zeros((n_out, m)) if problem.initial_velocity else None
    residuals = np.empty((n, n_out))
    counted = (problem.t >= t_r) if problem.initial_velocity else np.ones(n, dtype=bool)
    for j in range(n_out):
        rows, rhs = modal.constraint_rows(sigma, omega, problem.relative_degree[j], problem.dc_gain[j])
        if problem.initial_velocity:   # the s-terms are the initial velocities' (module docstring)
            rows = np.vstack([rows, np.eye(size)[2::2]])
            rhs = np.concatenate([rhs, np.zeros(m)])
        particular, null = modal.constrained_parametrisation(rows, rhs, size)
        target = problem.y[:, j] - phi @ particular
        design = phi @ null
        if free_response is not None:
            design = np.column_stack([design, free_response])
        if problem.fit_offset:
            design = np.column_stack([np.ones(n), design])
        design, target = design * counted[:, None], target * counted
        coef = _least_squares_small(design, target)
        residuals[:, j] = target - design @ coef
        beta = coef[1:] if problem.fit_offset else coef
        offset[j] = coef[0] if problem.fit_offset else 0.0
        if velocity is not None:
            velocity[j], beta = beta[beta.size - m:], beta[:beta.size - m]
        theta[j] = particular + null @ beta
    return theta, offset, residuals, velocity


def _least_squares_small(design: FloatArray, target: FloatArray) -> FloatArray:
    """argmin ‖design c - target‖ for a tall, thin design (N × k, k ≤ ~8): normal equations
    on unit-norm columns (condition number squared stays far below 1/eps here), falling back
    to an SVD solve when they are singular."""
    scale = np.linalg.norm(design, axis=0)
    scale[scale == 0.0] = 1.0
    scaled = design / scale
    gram = scaled.T @ scaled
    try:
        if np.linalg.cond(gram) > 1e12:
            raise np.linalg.LinAlgError("ill-conditioned")
        return np.asarray(np.linalg.solve(gram, scaled.T @ target) / scale)
    except np.linalg.LinAlgError:
        return np.asarray(np.linalg.lstsq(scaled, target, rcond=None)[0] / scale)


def n_linear_parameters(problem: Problem, sigma: FloatArray, omega: FloatArray) -> int:
    """Free linear parameters: numerator/feedthrough coefficients left by the constraints, offsets."""
    count = 0
    for j in range(problem.y.shape[1]):
        rows, _ = modal.constraint_rows(sigma, omega, problem.relative_degree[j], problem.dc_gain[j])
        if problem.initial_velocity:
            rows = np.vstack([rows, np.eye(1 + 2 * len(sigma))[2::2]])
            count += len(sigma)
        count += modal.constrained_parametrisation(rows, np.zeros(rows.shape[0]), 1 + 2 * len(sigma))[1].shape[1]
        count += 1 if problem.fit_offset else 0
    return count


def _weighted_residual(p: FloatArray, problem: Problem) -> FloatArray:
    t_r, sigma, omega = _split(problem, p)
    _, _, residuals = solve_linear(problem, t_r, sigma, omega)
    return np.asarray((residuals * problem.weights).ravel())


def central_jacobian(problem: Problem, p: FloatArray) -> FloatArray:
    """d(weighted residual)/dp by central differences, relative steps ~ eps^(1/3)."""
    steps = 6e-6 * np.maximum(np.abs(p), 1e-3)
    columns = []
    for k in range(len(p)):
        dp = np.zeros_like(p)
        dp[k] = steps[k]
        columns.append((_weighted_residual(p + dp, problem) - _weighted_residual(p - dp, problem))
                       / (2.0 * steps[k]))
    return np.column_stack(columns)


def fit(problem: Problem, release_s: float, sigma: FloatArray, omega: FloatArray,
        max_nfev: int = 200) -> Solution:
    """Refine (t_r, σ, ω) from the given start; linear parameters by projection."""
    from scipy.optimize import least_squares  # deferred: keeps `import ident` fast
    free_release = problem.step and problem.fixed_release_s is None
    start = np.concatenate([[release_s] if free_release else [], sigma, omega])
    m = len(sigma)
    t_lo, t_hi = float(problem.t[0]), float(problem.t[-1])
    lower = np.concatenate([[t_lo] if free_release else [], np.full(m, -0.2 * np.min(omega)),
                            np.full(m, 1e-3 * np.min(omega))])
    upper = np.concatenate([[t_hi] if free_release else [], np.full(m, np.inf), np.full(m, np.inf)])
    start = np.clip(start, lower + 1e-12, upper)
    result = least_squares(_weighted_residual, start, args=(problem,), bounds=(lower, upper),
                           method="trf", x_scale="jac", diff_step=1e-7, xtol=1e-12, ftol=1e-12,
                           gtol=1e-10, max_nfev=max_nfev)
    p = result.x
    t_r, sig, om = _split(problem, p)
    theta, offset, residuals, velocity = solve_linear_state(problem, t_r, sig, om)
    weighted = residuals * problem.weights
    dof = max(1, weighted.size - len(p) - n_linear_parameters(problem, sig, om))
    s2 = float(np.sum(weighted ** 2)) / dof
    jac = central_jacobian(problem, p)
    covariance = np.asarray(s2 * np.linalg.pinv(jac.T @ jac), dtype=np.float64)
    return Solution(t_r, sig, om, theta, offset, residuals, covariance, free_release,
                    float(result.cost), int(result.nfev), bool(result.success), str(result.message), velocity)
