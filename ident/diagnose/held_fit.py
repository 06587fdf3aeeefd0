"""The held cart's candidate: its coupling fitted from a grid and several starts. No I/O here."""

from __future__ import annotations

from ident.diagnose.fitting import FitResult, fit
from ident.diagnose.models import ModelSpec
from ident.diagnose.problem import FloatArray, Problem, best_on_grid


def fit_held_cart(spec: ModelSpec, prob: Problem, theta0: FloatArray, lower: FloatArray, upper: FloatArray,
                  typical: FloatArray, at: int, wn2: float, max_nfev: int) -> FitResult:
    """The held cart's coupling β fitted from the best of a grid at the current parameters and
    from 0.05, 0.2 and 0.5 wn², the best fit kept. The
    current model has absorbed the held cart's slow pull into its rest and frequency, so at
    those values any β > 0 costs more (a grid at fixed parameters picks β = 0) and a short
    fit from β = 0 does not find the joint move; from a start near the coupling it does."""
    grid = best_on_grid(spec, prob, theta0, at, tuple(wn2 * g for g in (0.0, 0.05, 0.2, 0.5)))
    best: FitResult | None = None
    for beta in (float(grid[at]), 0.05 * wn2, 0.2 * wn2, 0.5 * wn2):
        start = grid.copy()
        start[at] = beta
        result = fit(spec, start, lower, upper, typical, prob.dt, prob.y, prob.train, max_nfev=max_nfev)
        if best is None or result.sse_train < best.sse_train:
            best = result
    assert best is not None
    return best


__all__ = ["fit_held_cart"]
