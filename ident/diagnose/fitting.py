"""Output-error fit of a `ModelSpec` to the training samples of a free response.

Minimises `Σ_{k ∈ train} |y_k - ŷ_k(θ)|²` (simulated, not one-step, output) with scipy's
trust-region reflective least squares within bounds. The Jacobian is a forward difference
computed as ONE batched simulation of all perturbed parameter rows. The parameter
covariance is `σ² (JᵀJ)⁻¹` with `σ² = SSE / (n - p)` at the solution (Gauss-Newton).
No I/O here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.optimize
from numpy.typing import NDArray

from ident.diagnose.models import ModelSpec

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class FitResult:
    """`theta` (p,) fitted parameters, `std` (p,) 1-sigma (0 for fixed ones), `prediction`
    (N, carts) on every work sample, `sse_train`/`sse_val` on the two halves."""

    spec: ModelSpec
    theta: FloatArray
    std: FloatArray
    prediction: FloatArray
    sse_train: float
    sse_val: float
    n_train: int
    n_val: int

    def parameters(self) -> dict[str, float]:
        return {n: float(v) for n, v in zip(self.spec.names, self.theta)}

    def parameter_std(self) -> dict[str, float]:
        return {n: float(v) for n, v in zip(self.spec.names, self.std) if np.isfinite(v)}


def evaluate(spec: ModelSpec, theta: FloatArray, dt: float, y: FloatArray, train: NDArray[np.bool_],
             std: FloatArray | None = None) -> FitResult:
    """A `FitResult` for given parameters (no optimisation)."""
    pred = spec.predict(theta[None, :], dt, y.shape[0])[0]
    err = (pred - y) ** 2
    return FitResult(spec, theta.copy(), np.zeros_like(theta) if std is None else std, pred,
                     float(err[train].sum()), float(err[~train].sum()),
                     int(train.sum() * y.shape[1]), int((~train).sum() * y.shape[1]))


def fit(spec: ModelSpec, theta0: FloatArray, lower: FloatArray, upper: FloatArray,
        typical: FloatArray, dt: float, y: FloatArray, train: NDArray[np.bool_],
        max_nfev: int = 60) -> FitResult:
    """Fit the free parameters of `spec` (all but `spec.fixed`) to `y` (N, carts) on `train`."""
    n = y.shape[0]
    free = np.array([i for i in range(theta0.size) if i not in spec.fixed], dtype=int)
    base = theta0.astype(np.float64).copy()
    for i, v in spec.fixed.items():
        base[i] = v
    steps = 1e-6 * np.maximum(np.abs(base[free]), typical[free])
    y_train = y[train]

    def full(x: FloatArray) -> FloatArray:
        theta = np.repeat(base[None, :], x.shape[0], axis=0)
        theta[:, free] = x
        return theta

    def residual(x: FloatArray) -> FloatArray:
        pred = spec.predict(full(x[None, :]), dt, n)[0]
        return _finite((pred[train] - y_train).ravel())

    def jacobian(x: FloatArray) -> FloatArray:
        rows = np.repeat(x[None, :], free.size + 1, axis=0)
        h = steps * np.where(x + steps > upper[free], -1.0, 1.0)
        rows[1:] += np.diag(h)
        pred = spec.predict(full(rows), dt, n)[:, train, :].reshape(rows.shape[0], -1)
        jac: FloatArray = _finite(((pred[1:] - pred[0]) / h[:, None]).T)
        return jac

    x0 = _inside(base[free], lower[free], upper[free])
    with np.errstate(all="ignore"):
        sol = scipy.optimize.least_squares(residual, x0, jac=jacobian, bounds=(lower[free], upper[free]),
                                           x_scale="jac", max_nfev=max_nfev, ftol=1e-10, xtol=1e-10)
    theta = base.copy()
    theta[free] = sol.x
    std = np.zeros_like(theta)
    std[free] = _std(sol.jac, float(np.sum(sol.fun ** 2)))
    with np.errstate(all="ignore"):
        result = evaluate(spec, theta, dt, y, train, std)
        start = evaluate(spec, base, dt, y, train)
    if not np.isfinite(result.sse_train) or result.sse_train > start.sse_train:
        return start if np.isfinite(start.sse_train) else result
    return result


def _finite(a: FloatArray) -> FloatArray:
    """Unstable trial parameters overflow the simulation: a large finite penalty instead."""
    if np.all(np.isfinite(a)):
        return a
    return np.nan_to_num(a, nan=1e3, posinf=1e3, neginf=-1e3)


def _inside(x: FloatArray, lower: FloatArray, upper: FloatArray) -> FloatArray:
    """`x` moved strictly inside finite bounds (least_squares wants a strict interior)."""
    width = np.where(np.isfinite(upper - lower), upper - lower, np.maximum(np.abs(x), 1.0))
    margin = 1e-9 * width
    return np.minimum(np.maximum(x, lower + margin), upper - margin)


def _std(jac: FloatArray, sse: float) -> FloatArray:
    """Gauss-Newton standard deviations from the Jacobian (m, p) and SSE."""
    m, p = jac.shape
    sigma2 = sse / max(m - p, 1)
    try:
        cov = sigma2 * np.linalg.pinv(jac.T @ jac)
    except np.linalg.LinAlgError:
        return np.full(p, np.nan)
    return np.asarray(np.sqrt(np.maximum(np.diag(cov), 0.0)), dtype=np.float64)
