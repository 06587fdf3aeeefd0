"""`diagnose(t, y)`: baseline, evidence, candidates, choice, extended model, gain.

Steps (arrays in, a `Diagnosis` out; no files, clocks or printing):
1. window (`window.find_window`): hold level, where the hand's influence ends, release time;
   the window is decimated to at most `MAX_WORK_SAMPLES` work samples;
2. split: even work samples train every fit, odd work samples validate (held out);
3. baseline: the linear physical model (one cart or the chain) from the window start with
   its state (x0, v0) and rest positions (= the step, unless given) as parameters;
4. evidence from the baseline residual and the measured extrema (`evidence.collect`);
5. every extension fitted to the training samples from evidence-based start values
   (`candidates`);
6. choice on validation by likelihood ratio against the noise (`select`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ident.diagnose import explain
from ident.diagnose.candidates import Problem, fit_baseline, fit_candidates
from ident.diagnose.evidence import EvidenceResult, collect
from ident.diagnose.fitting import FitResult
from ident.diagnose.lattice import find_lattice
from ident.diagnose.models import effect_names
from ident.diagnose.select import fit_percent, likelihood_ratio, thresholds
from ident.diagnose.window import Window, find_window
from ident.errors import IdentDimensionError, IdentValueError
from ident.physics.chain import LINEAR_NAMES, modes
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


def diagnose(t: FloatArray, y: FloatArray, carts: int | None = None, step_m: float | None = None,
             source: str = "") -> Diagnosis:
    """Diagnose a release run: `t` (N,) s uniform, `y` (N,) or (N, n_out) m."""
    started = time.perf_counter()
    t_arr, y_arr = _check(t, y)
    carts = carts or min(y_arr.shape[1], 2)
    y_arr = _select_outputs(y_arr, carts)
    win = find_window(t_arr, y_arr, carts)
    idx = np.arange(win.start, t_arr.size, win.decimation)
    prob = Problem(t_arr[idx] - t_arr[win.start], y_arr[idx], float(t_arr[1] - t_arr[0]) * win.decimation,
                    np.arange(idx.size) % 2 == 0, carts, float(np.max(np.ptp(y_arr[idx], axis=0))))
    fixed = _fixed_rest(win, carts, step_m)
    base = fit_baseline(prob, fixed)
    lattice, coherence = find_lattice(y_arr[win.start:])
    wn_modes = np.array([w for w, _ in modes(base.theta[None, :len(LINEAR_NAMES[carts])], carts)])
    rest = base.theta[len(LINEAR_NAMES[carts]) + 2 * carts:len(LINEAR_NAMES[carts]) + 3 * carts]
    ev = collect(prob.tau, prob.y, base.prediction, rest, wn_modes, lattice)
    fits = fit_candidates(prob, base, ev, fixed, wn_modes)
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


def _candidate(prob: Problem, base: FitResult, cand: FitResult, effect: str) -> Candidate:
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


def _no_lattice(prob: Problem, base: FitResult) -> Candidate:
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


def _model_fit(prob: Problem, res: FitResult, name: str) -> ModelFit:
    val = ~prob.train
    per = fit_percent(prob.y[val], res.prediction[val])
    return ModelFit(model=name, fit_percent=float(np.mean(per)), fit_percent_per_output=per,
                    parameters=res.parameters(), parameter_std=res.parameter_std())


def _report(prob: Problem, win: Window, t: FloatArray, base: FitResult, ext: FitResult,
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
