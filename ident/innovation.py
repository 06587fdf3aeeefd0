"""Prediction-error refinement in innovation form (a noise model K), from an output-error fit.

Discrete innovation form at the data's sample time Ts (zoh, with the fractional release
delay split over the sample interval as in `ident.model`):

    x[k+1] = Φ x[k] + Γ1 v[k-1] + Γ2 v[k] + K e[k],     y[k] = C x[k] + o + e[k],

v the input delayed by whole samples. The one-step predictor is the same system driven by
the measured y: x̂[k+1] = F x̂[k] + Γ1 v[k-1] + Γ2 v[k] + K (y[k] - o), F = Φ - K C,
ŷ[k] = C x̂[k] + o, and the prediction errors ε = y - ŷ are minimised over all parameters
jointly: release time, σ_i, ω_i (the continuous modes), the free numerator coefficients β
(θ = θ_p + N β under the structural constraints), offsets o and the n × n_out gain K. F is
diagonalised once per evaluation, so the predictor runs as n first-order complex filters.
The start is the output-error fit with K = 0 (consistent for open-loop data whatever the
noise colour); coloured noise gets its model. With white noise the criterion is flat along
near pole–zero cancellations of the noise model 1 + C(zI - A)⁻¹K, so the refinement may stop
at `max_nfev` (reported in `Model.success`/`message`) with a small K and unchanged modes.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from ident import modal
from ident.comparison import fit_percent
from ident.data import IdData
from ident.errors import IdentValueError
from ident.model import ModeEstimate, Model
from ident.predictor import predict

if TYPE_CHECKING:
    from scipy.optimize import OptimizeResult

FloatArray = NDArray[np.float64]


class _Layout:
    """Where each parameter group sits in the flat vector p."""

    def __init__(self, model: Model, free_release: bool) -> None:
        self.m = len(model.sigma)
        self.n = 2 * self.m
        self.n_out = model.n_outputs
        self.free_release = free_release
        self.null_sizes: list[int] = []
        for j in range(self.n_out):
            rows, rhs = modal.constraint_rows(model.sigma, model.omega, model.relative_degree[j], None)
            self.null_sizes.append(modal.constrained_parametrisation(rows, rhs, 1 + self.n)[1].shape[1])

    def split(self, p: FloatArray
              ) -> tuple[float | None, FloatArray, FloatArray, list[FloatArray], FloatArray, FloatArray]:
        i = 0
        release = None
        if self.free_release:
            release, i = float(p[0]), 1
        sigma, omega = p[i:i + self.m], p[i + self.m:i + self.n]
        i += self.n
        betas = []
        for size in self.null_sizes:
            betas.append(p[i:i + size])
            i += size
        offset = p[i:i + self.n_out]
        i += self.n_out
        gain = p[i:i + self.n * self.n_out].reshape(self.n, self.n_out)
        return release, sigma, omega, betas, offset, gain


def _theta(sigma: FloatArray, omega: FloatArray, model: Model, betas: list[FloatArray]) -> FloatArray:
    rows_out = []
    for j, beta in enumerate(betas):
        rows, rhs = modal.constraint_rows(sigma, omega, model.relative_degree[j], None)
        particular, null = modal.constrained_parametrisation(rows, rhs, 1 + 2 * len(sigma))
        rows_out.append(particular + null @ beta)
    return np.array(rows_out)


def refine(model: Model, data: IdData, max_nfev: int = 100) -> Model:
    """Joint prediction-error fit with a noise model K, started from an output-error `model`."""
    from scipy.optimize import least_squares  # deferred: keeps `import ident` fast
    if not data.is_uniform():
        raise IdentValueError("time base", "uniform sampling for the innovation-form predictor", "non-uniform")
    ts = data.sample_time()
    free_release = model.release_time_s is not None
    layout = _Layout(model, free_release)
    step_time = model.release_time_s - model.input_delay_s if free_release else 0.0  # type: ignore[operator]
    betas0 = []
    for j in range(model.n_outputs):
        rows, rhs = modal.constraint_rows(model.sigma, model.omega, model.relative_degree[j], None)
        particular, null = modal.constrained_parametrisation(rows, rhs, 1 + model.order)
        betas0.append(np.linalg.lstsq(null, model.theta[j] - particular, rcond=None)[0])
    p0 = np.concatenate([[model.release_time_s] if free_release else [], model.sigma, model.omega,
                         *betas0, model.offset, np.zeros(model.order * model.n_outputs)])
    weights = 1.0 / model.noise_std

    def residual(p: FloatArray) -> FloatArray:
        release, sigma, omega, betas, offset, gain = layout.split(p)
        delay = (release - step_time) if release is not None else model.input_delay_s
        theta = _theta(sigma, omega, model, betas)
        y_hat = predict(sigma, omega, theta, offset, gain, data.u, data.y, ts, delay)
        return np.asarray(((data.y - y_hat) * weights).ravel())

    # tolerances far below the statistical resolution only make the trust region cycle
    result = least_squares(residual, p0, method="lm", x_scale="jac", diff_step=1e-7, ftol=1e-6,
                           xtol=1e-8, max_nfev=max_nfev)
    release, sigma, omega, betas, offset, gain = layout.split(result.x)
    theta = _theta(sigma, omega, model, betas)
    refined = replace(model, sigma=sigma, omega=omega, theta=theta, offset=offset, K=gain,
                      release_time_s=release, input_delay_s=(release - step_time) if release is not None
                      else model.input_delay_s, method=model.method.replace("pem-oe", "pem-innovation"),
                      nfev=model.nfev + int(result.nfev), success=bool(result.success),
                      message=str(result.message))
    return _with_statistics(refined, data, result, layout)


def _with_statistics(model: Model, data: IdData, result: OptimizeResult, layout: _Layout) -> Model:
    jac = np.asarray(result.jac)
    res = np.asarray(result.fun)
    s2 = float(res @ res) / max(1, res.size - jac.shape[1])
    cov_all = s2 * np.linalg.pinv(jac.T @ jac)
    first = 1 if layout.free_release else 0
    idx = list(range(first)) + list(range(first, first + layout.n))
    covariance = cov_all[np.ix_(idx, idx)]
    modes = []
    for i, (s, w) in enumerate(zip(model.sigma, model.omega, strict=True)):
        wn = float(np.hypot(s, w))
        block = cov_all[np.ix_([first + i, first + layout.m + i], [first + i, first + layout.m + i])]
        g_wn = np.array([s / wn, w / wn])
        g_zeta = np.array([w * w / wn ** 3, -s * w / wn ** 3])
        modes.append(ModeEstimate(wn, float(s / wn), float(np.sqrt(max(g_wn @ block @ g_wn, 0.0))),
                                  float(np.sqrt(max(g_zeta @ block @ g_zeta, 0.0)))))
    modes.sort(key=lambda mode: mode.wn)
    simulated = model.simulate(data.u, data.t)
    return replace(model, modes=tuple(modes), covariance=covariance,
                   fit_percent=tuple(fit_percent(data.y, simulated)), residuals=data.y - simulated)
