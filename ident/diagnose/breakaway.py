"""A breakaway ratio's 1-D search between its grid's levels, the other parameters profiled.
No I/O here.

A cart's breakaway ratio r_i (static over kinetic friction, `models`) is fitted on a grid of
levels, then refined. A least-squares step does not refine it: where a cart sticks and breaks
away moves by steps with r_i, so the cost's finite difference in r_i is zero or a jump of a
stick decision, and which of those the solver sees depends on the last bits of the rounding
(a generated Coulomb + held-cart flick, breakaway 1.417 x kinetic, fitted by free fits from
steps about the grid's 1.3: r 1.339 with numpy's AVX2/FMA3 loops, 1.378 without them, 1.330-1.378
with the readings changed by 1e-15-1e-13 of themselves, the held cart's gain 1-7.9 % off). So r_i
is searched as a 1-D problem: golden section over the profile cost

    p(r) = min over the other free parameters θ of SSE(θ, r_i = r)

(each evaluation one fit with r_i fixed, from the same start), on a bracket one grid cell
either side of the cell that holds the fitted ratio. The profile is smooth where the other
parameters move continuously and piecewise constant where only stick decisions do; either way
golden section compares costs only, never a derivative in r_i.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from ident.diagnose.fitting import FitResult, fit
from ident.diagnose.models import ModelSpec
from ident.diagnose.problem import FloatArray, Problem

#: Profile fits of one cart's golden-section search: a bracket of three grid cells (1.2-1.5)
#: narrows to about 0.01.
RATIO_SEARCH_FITS = 8
#: A fitted ratio this close (relative) above a grid level counts as on it (the bracket must
#: not depend on the fit's last bits).
ON_LEVEL = 1e-6
#: Costs within this share of the least are one plateau of the profile (`plateau_middle`).
PLATEAU = 1e-6
#: 1 / golden ratio.
INV_PHI = (math.sqrt(5.0) - 1.0) / 2.0


def ratio_bracket(ratio: float, levels: Sequence[float]) -> tuple[float, float]:
    """(low, high): the grid `levels` (ascending, from 1) one cell below and above the cell
    [L_k, L_k+1) that holds `ratio`, clipped to the grid's ends."""
    k = int(np.searchsorted(np.asarray(levels), ratio * (1.0 + ON_LEVEL), side="right")) - 1
    k = min(max(k, 0), len(levels) - 1)
    return float(levels[max(k - 1, 0)]), float(levels[min(k + 2, len(levels) - 1)])


def search_ratios(spec: ModelSpec, prob: Problem, best: FitResult,
                  bounds: tuple[FloatArray, FloatArray, FloatArray], levels: Sequence[float],
                  max_nfev: int) -> FitResult:
    """`best` (a fit of a model with static friction) with each cart's breakaway ratio in turn
    searched by golden section (`golden_profile`) between its `levels`' neighbours
    (`ratio_bracket`), the other parameters refitted at every trial ratio; of those fits and
    `best`, the one in the middle of the least cost's plateau (`plateau_middle`). Returned with
    `spec` (every ratio free)."""
    block = spec.block("static_friction")
    for at in range(block.start, block.stop):
        low, high = ratio_bracket(float(best.theta[at]), levels)
        if high <= low:
            continue
        tried = golden_profile(spec, prob, best.theta, at, (low, high), bounds, max_nfev)
        best = dataclasses.replace(plateau_middle([best, *tried], at), spec=spec)
    return best


def plateau_middle(fits: list[FitResult], at: int) -> FitResult:
    """Of `fits`, those within `PLATEAU` of the least cost (one plateau: a ratio that moves no
    stick decision there, which the readings do not tell apart), the one nearest the middle of
    their range of parameter `at` (golden section sends ties to one end)."""
    least = min(f.sse_train for f in fits)
    flat = [f for f in fits if f.sse_train <= least * (1.0 + PLATEAU)]
    values = [float(f.theta[at]) for f in flat]
    middle = 0.5 * (min(values) + max(values))
    return min(flat, key=lambda f: (abs(float(f.theta[at]) - middle), float(f.theta[at])))


def golden_profile(spec: ModelSpec, prob: Problem, theta: FloatArray, at: int, bracket: tuple[float, float],
                   bounds: tuple[FloatArray, FloatArray, FloatArray], max_nfev: int) -> list[FitResult]:
    """The profile fits of parameter `at` tried by `RATIO_SEARCH_FITS` golden-section
    evaluations of p(r) over `bracket` (module docstring), each a fit of `spec` with `at` fixed
    at r, started from `theta` with r set (the same start for every r, so p does not depend on
    the order of the search). Ties narrow to the lower ratio."""
    lower, upper, typical = bounds
    name = spec.names[at]

    def profile(r: float) -> FitResult:
        start = theta.copy()
        start[at] = r
        fixed = dataclasses.replace(spec, fixed={**spec.fixed, name: r})
        return fit(fixed, start, lower, upper, typical, prob.dt, prob.y, prob.train, max_nfev=max_nfev)

    a, b = bracket
    c, d = b - INV_PHI * (b - a), a + INV_PHI * (b - a)
    fc, fd = profile(c), profile(d)
    tried = [fc, fd]
    for _ in range(RATIO_SEARCH_FITS - 2):
        if fc.sse_train <= fd.sse_train:
            b, d, fd = d, c, fc
            c = b - INV_PHI * (b - a)
            fc = profile(c)
            tried.append(fc)
        else:
            a, c, fc = c, d, fd
            d = a + INV_PHI * (b - a)
            fd = profile(d)
            tried.append(fd)
    return tried


__all__ = ["PLATEAU", "RATIO_SEARCH_FITS", "golden_profile", "plateau_middle", "ratio_bracket", "search_ratios"]
