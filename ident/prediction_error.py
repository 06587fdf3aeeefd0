"""Prediction-error identification of the carts' linear models (`ident.pem(data, order)`).

Pipeline (MATLAB `pem` → `d2c` → `tf`, made robust for lightly damped poles at high rates):
1. start values: release time from the onset of the motion (`ident.release`), modes from a
   subspace (Hankel/shift-invariance) estimate on the free response after the release,
   decimated so the poles do not crowd z = 1 (`ident.subspace`); the modes of the physical
   cart or chain that explains the free response (`ident.physical_start`, built by
   `ident.physics`); for any other recorded input, PO-MOESP on the whole record and
   `d2c_zoh`; one cart per spectral peak as fallback; the starts are tried in the order of
   their projected cost;
2. refinement: minimise the output prediction error of the continuous-time modal model
   (noise model H = 1: white measurement noise, for which the one-step predictor equals the
   simulation, so PEM = output error) by variable projection (`ident.varpro`), with the
   release time a continuous parameter and the physical structure (relative degree, DC gain)
   as linear constraints;
3. optionally (`noise_model="innovation"`), a joint refinement of everything with an
   innovation gain K on the one-step prediction errors (`ident.innovation`);
4. the result is continuous-time already: poles, `wn`, `zeta` per mode, transfer functions.
   The discrete innovation form is available from `Model.discrete()`.

Initial state (`initial_state`, as MATLAB pem's InitialState): "zero" releases the carts from
rest at a fitted release time (a pull-hold-release); "estimate" starts them at the release the
data state (`data.release_time_s`, else where u steps) with their velocities there estimated
(a flicked cart is let go moving; `ident.varpro`'s docstring), so a flicked window is fitted from
its first sample; "auto" (default) fits both when the data state a release and keeps "zero"
unless the estimate's BIC is lower by more than `CHOICE_CHI2`.

Order selection: `order=None` fits 2, 4 and 6 and keeps the smallest BIC among the stable
models (all of them when none is stable).

An unstable estimate (a mode with ζ ≤ 0, i.e. |z| ≥ 1 once sampled: seen on real motor-pulse
records, where an extra slow mode absorbs what the linear model cannot explain) is not a
model of the carts: it comes back with `success=False`, `Model.stable` False and a message
naming the modes, never as converged.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from ident import subspace, varpro
from ident.data import FloatArray, IdData, input_jumps, make_uniform
from ident.errors import FitFailed, IdentValueError
from ident.innovation import refine
from ident.model import ModeEstimate, Model
from ident.physical_start import carts_at_peaks, physical_start
from ident.physics import fit_percent, spectral_peaks
from ident.release import check_motion, moving_outputs, noise_std
from ident.zoh import d2c_zoh

#: Orders tried by the order selection.
CANDIDATE_ORDERS = (2, 4, 6)
#: "auto" keeps the release from rest unless the estimated initial state lowers the BIC by more
#: than this (χ², 1 degree of freedom, α = 1e-3), as `ident.simple` does.
CHOICE_CHI2 = 10.83
InitialState = Literal["auto", "zero", "estimate"]


def pem(data: IdData, order: int | None = None, *, relative_degree: int | Sequence[int] = 2,
        dc_gain: float | Sequence[float | None] | None = None, fit_release: bool = True,
        fit_offset: bool = True, noise_model: Literal["oe", "innovation"] = "oe",
        initial_state: InitialState = "auto") -> Model:
    """Identify a linear model of even `order` (2: one cart, 4: two carts; None: BIC choice).

    `relative_degree` (per output or one for all) and `dc_gain` (per output, None = free)
    are the physical structure imposed as constraints: relative degree 2 is what every
    input structure of the lab implies. `noise_model="innovation"` then refines everything
    jointly with an innovation gain K by minimising one-step prediction errors
    (`ident.innovation`; white noise gives K ≈ 0). `fit_release=False` keeps the release fixed at
    `data.release_time_s` (e.g. from the run's metadata), or where `u` steps when that is None.
    `initial_state`: "zero", "estimate" or "auto" (the module docstring; "estimate" needs a step
    input and the output-error noise model).
    Raises `IdentValueError` for unusable data and `FitFailed` when no fit converges.
    """
    if order is None:
        models = [pem(data, n, relative_degree=relative_degree, dc_gain=dc_gain, fit_release=fit_release,
                      fit_offset=fit_offset, noise_model=noise_model, initial_state=initial_state)
                  for n in CANDIDATE_ORDERS]
        stable = [model for model in models if model.stable]
        return min(stable or models, key=lambda model: _bic(model, data))
    if order < 2 or order % 2:
        raise IdentValueError("order", "an even order ≥ 2 (2 per oscillatory mode) or None", order)
    check_motion(data.y)
    moving = sorted(moving_outputs(data.y))
    still = sorted(set(range(data.n_outputs)) - set(moving))
    if still:
        raise IdentValueError("y", "motion in every output: fit the moving carts only with "
                              f"pem(data.select_outputs({moving}), ...)",
                              f"no motion in output(s) {still} (a held cart?)")
    if initial_state not in ("auto", "zero", "estimate"):
        raise IdentValueError("initial_state", "'auto', 'zero' or 'estimate'", initial_state)
    if noise_model not in ("oe", "innovation"):
        raise IdentValueError("noise_model", "'oe' or 'innovation'", noise_model)
    step = input_jumps(data.u).size == 1
    if initial_state == "estimate" and not (step and noise_model == "oe"):
        raise IdentValueError("initial_state", "'zero' for a general input or noise_model='innovation' "
                              "('estimate' starts the carts moving at a release step)", initial_state)
    estimate = initial_state == "estimate" or (initial_state == "auto" and step and noise_model == "oe"
                                               and data.release_time_s is not None)
    degrees = _per_output(relative_degree, data.n_outputs, "relative_degree")
    gains = _per_output(dc_gain, data.n_outputs, "dc_gain")
    kinds = ([False] if initial_state != "estimate" else []) + ([True] if estimate else [])
    model = _choose(data, [_fit_or_failure(data, order, degrees, gains, fit_release, fit_offset, kind)
                           for kind in kinds])
    if noise_model == "innovation":
        if any(dc is not None for dc in gains):
            raise IdentValueError("dc_gain", "None with noise_model='innovation'", gains)
        model = refine(model, data if data.is_uniform() else make_uniform(data, "linear"))
    return flag_unstable(model)


def _fit_or_failure(data: IdData, order: int, degrees: tuple[int, ...], gains: tuple[float | None, ...],
                    fit_release: bool, fit_offset: bool, estimate: bool) -> Model | FitFailed:
    try:
        return _fit_order(data, order, degrees, gains, fit_release, fit_offset, estimate)
    except FitFailed as exc:
        return exc


def _choose(data: IdData, fits: list[Model | FitFailed]) -> Model:
    """The only model, or of [from rest, estimated state] the one from rest unless the other's
    BIC (both on the first one's noise weights) is lower by more than `CHOICE_CHI2`."""
    models = [fit for fit in fits if isinstance(fit, Model)]
    if not models:
        raise next(fit for fit in fits if isinstance(fit, FitFailed))
    if len(models) == 1:
        return models[0]
    noise = models[0].noise_std
    after = models[1].t >= float(models[1].release_time_s or models[1].t[0])   # the estimate's samples
    return models[1] if _bic(models[0], data, noise, after) - _bic(models[1], data, noise, after) > CHOICE_CHI2 \
        else models[0]


def _fit_order(data: IdData, order: int, degrees: tuple[int, ...], gains: tuple[float | None, ...],
               fit_release: bool, fit_offset: bool, estimate: bool) -> Model:
    """One model of `order`: released from rest, or with the initial state estimated."""
    problem, release0 = _problem(data, degrees, gains, fit_release, fit_offset, estimate)
    solution = _best_fit(problem, data, release0, order // 2)
    if problem.y.shape[1] > 1:
        solution = _reweighted(problem, solution)
    return _to_model(data, problem, solution)


def flag_unstable(model: Model) -> Model:
    """The model with `success=False` and a message naming the modes with ζ ≤ 0, when it has any."""
    if model.stable:
        return model
    modes = ", ".join(f"mode {i + 1} (wn = {model.modes[i].wn:.4g} rad/s, zeta = {model.modes[i].zeta:.4g})"
                      for i in model.unstable_modes)
    message = (f"unstable estimate: zeta <= 0 in {modes}: not a model of the carts; try another order, "
               f"the --input column or a shorter window (optimizer: {model.message})")
    return replace(model, success=False, message=message)


def _per_output(value: object, n_out: int, name: str) -> tuple[Any, ...]:
    if isinstance(value, (list, tuple)):
        if len(value) != n_out:
            raise IdentValueError(name, f"one value per output ({n_out})", len(value))
        return tuple(value)
    return (value,) * n_out


def _problem(data: IdData, relative_degree: tuple[int, ...], dc_gain: tuple[float | None, ...],
             fit_release: bool, fit_offset: bool, estimate: bool = False) -> tuple[varpro.Problem, float]:
    jumps = input_jumps(data.u)
    if jumps.size == 0:
        raise IdentValueError("u", "a step at the release (or an input that changes)", "a constant input")
    step = jumps.size == 1
    release0 = _release_start(data, jumps) if step else float(data.t[0])
    source = data if (step or data.is_uniform()) else make_uniform(data, "linear")
    weights = 1.0 / _noise_level(source, release0)
    known = data.release_time_s if data.release_time_s is not None else float(data.t[jumps[0] + 1])
    fixed = None if (fit_release and step and not estimate) else known
    problem = varpro.Problem(
        t=source.t, y=np.asarray(source.y), weights=weights, amplitude=data.step_amplitude,
        step=step, u=np.asarray(source.u), ts=source.sample_time(), relative_degree=relative_degree,
        dc_gain=dc_gain, fit_offset=fit_offset, fixed_release_s=fixed, initial_velocity=estimate)
    return problem, (release0 if fixed is None else fixed)


def _release_start(data: IdData, jumps: NDArray[np.intp]) -> float:
    """Start value of the release: the known one, else where u steps (whoever built `data`
    placed the step at the release; `ident.releases` finds it in a raw record)."""
    if data.release_time_s is not None:
        return data.release_time_s
    return float(data.t[int(jumps[0]) + 1])


def _noise_level(data: IdData, release0: float) -> FloatArray:
    """Noise std per output: from the rest before the release when there are ≥ 10 samples."""
    before = data.y[data.t < release0 - 0.02]
    rest = np.std(before, axis=0) if len(before) >= 10 else np.zeros(data.n_outputs)
    fallback = noise_std(data.y)
    return np.where(rest > 0.0, rest, fallback)


def _moesp_modes(data: IdData, n_modes: int) -> list[tuple[FloatArray, FloatArray]]:
    """Start values from PO-MOESP on the whole record (any input), converted by d2c."""
    uniform = make_uniform(data, "auto")
    try:
        a_d, b_d, _, _ = subspace.moesp(uniform.u, uniform.y, 2 * n_modes)
        a_c, _ = d2c_zoh(a_d, b_d, uniform.sample_time())
    except (ValueError, np.linalg.LinAlgError):
        return []
    found = subspace.oscillatory_modes(np.linalg.eigvals(a_c).astype(np.complex128), n_modes)
    return [] if found is None else [(np.abs(found[0]), found[1])]


def _start_modes(data: IdData, release0: float, n_modes: int,
                 step: bool = True) -> list[tuple[FloatArray, FloatArray]]:
    """Start values (σ, ω): subspace estimate first (free response after a step, MOESP for
    other inputs), then the physical model of the free response after a step
    (`ident.physical_start`), then one cart per spectral peak with ζ = 0.02 and 0.1."""
    starts = [] if step else _moesp_modes(data, n_modes)
    after = data.t > release0 + 0.02
    uniform = make_uniform(IdData(data.t[after], data.u[after], data.y[after]), "auto")
    ts = uniform.sample_time()
    peaks = spectral_peaks(uniform.y, ts, n_modes, fill=False)
    if peaks.size and step:
        q = subspace.decimation_for(float(np.max(peaks)), ts)
        try:  # + 1: the constant level; + 3: room for noise poles
            candidates = subspace.free_response_poles(uniform.y, ts, (2 * n_modes + 1, 2 * n_modes + 3), q)
        except (ValueError, np.linalg.LinAlgError):
            candidates = []
        for poles in candidates:
            found = subspace.oscillatory_modes(poles, n_modes, 0.8 * np.pi / (q * ts))
            if found is not None:
                starts.append((np.abs(found[0]), found[1]))
        physical = physical_start(uniform.y, ts, n_modes, peaks)
        if physical is not None:
            starts.append(physical)
    if peaks.size == n_modes:
        starts += [carts_at_peaks(peaks, zeta) for zeta in (0.02, 0.1)]
    if not starts:
        raise FitFailed(f"expected {n_modes} oscillatory modes in the response, found "
                        f"{peaks.size} spectral peaks")
    return starts


def _start_cost(problem: varpro.Problem, release0: float, sigma: FloatArray, omega: FloatArray) -> float:
    try:
        _, _, residuals = varpro.solve_linear(problem, release0, sigma, omega)
    except (ValueError, np.linalg.LinAlgError):
        return float("inf")
    return float(np.sum((residuals * problem.weights) ** 2))


def _best_fit(problem: varpro.Problem, data: IdData, release0: float, n_modes: int) -> varpro.Solution:
    """Refine from the start values in the order of their projected cost; stop at a good fit."""
    best: varpro.Solution | None = None
    starts = _start_modes(data, release0, n_modes, problem.step)
    starts.sort(key=lambda start: _start_cost(problem, release0, *start))
    for sigma, omega in starts:
        try:
            solution = varpro.fit(problem, release0, sigma, omega)
        except (ValueError, np.linalg.LinAlgError):
            continue
        if best is None or solution.cost < best.cost:
            best = solution
        if min(fit_percent(problem.y, problem.y - solution.residuals)) > 95.0:
            break
    if best is None:
        raise FitFailed(f"no start value led to a converged fit of {2 * n_modes} states")
    return best


def _reweighted(problem: varpro.Problem, solution: varpro.Solution) -> varpro.Solution:
    """Refit with weights 1/(residual std) when they differ from the noise-based ones by > 20 %."""
    residual_std = np.std(solution.residuals, axis=0)
    ratio = (1.0 / problem.weights) / np.maximum(residual_std, 1e-15)
    if np.max(ratio) / np.min(ratio) < 1.2:
        return solution
    reweighted = replace(problem, weights=1.0 / np.maximum(residual_std, 1e-15))
    return varpro.fit(reweighted, solution.release_time_s, solution.sigma, solution.omega)


def mode_estimates(sigma: FloatArray, omega: FloatArray, covariance: FloatArray,
                   offset_index: int) -> tuple[ModeEstimate, ...]:
    """wn = √(σ² + ω²), ζ = σ/wn with delta-method standard errors from cov(σ, ω)."""
    m = len(sigma)
    estimates = []
    for i in range(m):
        s, w = float(sigma[i]), float(omega[i])
        wn = float(np.hypot(s, w))
        idx = [offset_index + i, offset_index + m + i]
        cov = covariance[np.ix_(idx, idx)]
        grad_wn = np.array([s / wn, w / wn])
        grad_zeta = np.array([w * w / wn ** 3, -s * w / wn ** 3])
        estimates.append(ModeEstimate(wn, s / wn, float(np.sqrt(max(grad_wn @ cov @ grad_wn, 0.0))),
                                      float(np.sqrt(max(grad_zeta @ cov @ grad_zeta, 0.0)))))
    return tuple(estimates)


def _to_model(data: IdData, problem: varpro.Problem, solution: varpro.Solution) -> Model:
    jumps = input_jumps(data.u)
    step_time = float(data.t[jumps[0] + 1])
    release = solution.release_time_s if problem.step else None
    order = np.argsort(solution.omega)
    sigma, omega = solution.sigma[order], solution.omega[order]
    m = len(sigma)
    theta = solution.theta.copy()
    for new, old in enumerate(order):
        theta[:, 1 + 2 * new:3 + 2 * new] = solution.theta[:, 1 + 2 * old:3 + 2 * old]
    offset_index = 1 if solution.free_release else 0
    perm = np.concatenate([np.arange(offset_index), offset_index + order, offset_index + m + order])
    covariance = solution.covariance[np.ix_(perm, perm)]
    modes = mode_estimates(sigma, omega, covariance, offset_index)
    fit = tuple(fit_percent(problem.y, problem.y - solution.residuals))
    return Model(sigma=sigma, omega=omega, theta=theta, offset=solution.offset, t=problem.t,
                 input_delay_s=(release - step_time) if release is not None else 0.0,
                 release_time_s=release, relative_degree=problem.relative_degree, modes=modes,
                 fit_percent=fit, noise_std=1.0 / problem.weights, residuals=solution.residuals,
                 covariance=covariance, method=f"pem-oe-ct order {2 * m}", nfev=solution.nfev,
                 success=solution.success, message=solution.message, notes=data.notes,
                 initial_velocity=None if solution.velocity is None else solution.velocity[:, order])


def _bic(model: Model, data: IdData, noise_std: FloatArray | None = None,
         samples: NDArray[np.bool_] | None = None) -> float:
    """N log(RSS/N) + p log N over all outputs, residuals over `noise_std` (default: the model's
    own weights). p: modes, the release (fitted from rest), free linear coefficients: numerator
    coefficients after the relative-degree constraints, order + 1 - r per output, one more per
    output with the initial state estimated (m velocities in place of m - 1 free s-terms).
    `samples` (N,) picks the samples counted (default: all)."""
    residuals = model.residuals if samples is None else model.residuals[samples]
    n_total = residuals.size
    rss = float(np.sum((residuals / (model.noise_std if noise_std is None else noise_std)) ** 2))
    numerators = sum(model.order + 1 - r for r in model.relative_degree)
    estimated = model.initial_velocity is not None
    n_params = (2 * len(model.sigma) + (0 if estimated else 1) + numerators + model.offset.size
                + (model.n_outputs if estimated else 0))
    return n_total * np.log(rss / n_total) + n_params * np.log(n_total)
