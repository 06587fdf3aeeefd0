"""Output-error fit of a `ModelSpec` to a free response, and its blocked cross-validation.

Minimises `Σ_{k ∈ fit} |y_k - ŷ_k(θ)|²` (simulated, not one-step, output) with scipy's
trust-region reflective least squares within bounds. The Jacobian is a forward difference
computed as ONE batched simulation of all perturbed parameter rows. The parameter
covariance is `σ² (JᵀJ)⁻¹` with `σ² = SSE / (n - p)` at the solution (Gauss-Newton).

Blocked cross-validation (`BLOCKS` contiguous blocks after a first stretch of the window that
anchors the release state, spread over the motion: a stuck tail goes into the last block; a
cart that rings freely to the end is anchored on `anchor` samples, one period of its main mode,
when that is shorter): for block b the model
is refitted with the cost taken outside b — `CV_ITERATIONS` damped Gauss-Newton steps from the
whole-window fit, `(J_{-b}ᵀJ_{-b} + λ D) Δ_b = -J_{-b}ᵀ r_{-b}`, λ chosen by the cost outside b — and simulated through
the WHOLE window from the window start (the state stays continuous); the cost is the squared
residual inside b. CV = Σ_b, of the better of two refits (`CV_DAMPING`). Interleaved samples
would test interpolation; a block tests what the model predicts where it was not fitted. No I/O
here.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ident.diagnose.drift import drift_penalty
from ident.diagnose.models import ModelSpec

FloatArray = NDArray[np.float64]


BLOCKS = 5


@dataclass(frozen=True)
class FitResult:
    """`theta` (p,) fitted parameters, `std` (p,) 1-sigma (0 for fixed ones), `prediction`
    (N, carts) on every work sample, `sse_train` the cost on the fitted samples, `sse_val`
    the blocked cross-validation cost (see the module docstring; = sse_train when not run),
    `n_train` residuals, `n_free` fitted parameters."""

    spec: ModelSpec
    theta: FloatArray
    std: FloatArray
    prediction: FloatArray
    sse_train: float
    sse_val: float
    n_train: int
    n_free: int = 0
    #: (N, carts) what the blocked cross-validation predicted: inside each held-out block its
    #: refit's prediction, in the first (anchoring) stretch the whole-window one; None when not run
    cv_prediction: FloatArray | None = None
    #: (whole window, held out): twice the log-likelihood gain over the model this one extends,
    #: for an effect whose readings are no Gaussian scatter (an encoder lattice: a mixture of
    #: levels); None: the gain is the SSE ratio
    likelihood_gain: tuple[float, float] | None = None
    #: whole window, for an effect of the carts added to a model that reads through an encoder
    #: lattice: twice the log-likelihood gain of the readings as the lattice's levels over the
    #: model this one extends (`lattice.level_log_likelihood`); None: the gain is the SSE ratio
    level_gain: float | None = None

    def parameters(self) -> dict[str, float]:
        return {n: float(v) for n, v in zip(self.spec.names, self.theta)}

    def parameter_std(self) -> dict[str, float]:
        return {n: float(v) for n, v in zip(self.spec.names, self.std) if np.isfinite(v)}


def evaluate(spec: ModelSpec, theta: FloatArray, dt: float, y: FloatArray, train: NDArray[np.bool_],
             std: FloatArray | None = None) -> FitResult:
    """A `FitResult` for given parameters (no optimisation)."""
    pred = spec.predict(theta[None, :], dt, y.shape[0])[0]
    sse = float(((pred - y) ** 2)[train].sum())
    return FitResult(spec, theta.copy(), np.zeros_like(theta) if std is None else std, pred,
                     sse, sse, int(train.sum() * y.shape[1]), 0)


def fit(spec: ModelSpec, theta0: FloatArray, lower: FloatArray, upper: FloatArray,
        typical: FloatArray, dt: float, y: FloatArray, train: NDArray[np.bool_],
        max_nfev: int = 60, cross_validate: bool = False, anchor: int = 0) -> FitResult:
    """Fit the free parameters of `spec` (all but `spec.fixed`) to `y` (N, carts) on `train`;
    with `cross_validate`, `sse_val` is the blocked cross-validation cost after an anchoring
    stretch of `anchor` samples (`block_edges`)."""
    import scipy.optimize  # deferred: keeps `import ident` fast
    n = y.shape[0]
    names = spec.names
    free = np.array([i for i, name in enumerate(names) if name not in spec.fixed], dtype=int)
    base = theta0.astype(np.float64).copy()
    for i, name in enumerate(names):
        if name in spec.fixed:
            base[i] = spec.fixed[name]
    steps = 1e-6 * np.maximum(np.abs(base[free]), typical[free])
    y_train = y[train]
    # a rest drift's knots are held near their neighbours and near no drift where the data do not see them
    root = None
    if "rest_drift" in spec.effects:
        root = drift_penalty(spec, free, _misfit_variance(spec, base, dt, y, train))
    m_data = y_train.size

    def full(x: FloatArray) -> FloatArray:
        theta = np.repeat(base[None, :], x.shape[0], axis=0)
        theta[:, free] = x
        return theta

    def residual(x: FloatArray) -> FloatArray:
        pred = spec.predict(full(x[None, :]), dt, n)[0]
        out = _finite((pred[train] - y_train).ravel())
        return out if root is None else np.concatenate([out, root @ x])

    def jacobian(x: FloatArray) -> FloatArray:
        rows = np.repeat(x[None, :], free.size + 1, axis=0)
        h = steps * np.where(x + steps > upper[free], -1.0, 1.0)
        rows[1:] += np.diag(h)
        pred = spec.predict(full(rows), dt, n)[:, train, :].reshape(rows.shape[0], -1)
        jac: FloatArray = _finite(((pred[1:] - pred[0]) / h[:, None]).T)
        return jac if root is None else np.concatenate([jac, root])

    x0 = _inside(base[free], lower[free], upper[free])
    with np.errstate(all="ignore"):
        sol = scipy.optimize.least_squares(residual, x0, jac=jacobian, bounds=(lower[free], upper[free]),
                                           x_scale="jac", max_nfev=max_nfev, ftol=1e-8, xtol=1e-8)
    x_fit = sol.x if root is None else _polish(sol.x, sol.jac, sol.fun, residual, lower[free], upper[free])
    theta = base.copy()
    theta[free] = x_fit
    std = np.zeros_like(theta)
    std[free] = _std(sol.jac, float(np.sum(sol.fun ** 2)))
    if "quantization" in spec.effects:
        std = _std_through_lattice(spec, theta, std, free, steps, dt, y, train, root)
    with np.errstate(all="ignore"):
        result = evaluate(spec, theta, dt, y, train, std)
        start = evaluate(spec, base, dt, y, train)
    if not np.isfinite(result.sse_train) or result.sse_train > start.sse_train:
        with np.errstate(all="ignore"):   # a perturbed trial may diverge (`_finite`)
            at = jacobian(base[free]) if np.isfinite(start.sse_train) else jacobian(result.theta[free])
            if np.isfinite(start.sse_train):   # the start, with its own Gauss-Newton σ (it had 0)
                std_start = np.zeros_like(theta)
                std_start[free] = _std(at, float(np.sum(residual(base[free]) ** 2)))
                result = dataclasses.replace(start, std=std_start)
        jac_at = at[:m_data].copy() if cross_validate else None
    else:
        jac_at = sol.jac[:m_data] if cross_validate else None
    cv, cv_pred = result.sse_train, None
    if jac_at is not None:
        prior = None if root is None else root.T @ root
        for damping in CV_DAMPING:
            pred = _blocked_cv(spec, result, full, free, jac_at, lower[free], upper[free], dt, y, train, prior, anchor,
                               damping)
            cost = held_out_cost(pred, y, train, anchor)
            if cv_pred is None or cost < cv:
                cv, cv_pred = cost, pred
    return FitResult(spec, result.theta, result.std, result.prediction, result.sse_train, cv,
                     result.n_train, int(free.size), cv_pred)


#: A sample moves when some output is farther than this share of its peak-to-peak from its
#: final level (the median of the last tenth of the window).
MOVING_SHARE = 0.02


def motion_end(y: FloatArray) -> int:
    """Samples of `y` (N, c) m up to the last one that moves (`MOVING_SHARE`), at least N/6.

    A dry-friction cart can stop within the first sixth of a long record (a 16 s record whose
    cart sticks after 2.6 s, a held cart wandering on): blocks of equal time would then all
    lie in the stuck tail, where an effect of the motion (the held cart's coupling: 99.7 % of
    the misfit removed, all of it before the stop) cannot show, and would be refused."""
    return max(last_moving(y, MOVING_SHARE * np.ptp(y, axis=0)), y.shape[0] // 6)


def last_moving(y: FloatArray, bound: FloatArray) -> int:
    """Samples of `y` (N, c) up to the last one where some column is farther than `bound` (c,)
    from its final level (the median of the last tenth); N when none is."""
    n = y.shape[0]
    final = np.median(y[-max(n // 10, 1):], axis=0)
    away = np.flatnonzero(np.any(np.abs(y - final) > bound, axis=1))
    return int(away[-1]) + 1 if away.size else n


def block_edges(y: FloatArray, anchor: int = 0) -> NDArray[np.int_]:
    """Sample edges of the `BLOCKS` held-out blocks of `y` (N, c) (BLOCKS + 1 values; before
    the first edge is the anchoring stretch, never held out): the anchor is the first
    1/(BLOCKS + 1) of the motion (`motion_end`), or `anchor` samples when that is shorter and
    not 0; the blocks split the rest of the window equally (a still tail keeps blocks of its
    own: a slow drift of the rest shows there).

    A freely ringing cart's anchor needs only to fix the release state (x0, v0): about one
    period of the main mode (`anchor`, `anchor.anchor_of`). A longer one hides what happens early
    from every held-out block: a second mode that has decayed by a few 1/s lives mostly in the
    first seconds, and a sixth of a 9 s window (1.5 s) had held 95 % of a 1/s mode's energy
    (coupled_mode seed 1958525349 at bench seed 12: whole-window ratio 226 against a bound of
    29, held-out ratio -4.6)."""
    n = y.shape[0]
    start = motion_end(y) // (BLOCKS + 1)
    if 0 < anchor < start:
        start = anchor
    return np.linspace(start, n, BLOCKS + 1).astype(int)


def held_out_samples(y: FloatArray, anchor: int = 0) -> NDArray[np.bool_]:
    """(N,) the samples of the held-out blocks of `y` (N, c) (all after the anchoring stretch)."""
    inside = np.zeros(y.shape[0], dtype=bool)
    inside[int(block_edges(y, anchor)[0]):] = True
    return inside


def held_out_cost(cv_prediction: FloatArray, y: FloatArray, train: NDArray[np.bool_], anchor: int = 0) -> float:
    """Σ over the held-out blocks of the squared residual of a cross-validated prediction (N, c)."""
    inside = held_out_samples(y, anchor) & train
    total = float(np.sum((cv_prediction[inside] - y[inside]) ** 2))
    return total if np.isfinite(total) else float("inf")


#: Damping factors λ of the refit steps tried per block: (JᵀJ + λ diag JᵀJ) Δ = -Jᵀr; the
#: held-out cost is that of the better of two such refits (two sets of λ). Which cart sticks
#: where moves discontinuously with the parameters, and one refit's held-out cost came out
#: anywhere within a factor of 3 per block: on a real release (07-Feb-2025_11_32_48) its
#: mirror image, the same physics, read a 0.29-point mode's held-out ratio as 2.7 where the
#: record as recorded read 311 (bound 29.5), and a cubic spring -405 and 191, so the two named
#: different fourth effects (fits 99.03 and 98.80 %).
CV_DAMPING = ((1e-3, 1e-1, 1.0), (1e-2, 0.3, 3.0))
#: Levenberg-Marquardt iterations of each block's refit.
CV_ITERATIONS = 2


def _blocked_cv(spec: ModelSpec, res: FitResult, full: Callable[[FloatArray], FloatArray], free: NDArray[np.int_],
                jac: FloatArray, lower: FloatArray, upper: FloatArray, dt: float, y: FloatArray,
                train: NDArray[np.bool_], prior: FloatArray | None = None, anchor: int = 0,
                damping: tuple[float, ...] = CV_DAMPING[0]) -> FloatArray:
    """The prediction (N, c) of each held-out block b after a refit without b (docstring);
    the whole-window prediction before the first block.

    The refit of every block starts at the whole-window fit and takes `CV_ITERATIONS`
    Levenberg-Marquardt steps, all blocks in one batched simulation per step; each step's
    damping is chosen among `damping` (or no step) by the cost OUTSIDE block b, so the
    held-out block never chooses its own model. `prior` (p, p): the quadratic penalty xᵀ P x
    of the whole-window fit (`drift.drift_penalty`), added to every refit's cost: a drift knot
    that mostly block b saw keeps its neighbours' level instead of flying off on the outside's
    noise.
    """
    n, c = y.shape
    # the first of BLOCKS + 1 stretches is never held out: it fixes the release state
    # (x0, v0), which the rest of a record determines only through a chaotic extrapolation
    # backwards across every stick of a dry-friction cart
    edges = block_edges(y, anchor)
    outside = np.ones((BLOCKS, n), dtype=bool)
    for b in range(BLOCKS):
        outside[b, edges[b]:edges[b + 1]] = False
    outside &= train[None, :]
    x = np.repeat(res.theta[free][None, :], BLOCKS, axis=0)
    pred = np.repeat(res.prediction[None], BLOCKS, axis=0)
    jacs = [jac] * BLOCKS
    p = free.size
    steps_fd = 1e-6 * np.maximum(np.abs(res.theta[free]), 1e-12)
    for it in range(CV_ITERATIONS):
        if it > 0:
            jacs, pred = _jacobians(spec, full, x, steps_fd, upper, dt, n)
        k = len(damping) + 1
        trials = np.repeat(x, k, axis=0)
        for b in range(BLOCKS):
            jb = jacs[b].reshape(n, c, p)[outside[b]].reshape(-1, p)
            rb = (pred[b] - y)[outside[b]].ravel()
            scale = np.maximum(np.linalg.norm(jb, axis=0), 1e-300)
            if prior is not None:   # a knot the outside does not see is scaled by its penalty
                scale = np.maximum(scale, np.sqrt(np.diag(prior)))
            js = jb / scale
            g, h = js.T @ rb, js.T @ js
            if prior is not None:   # in the scaled coordinates φ = x · scale
                g = g + (prior @ x[b]) / scale
                h = h + prior / scale[:, None] / scale[None, :]
            for i, lam in enumerate(damping):
                step = np.linalg.lstsq(h + lam * np.diag(np.diag(h)) + 1e-12 * np.eye(p), -g, rcond=1e-12)[0] / scale
                # a Jacobian column of a trial that diverged is not finite: no step (a motor
                # record's refit, DOF1_en1_input1_test4 of the 2023 set, raised LinAlgError)
                if np.all(np.isfinite(step)):
                    trials[b * k + i + 1] = np.clip(x[b] + step, lower, upper)
        with np.errstate(all="ignore"):
            tp = spec.predict(full(trials), dt, n)
        err = np.nan_to_num(((tp - y[None]) ** 2).sum(axis=2), nan=np.inf, posinf=np.inf)
        for b in range(BLOCKS):
            cost = err[b * k:(b + 1) * k][:, outside[b]].sum(axis=1)
            if prior is not None:
                cost = cost + np.einsum("ip,pq,iq->i", trials[b * k:(b + 1) * k], prior, trials[b * k:(b + 1) * k])
            best = int(np.argmin(cost))
            x[b] = trials[b * k + best]
            pred[b] = tp[b * k + best]
    out = res.prediction.copy()
    for b in range(BLOCKS):
        out[edges[b]:edges[b + 1]] = pred[b, edges[b]:edges[b + 1]]
    return out


def _jacobians(spec: ModelSpec, full: Callable[[FloatArray], FloatArray], xs: FloatArray, steps: FloatArray,
               upper: FloatArray, dt: float, n: int) -> tuple[list[FloatArray], FloatArray]:
    """Forward-difference Jacobians (N·c, p) at each row of `xs` (B, p), and the predictions
    (B, N, c) there, from ONE batched simulation."""
    b_count, p = xs.shape
    rows = np.repeat(xs, p + 1, axis=0)
    hs = np.empty((b_count, p))
    for b in range(b_count):
        h = steps * np.where(xs[b] + steps > upper, -1.0, 1.0)
        hs[b] = h
        rows[b * (p + 1) + 1:(b + 1) * (p + 1)] += np.diag(h)
    with np.errstate(all="ignore"):
        pred = spec.predict(full(rows), dt, n)
    out = []
    base = np.empty((b_count, *pred.shape[1:]))
    for b in range(b_count):
        block = pred[b * (p + 1):(b + 1) * (p + 1)].reshape(p + 1, -1)
        out.append(_finite(((block[1:] - block[0]) / hs[b][:, None]).T))
        base[b] = pred[b * (p + 1)]
    return out, base


def _polish(x: FloatArray, jac: FloatArray, fun: FloatArray, residual: Callable[[FloatArray], FloatArray],
            lower: FloatArray, upper: FloatArray) -> FloatArray:
    """One Gauss-Newton step of the penalised cost from the solver's end, kept if it lowers the
    cost: the directions the readings do not see (a drift knot in a stuck cart's dead band) are
    set by the penalty alone, on which the solver's relative tolerances stop long before."""
    step = np.linalg.lstsq(jac, -fun, rcond=1e-12)[0]
    trial = np.clip(x + step, lower, upper)
    with np.errstate(all="ignore"):
        better = float(np.sum(residual(trial) ** 2)) < float(np.sum(fun ** 2))
    return trial if better else x


def _misfit_variance(spec: ModelSpec, theta: FloatArray, dt: float, y: FloatArray,
                     train: NDArray[np.bool_]) -> float:
    """The start's residual variance (m²) per reading: what the model being extended leaves."""
    with np.errstate(all="ignore"):
        res = spec.predict(theta[None, :], dt, y.shape[0])[0][train] - y[train]
    value = float(np.mean(res ** 2)) if res.size else 0.0
    return value if np.isfinite(value) else 0.0


#: Largest magnitude a residual or Jacobian entry keeps (a runaway simulation's can be finite
#: but so large that least_squares' column norms overflow to inf and its solver gets NaN: a
#: strong softening cubic past the spring's turning point on the real 14-Feb-2025_09_22_43).
FINITE_CAP = 1e8


def _finite(a: FloatArray) -> FloatArray:
    """Unstable trial parameters overflow the simulation: a large finite penalty instead."""
    if np.all(np.isfinite(a)) and float(np.max(np.abs(a), initial=0.0)) < FINITE_CAP:
        return a
    return np.clip(np.nan_to_num(a, nan=1e3, posinf=1e3, neginf=-1e3), -FINITE_CAP, FINITE_CAP)


def _inside(x: FloatArray, lower: FloatArray, upper: FloatArray) -> FloatArray:
    """`x` moved strictly inside finite bounds (least_squares wants a strict interior)."""
    width = np.where(np.isfinite(upper - lower), upper - lower, np.maximum(np.abs(x), 1.0))
    margin = 1e-9 * width
    return np.minimum(np.maximum(x, lower + margin), upper - margin)


def without_lattice(spec: ModelSpec) -> tuple[ModelSpec, NDArray[np.bool_]]:
    """`spec` reading the carts' positions themselves, without its encoder lattice's staircase,
    and which of `spec`'s parameters it keeps (all but the lattice's)."""
    lattice = set(spec.names_of("quantization"))
    keep = np.array([name not in lattice for name in spec.names])
    bare = dataclasses.replace(spec, effects=tuple(e for e in spec.effects if e != "quantization"),
                               fixed={k: v for k, v in spec.fixed.items() if k not in lattice})
    return bare, keep


def continuous_jacobian(bare: ModelSpec, theta: FloatArray, at: NDArray[np.int_], steps: FloatArray,
                        dt: float, n: int) -> tuple[FloatArray, FloatArray]:
    """The positions (n, carts) m of `bare` (a model read without its lattice, `without_lattice`)
    at `theta` over `n` steps of `dt` s, and their forward differences (len(at), n, carts) in
    the parameters at indices `at`, steps `steps`: ONE batched simulation of every perturbed row
    (a diverging row is non-finite: the caller decides)."""
    rows = np.repeat(theta[None, :], at.size + 1, axis=0)
    rows[np.arange(1, at.size + 1), at] += steps
    with np.errstate(all="ignore"):
        pred = bare.predict(rows, dt, n)
        diff = (pred[1:] - pred[0]) / steps[:, None, None]
    return pred[0], diff


def _std_through_lattice(spec: ModelSpec, theta: FloatArray, std: FloatArray, free: NDArray[np.int_],
                         steps: FloatArray, dt: float, y: FloatArray, train: NDArray[np.bool_],
                         root: FloatArray | None) -> FloatArray:
    """`std` with the carts' parameters' 1-sigma taken from the model read without its encoder
    lattice: Gauss-Newton through the continuous prediction, the lattice's error counted as
    noise (Widrow: q²/12 a sample, in the residual).

    Through a nearly hard staircase (a small blur) a parameter's finite difference is zero
    at most samples and steep at those on a level's edge, and the matched levels leave almost
    no residual: the Gauss-Newton σ came out absurdly small (a 25 Hz real release read
    through a 1 mm lattice: a cubic spring of -3538 ± 1.7e-6 /m²/s²). The lattice's own
    parameters keep theirs."""
    bare, keep = without_lattice(spec)
    kept = keep[free]
    cols = free[kept]
    position, diff = continuous_jacobian(bare, theta[keep], (np.cumsum(keep) - 1)[cols], steps[kept], dt,
                                         y.shape[0])
    jac = _finite(diff[:, train, :].reshape(cols.size, -1).T)   # `_finite` takes a diverging row
    resid = _finite(position[train].ravel() - y[train].ravel())
    if root is not None:   # the rest drift's penalty, on the kept parameters
        jac = np.concatenate([jac, root[:, kept]])
        resid = np.concatenate([resid, root[:, kept] @ theta[cols]])
    out = std.copy()
    out[cols] = _std(jac, float(resid @ resid))
    return out


def _std(jac: FloatArray, sse: float) -> FloatArray:
    """Gauss-Newton standard deviations from the Jacobian (m, p) and SSE."""
    m, p = jac.shape
    sigma2 = sse / max(m - p, 1)
    try:
        cov = sigma2 * np.linalg.pinv(jac.T @ jac)
    except np.linalg.LinAlgError:
        return np.full(p, np.nan)
    return np.asarray(np.sqrt(np.maximum(np.diag(cov), 0.0)), dtype=np.float64)
