"""`diagnose(t, y)`: baseline, evidence, candidates, choice, extended model, gain.

Steps (arrays in, a `Diagnosis` out; no files, clocks or printing):
1. window (`window.find_window`): hold level, where the hand's influence ends, release time;
   the window is decimated to at most `MAX_WORK_SAMPLES` work samples;
2. split: even work samples train every fit, odd work samples validate (held out);
3. baseline: the linear physical model (one cart or the chain) from the window start with
   its state (x0, v0) and rest positions (= the step, unless given) as parameters;
4. evidence from the baseline residual and the measured extrema (`evidence.collect`);
5. every extension fitted to the training samples from evidence-based start values;
6. choice on validation by likelihood ratio against the noise (`select`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ident.diagnose import explain, starts
from ident.diagnose.chain import LINEAR_NAMES, modes
from ident.diagnose.evidence import EvidenceResult, collect
from ident.diagnose.fitting import FitResult, evaluate, fit
from ident.diagnose.lattice import find_lattice
from ident.diagnose.modal import fit_modes, project, spectral_peaks
from ident.diagnose.models import EFFECTS, ModelSpec, effect_names
from ident.diagnose.select import fit_percent, likelihood_ratio, thresholds
from ident.diagnose.window import Window, find_window
from ident.errors import IdentDimensionError, IdentValueError
from schemas.diagnosis import Candidate, DiagnosisReport, Evidence, ModelFit

FloatArray = NDArray[np.float64]

MODEL_NAMES = {1: "single cart m x'' + c x' + k (x - rest) = 0",
               2: "two-cart chain M x'' + C x' + K (x - rest) = 0"}


@dataclass(frozen=True)
class Diagnosis:
    """The report plus the arrays its figures need (work samples of the window)."""

    report: DiagnosisReport
    t: FloatArray                # (N,) s, run time base
    y: FloatArray                # (N, carts) m measured
    baseline: FloatArray         # (N, carts) m simulated linear model
    extended: FloatArray         # (N, carts) m simulated extended model
    train: NDArray[np.bool_]     # (N,) samples the fits used
    extrema: FloatArray          # (K, 2) time (s, run base) and |y - rest| (m)


@dataclass(frozen=True)
class _Problem:
    tau: FloatArray
    y: FloatArray
    dt: float
    train: NDArray[np.bool_]
    carts: int
    amplitude: float


def diagnose(t: FloatArray, y: FloatArray, carts: int | None = None, step_m: float | None = None,
             source: str = "") -> Diagnosis:
    """Diagnose a release run: `t` (N,) s uniform, `y` (N,) or (N, n_out) m."""
    started = time.perf_counter()
    t_arr, y_arr = _check(t, y)
    carts = carts or min(y_arr.shape[1], 2)
    y_arr = _select_outputs(y_arr, carts)
    win = find_window(t_arr, y_arr, carts)
    idx = np.arange(win.start, t_arr.size, win.decimation)
    prob = _Problem(t_arr[idx] - t_arr[win.start], y_arr[idx], float(t_arr[1] - t_arr[0]) * win.decimation,
                    np.arange(idx.size) % 2 == 0, carts, float(np.max(np.ptp(y_arr[idx], axis=0))))
    fixed = _fixed_rest(win, carts, step_m)
    base = _fit_baseline(prob, fixed)
    lattice, coherence = find_lattice(y_arr[win.start:])
    wn_modes = np.array([w for w, _ in modes(base.theta[None, :len(LINEAR_NAMES[carts])], carts)])
    rest = base.theta[len(LINEAR_NAMES[carts]) + 2 * carts:len(LINEAR_NAMES[carts]) + 3 * carts]
    ev = collect(prob.tau, prob.y, base.prediction, rest, wn_modes, lattice)
    fits = _fit_candidates(prob, base, ev, fixed, wn_modes)
    candidates = [_candidate(prob, base, f, effect) for effect, f in fits.items()]
    if "quantization" not in fits:
        candidates.insert(3, _no_lattice(prob, base))
    chosen = _choose(candidates)
    ext = fits[chosen] if chosen != "none" else base
    report = _report(prob, win, t_arr, base, ext, candidates, chosen, ev, coherence, step_m,
                     source, time.perf_counter() - started)
    extrema = ev.extrema.copy()
    extrema[:, 0] += t_arr[win.start]
    return Diagnosis(report, t_arr[idx], prob.y, base.prediction, ext.prediction, prob.train, extrema)


def _check(t: FloatArray, y: FloatArray) -> tuple[FloatArray, FloatArray]:
    t_arr = np.asarray(t, dtype=np.float64)
    y_arr = np.asarray(y, dtype=np.float64)
    if y_arr.ndim == 1:
        y_arr = y_arr[:, None]
    if t_arr.ndim != 1 or y_arr.ndim != 2 or y_arr.shape[0] != t_arr.shape[0]:
        raise IdentDimensionError("t, y", "t (N,) and y (N,) or (N, n_out)",
                                  f"t {t_arr.shape}, y {y_arr.shape}")
    if t_arr.size < 50:
        raise IdentValueError("run length", "at least 50 samples", t_arr.size)
    if not (np.all(np.isfinite(t_arr)) and np.all(np.isfinite(y_arr))):
        raise IdentValueError("t, y", "finite values", "NaN or inf")
    dt = np.diff(t_arr)
    if np.any(dt <= 0) or np.ptp(dt) > 0.01 * float(np.median(dt)):
        raise IdentValueError("time steps", "a uniform increasing grid (use ident.make_uniform)",
                              f"steps from {dt.min():.6g} to {dt.max():.6g} s")
    return t_arr, y_arr


def _select_outputs(y: FloatArray, carts: int) -> FloatArray:
    if carts not in (1, 2):
        raise IdentValueError("carts", "1 or 2", carts)
    if y.shape[1] < carts:
        raise IdentDimensionError("positions", f"{carts} position columns", y.shape[1])
    if carts == 1 and y.shape[1] > 1:
        return y[:, [int(np.argmax(np.ptp(y, axis=0)))]]
    return y[:, :carts]


def _fixed_rest(win: Window, carts: int, step_m: float | None) -> dict[int, float]:
    if step_m is None:
        return {}
    first = len(LINEAR_NAMES[carts]) + 2 * carts
    rest = {first: float(win.hold[0] + step_m)}
    if carts == 2:
        rest[first + 1] = float(win.hold[1])
    return rest


def _fit_baseline(prob: _Problem, fixed: dict[int, float]) -> FitResult:
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


def _fit_candidates(prob: _Problem, base: FitResult, ev: EvidenceResult, fixed: dict[int, float],
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


def _fit_friction(spec: ModelSpec, prob: _Problem, theta0: FloatArray, lower: FloatArray,
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


def _large_amplitude_samples(prob: _Problem, ev: EvidenceResult) -> int:
    """Work samples up to a quarter period after the last peak above 30 % of the first."""
    amps = ev.extrema[:, 1]
    n = prob.tau.size
    if amps.size < 4:
        return n
    last = float(ev.extrema[np.flatnonzero(amps >= 0.3 * amps[0])[-1], 0])
    quarter = 0.25 * (ev.extrema[-1, 0] - ev.extrema[0, 0]) / max(amps.size - 1, 1) * 2
    return int(min(n, max(np.searchsorted(prob.tau, last + quarter), 40)))


BLURS = (0.01, 0.03, 0.06, 0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.45)


def _fit_staircase(spec: ModelSpec, prob: _Problem, base: FitResult, ev: EvidenceResult) -> FitResult:
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


def _effect_start(effect: str, prob: _Problem, base: FitResult, ev: EvidenceResult,
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


def _candidate(prob: _Problem, base: FitResult, cand: FitResult, effect: str) -> Candidate:
    val = ~prob.train
    n_tr, n_val = base.n_train, base.n_val
    extra = len(effect_names(effect, prob.carts))
    lr_tr = likelihood_ratio(n_tr, base.sse_train, cand.sse_train)
    lr_val = likelihood_ratio(n_val, base.sse_val, cand.sse_val)
    th_tr, th_val = thresholds(extra, effect == "coupled_mode", n_tr)
    fit_b = float(np.mean(fit_percent(prob.y[val], base.prediction[val])))
    fit_c = float(np.mean(fit_percent(prob.y[val], cand.prediction[val])))
    params = {k: v for k, v in cand.parameters().items() if k in effect_names(effect, prob.carts)}
    std = {k: v for k, v in cand.parameter_std().items() if k in params}
    return Candidate(effect=effect, parameters=params, parameter_std=std, fit_percent=fit_c,  # type: ignore[arg-type]
                     gain_points=fit_c - fit_b, extra_parameters=extra, lr_train=lr_tr,
                     lr_validation=lr_val, threshold_train=th_tr, threshold_validation=th_val,
                     significant=bool(lr_tr > th_tr and lr_val > th_val))


def _no_lattice(prob: _Problem, base: FitResult) -> Candidate:
    """The quantization candidate when the samples lie on no lattice: nothing to model."""
    fit_b = float(np.mean(fit_percent(prob.y[~prob.train], base.prediction[~prob.train])))
    th_tr, th_val = thresholds(len(effect_names("quantization", prob.carts)), False, base.n_train)
    return Candidate(effect="quantization", parameters={}, fit_percent=fit_b, gain_points=0.0,
                     extra_parameters=len(effect_names("quantization", prob.carts)), lr_train=0.0,
                     lr_validation=0.0, threshold_train=th_tr, threshold_validation=th_val,
                     significant=False, note="the measured positions lie on no lattice (no encoder steps)")


def _choose(candidates: list[Candidate]) -> str:
    called = [c for c in candidates if c.significant]
    if not called:
        return "none"
    return max(called, key=lambda c: c.lr_validation).effect


def _model_fit(prob: _Problem, res: FitResult, name: str) -> ModelFit:
    val = ~prob.train
    per = fit_percent(prob.y[val], res.prediction[val])
    return ModelFit(model=name, fit_percent=float(np.mean(per)), fit_percent_per_output=per,
                    parameters=res.parameters(), parameter_std=res.parameter_std())


def _report(prob: _Problem, win: Window, t: FloatArray, base: FitResult, ext: FitResult,
            candidates: list[Candidate], chosen: str, ev: EvidenceResult, coherence: float,
            step_m: float | None, source: str, elapsed: float) -> DiagnosisReport:
    carts = prob.carts
    n_lin = len(LINEAR_NAMES[carts])
    rest = ext.theta[n_lin + 2 * carts:n_lin + 3 * carts]
    base_fit = _model_fit(prob, base, MODEL_NAMES[carts])
    ext_fit = (base_fit if chosen == "none" else
               _model_fit(prob, ext, f"{MODEL_NAMES[carts]} + {chosen}"))
    corrected = explain.linear_summary(ext.theta[:n_lin], carts)
    evidence = Evidence(
        residual_rms_m=ev.residual_rms_m, noise_std_m=ev.noise_std_m,
        whiteness_fraction_outside=ev.whiteness_fraction_outside,
        residual_is_white=ev.residual_is_white, residual_peak_hz=ev.residual_peak_hz,
        residual_peak_to_baseline_ratio=ev.residual_peak_to_baseline_ratio,
        envelope_shape=ev.envelope_shape,  # type: ignore[arg-type]
        envelope_peaks=ev.envelope_peaks, envelope_step_m=ev.envelope_step_m,
        envelope_ratio=ev.envelope_ratio, frequency_drift_per_m2=ev.frequency_drift_per_m2,
        rest_offset_m=ev.rest_offset_m, stuck_for_s=ev.stuck_for_s,
        lattice_quantum_m=ev.lattice.quantum_m if ev.lattice is not None else None,
        lattice_coherence=coherence, second_frequency_hz=ev.second_frequency_hz)
    gain = ext_fit.fit_percent - base_fit.fit_percent if chosen != "none" else 0.0
    report = DiagnosisReport(
        source=source, carts=carts, sample_rate_hz=1.0 / float(t[1] - t[0]),
        release_time_s=win.release_time_s, window_start_s=float(t[win.start]),
        window_end_s=float(t[-1]), step_m=[float(r - h) for r, h in zip(rest, win.hold)],
        step_estimated=step_m is None, baseline=base_fit, candidates=candidates,
        cause=chosen,  # type: ignore[arg-type]
        extended=ext_fit, gain_points=gain,
        corrected_linear=corrected, evidence=evidence,
        validation=explain.validation_text(win.decimation, prob.train.size),
        explanation="", elapsed_s=elapsed)
    return report.model_copy(update={"explanation": explain.explanation(report, base.theta[:n_lin])})
