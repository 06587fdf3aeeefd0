"""Model validation as MATLAB reports it: `compare` (fit %) and `resid` (residual tests).

fit % (per output j), on the free-run SIMULATED output ŷ (not the one-step prediction):

    fit_j = 100 · (1 - ‖y_j - ŷ_j‖ / ‖y_j - mean(y_j)‖).

resid: normalised residual autocorrelation ρ_ee(τ), τ = 1 … M, and residual-input
cross-correlation ρ_eu(τ), τ = -M … M, with 99 % confidence bounds ±2.576/√N for whiteness
and ±2.576·√(Σ_k ρ_ee(k) ρ_uu(k))/√N for independence (Ljung, System Identification, 16.6);
whiteness passes when the portmanteau statistic N Σ_{τ≥1} ρ_ee² is below the 99 % point of
χ²(M); independence passes when max |ρ_eu(τ)| is inside the 99 % bound corrected for the
2M + 1 lags tested (Bonferroni).

Argument order: `compare`, `resid` and `simulate` take `(model, data)` or MATLAB's
`(data, model)`; a model is anything with `simulate(u, t)` (a fitted `Model`, a physical
fit) or a python-control system, continuous or discrete, TF or SS, or a list of SISO ones,
one per output (`ident.lti`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from ident import summary
from ident.data import IdData
from ident.errors import IdentDimensionError, IdentValueError
from ident.lti import as_simulator, is_lti
from ident.physics.measures import fit_percent
from ident.release import moving_outputs

FloatArray = NDArray[np.float64]

#: Two-sided 99 % quantile of the standard normal distribution.
Z99 = 2.5758293035489004


class Simulates(Protocol):
    """Anything with `simulate(u, t) -> y_hat (N, n_out)`: a `Model`, a physical fit."""

    def simulate(self, u: NDArray[np.float64], t: NDArray[np.float64] | None = None) -> FloatArray: ...


def _model_and_data(first: object, second: object, function: str) -> tuple[Simulates, IdData]:
    """(model, data) from either argument order; python-control systems wrapped."""
    if isinstance(first, IdData) and not isinstance(second, IdData):
        first, second = second, first
    if not isinstance(second, IdData):
        raise IdentValueError(f"{function}(data, model)", "an ident.IdData among the arguments "
                              "(build one with ident.IdData(t, u, y) or ident.load(path))",
                              f"{type(first).__name__} and {type(second).__name__}")
    model: object = first
    if is_lti(model):
        model = as_simulator(model)
    if not hasattr(model, "simulate"):
        raise IdentValueError(f"{function}(data, model)", "a fitted Model, a physical fit or a "
                              "python-control TransferFunction/StateSpace", type(first).__name__)
    return model, second


def simulate(first: object, second: object) -> FloatArray:
    """MATLAB's `sim`: the free-run output ŷ (N, n_out) of the model for `data.u` on `data.t`.

    `simulate(model, data)` or `simulate(data, model)`.
    """
    model, data = _model_and_data(first, second, "simulate")
    return _checked_simulation(model, data)


def _checked_simulation(model: Simulates, data: IdData) -> FloatArray:
    y_hat = np.asarray(model.simulate(data.u, data.t), dtype=np.float64).reshape(data.n_samples, -1)
    if y_hat.shape[1] != data.n_outputs:
        moving = moving_outputs(data.y)   # the modelled columns are, in the lab, the moving carts'
        columns = moving if len(moving) == y_hat.shape[1] else list(range(y_hat.shape[1]))
        hint = (f"select the modelled columns, e.g. data.select_outputs({columns})"
                if y_hat.shape[1] < data.n_outputs else "give one model output per data column")
        raise IdentDimensionError("model outputs", f"{data.n_outputs} (one per column of data.y): {hint}",
                                  y_hat.shape[1])
    return y_hat


def compare(first: object, second: object) -> list[float]:
    """Fit % per output of the model's free-run simulation of `data.u` against `data.y`.

    `compare(model, data)` or MATLAB's `compare(data, model)`.
    """
    model, data = _model_and_data(first, second, "compare")
    return fit_percent(data.y, _checked_simulation(model, data))


@dataclass(frozen=True)
class ResidualTest:
    """Residual analysis of one output.

    `autocorrelation` (M+1,) at lags 0 … M (ρ(0) = 1); `cross_correlation` (2M+1,) at lags
    -M … M (positive lag: input leads); bounds are the 99 % half-widths.
    """

    lags: NDArray[np.int64]
    autocorrelation: FloatArray
    auto_bound: float
    cross_lags: NDArray[np.int64]
    cross_correlation: FloatArray
    cross_bound: float
    whiteness_statistic: float
    whiteness_threshold: float
    independence_statistic: float
    independence_threshold: float

    @property
    def white(self) -> bool:
        return self.whiteness_statistic <= self.whiteness_threshold

    @property
    def independent(self) -> bool:
        """max |ρ_eu(τ)| inside the Bonferroni-corrected 99 % bound over the 2M + 1 lags (a
        step input makes the lags strongly correlated, so a χ² sum over them is not valid)."""
        return self.independence_statistic <= self.independence_threshold

    @property
    def passed(self) -> bool:
        return self.white and self.independent

    def summary_rows(self) -> list[tuple[str, str]]:
        """The labelled lines of `repr` and `_repr_html_`."""
        verdict = {True: "pass", False: "FAIL"}
        return [
            ("whiteness", (f"{verdict[self.white]}: N·Σρ² = {self.whiteness_statistic:.4g} "
                           f"(99 % limit {self.whiteness_threshold:.4g}, lags 1 … {len(self.lags) - 1})")),
            ("independence", (f"{verdict[self.independent]}: max |ρ_eu| = {self.independence_statistic:.3g} "
                              f"(limit {self.independence_threshold:.3g})")),
            ("arrays", "autocorrelation, cross_correlation, lags, cross_lags, auto_bound, cross_bound"),
        ]

    def __repr__(self) -> str:
        return summary.text(f"ResidualTest: {'passed' if self.passed else 'failed'}", self.summary_rows())

    def _repr_html_(self) -> str:
        return summary.html_table(f"ResidualTest: {'passed' if self.passed else 'failed'}",
                                  self.summary_rows())


def _correlation(a: FloatArray, b: FloatArray, max_lag: int) -> FloatArray:
    """ρ_ab(τ) = Σ_k a[k+τ] b[k] / (N σ_a σ_b), τ = -max_lag … max_lag (means removed)."""
    a0, b0 = a - a.mean(), b - b.mean()
    norm = np.sqrt(np.sum(a0 * a0) * np.sum(b0 * b0))
    n = len(a0)
    out = np.zeros(2 * max_lag + 1)
    if norm == 0.0:
        return out
    for i, lag in enumerate(range(-max_lag, max_lag + 1)):
        out[i] = np.dot(a0[max(lag, 0):n + min(lag, 0)], b0[max(-lag, 0):n - max(lag, 0)]) / norm
    return out


def residual_test(residuals: FloatArray, u: FloatArray, max_lag: int = 25) -> ResidualTest:
    """Whiteness and input-independence tests of one output's residual (N,)."""
    from scipy.stats import chi2, norm

    e = np.asarray(residuals, dtype=np.float64)
    n = len(e)
    auto_full = _correlation(e, e, max_lag)
    auto = auto_full[max_lag:]
    cross = _correlation(e, np.asarray(u, dtype=np.float64), max_lag)
    uu = _correlation(np.asarray(u, dtype=np.float64), np.asarray(u, dtype=np.float64), max_lag)
    spread = float(np.sum(auto_full * uu)) if np.any(uu) else 1.0
    return ResidualTest(
        lags=np.arange(max_lag + 1), autocorrelation=auto, auto_bound=Z99 / np.sqrt(n),
        cross_lags=np.arange(-max_lag, max_lag + 1), cross_correlation=cross,
        cross_bound=Z99 * np.sqrt(max(spread, 0.0)) / np.sqrt(n),
        whiteness_statistic=float(n * np.sum(auto[1:] ** 2)),
        whiteness_threshold=float(chi2.ppf(0.99, max_lag)),
        independence_statistic=float(np.max(np.abs(cross))),
        independence_threshold=float(norm.ppf(1.0 - 0.005 / (2 * max_lag + 1))
                                     * np.sqrt(max(spread, 0.0)) / np.sqrt(n)))


def resid(first: object, second: object, max_lag: int = 25) -> list[ResidualTest]:
    """MATLAB-style `resid`: one `ResidualTest` per output of the simulation error.

    `resid(model, data)` or MATLAB's `resid(data, model)`.
    """
    model, data = _model_and_data(first, second, "resid")
    errors = data.y - _checked_simulation(model, data)
    return [residual_test(errors[:, j], data.u, max_lag) for j in range(data.n_outputs)]
