"""`diagnose(t, y)`: baseline, evidence, forward selection of effects, the extended model.

Steps (arrays in, a `Diagnosis` out; no files, clocks or printing):
1. window (`stretch.release_stretch`: the release `ident.releases` finds unless given, and
   `window.find_window`): hold level, where the hand's influence ends, release time;
   the window is decimated to at most `MAX_WORK_SAMPLES` work samples (with a force input
   the window is the whole record: the input, not a hand, starts the motion);
2. baseline: the linear physical model (one cart or the chain) from the window start with
   its state (x0, v0) and rest positions (= the step, unless given) as parameters, fitted
   on every work sample (simulated output error);
3. evidence from the baseline residual and the measured extrema (`evidence.collect`);
4. forward selection (`select.forward`): each available effect added to the current model
   and refitted; the best by blocked cross-validation kept while it beats the noise; then
   backward elimination (`backward.settle`), and, when it took effects out, forward
   selection once more from the model it left (`_stepwise`);
5. the report: every accepted effect ranked by its own gain, the headline (largest material
   effect), the whole-window fit of the final model; a flick's release dated again on the
   final model (`redate.redated_release`).

A single-cart diagnosis of a record with a second, held cart (its swing under
`HELD_FRACTION` of the free cart's) offers that cart's measured motion as an input
(`held_cart_motion`).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

from ident import progress, summary
from ident.diagnose import candidates as cands
from ident.diagnose import explain
from ident.diagnose.anchor import anchor_of, still_start, still_until
from ident.diagnose.backward import settle
from ident.diagnose.candidates import Problem, fit_baseline
from ident.diagnose.drift import drift_basis, drift_spacing, slow_residual
from ident.diagnose.evidence import EvidenceResult, collect
from ident.diagnose.fine import refit_fine
from ident.diagnose.fitting import FitResult
from ident.diagnose.held_error import read_held, with_input_error
from ident.diagnose.held_fit import work_grid
from ident.diagnose.identifiable import identifiable_friction, identifiable_model, one_encoder, typical_scale
from ident.diagnose.lattice import (
    Lattice,
    find_lattice,
    find_noisy_lattice,
    lattice_candidates,
    lattice_worth_points,
    reading_noise,
)
from ident.diagnose.models import EFFECTS, effect_names
from ident.diagnose.reading_error import with_reading_error
from ident.diagnose.redate import redated_release
from ident.diagnose.select import Judgement, Selection, Step, forward, is_material, threshold
from ident.diagnose.stretch import Stretch, check, check_input, moving, release_stretch, resolving_decimation
from ident.diagnose.window import Window
from ident.errors import IdentDimensionError, IdentValueError
from ident.physics.chain import LINEAR_NAMES, modes
from ident.physics.free import switched_input
from ident.physics.measures import fit_percent
from schemas.diagnosis import Candidate, DiagnosisReport, EffectFit, Evidence, ModelFit

_T = TypeVar("_T")

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

    def summary_rows(self) -> list[tuple[str, str]]:
        """The labelled lines of `repr` and `_repr_html_` (the arrays stay in the attributes)."""
        r = self.report
        rows = [("window", f"{r.window_start_s:.3f} … {r.window_end_s:.3f} s, {r.sample_rate_hz:.4g} Hz, "
                           f"release at {r.release_time_s:.3f} s"),
                ("linear", f"{r.baseline.fit_percent:.3f} % ({r.baseline.model})"),
                ("extended", f"{r.extended.fit_percent:.3f} % ({r.gain_points:+.3f} points)")]
        rows += [(f"effect {e.rank}", f"{e.effect}: {e.gain_points:+.3f} points"
                                      + ("" if e.material else " (immaterial)")) for e in r.effects]
        rows.append(("see", "diagnosis.report (every number, JSON: .model_dump_json()), .t, .y, .baseline"))
        return rows

    def _title(self) -> str:
        return f"Diagnosis {self.report.source!r}: cause {self.report.cause}"

    def __repr__(self) -> str:
        return summary.text(self._title(), self.summary_rows())

    def _repr_html_(self) -> str:
        return summary.html_table(self._title(), self.summary_rows())


def diagnose(t: FloatArray, y: FloatArray, carts: int | None = None, step_m: float | None = None,
             source: str = "", u: FloatArray | None = None, start_s: float | None = None,
             stop_s: float | None = None, readings: FloatArray | None = None) -> Diagnosis:
    """Diagnose a release run: `t` (N,) s uniform, `y` (N,) or (N, n_out) m, `u` (N,) or
    (N, m) a measured force input (any unit), `start_s`/`stop_s` the stretch to use (a
    release window on the run's time base, `start_s` its release as `ident.releases` dates
    it: the fit starts there; by default, without a force input, the first complete release
    `ident.releases` finds, up to the next release, dated by the window's scan
    (`window.find_window`), for one cart from the later of the two; `stretch.release_stretch`). `carts`
    (1 or 2) by default counts the columns that swing at least `HELD_FRACTION` of the largest:
    a cart that moves less is held (by a hand that wanders) and enters as measured input.
    `readings` (M, n_out): the same record's positions as read, when `y` was resampled from
    them (`ident.make_uniform` interpolates an uneven clock's samples): its encoder lattice is
    looked for there, as a position interpolated between two readings lies between the
    lattice's levels (on the ECP-210 records, whose samples were interpolated a third of a
    step off, a lattice of a third of the encoder's count had been found)."""
    started = time.perf_counter()
    as_read = None if readings is None else _readings_of(readings, y)
    outputs = moving(y, carts)   # before anything is fitted: a still column has no fit %
    t_arr, y_arr = check(t, outputs.y)
    u_in = check_input(u, t_arr.size)
    cut = release_stretch(t_arr, y_arr, u_in, carts, start_s, stop_s)
    prob, fixed = _work_problem(cut, step_m)
    progress.stage("diagnosis: the linear baseline")
    base = fit_baseline(prob, fixed)
    n_lin = len(LINEAR_NAMES[cut.carts])
    finest = resolving_decimation(max(w for w, _ in modes(base.theta[None, :n_lin], cut.carts)),
                                  float(t_arr[1] - t_arr[0]))
    if u_in is None and finest < cut.win.decimation:
        # the work grid too coarse for the fitted modes: finer, cut where its samples run out
        cut = release_stretch(t_arr, y_arr, u_in, carts, start_s, stop_s, finest)
        prob, fixed = _work_problem(cut, step_m)
        base = fit_baseline(prob, fixed)
    t_arr, y_all, u_arr, carts, y_arr, other, win = (cut.t, cut.y_all, cut.u, cut.carts, cut.y, cut.other,
                                                      cut.win)
    idx = np.arange(win.start, t_arr.size, win.decimation)
    lattice, coherence = find_lattice(y_arr[win.start:])
    read = None    # the readings' lattice, when the positions were resampled between its levels
    if lattice is None and as_read is not None:
        read, coherence = find_lattice(as_read[:, list(outputs.kept)])
    if lattice is None and read is None:   # noise after the encoder: a lattice proposed, kept only if it fits
        lattice = find_noisy_lattice(y_arr[win.start:])
        coherence = lattice.coherence if lattice is not None else coherence
    wn_modes = np.array([w for w, _ in modes(base.theta[None, :n_lin], carts)])
    prob, base = _with_drift(prob, base, float(wn_modes[0]))
    held = None
    if other is not None:   # the held cart's reading as an input: its noise filtered away
        found = lattice if lattice is not None else read
        held = read_held(y_all[win.start:, other], y_arr[win.start:, 0], float(t_arr[1] - t_arr[0]),
                         float(wn_modes[0]), 0.0 if found is None else found.quantum_m)
        smooth = work_grid(held.motion, win.decimation)
        prob = dataclasses.replace(prob, held=smooth)
        base = dataclasses.replace(base, spec=dataclasses.replace(base.spec, held=smooth))
    rest = base.theta[n_lin + 2 * carts:n_lin + 3 * carts]
    ev = collect(prob.tau, prob.y, base.prediction, rest, wn_modes, lattice)
    if read is None and (lattice is None or lattice.levels == 0):   # no exact encoder steps: fainter lattices too
        ev = dataclasses.replace(ev, lattice_proposals=tuple(lattice_candidates(y_arr[win.start:])))
    selection = _stepwise(prob, ev, wn_modes, base, carts)
    steps, first_round, base, last = selection.steps, selection.first_round, selection.baseline, selection.last
    ext = steps[-1].judgement.result if steps else base
    final = (prob, ext)
    if last is not None and steps:
        progress.stage("diagnosis: the final model on every sample")
        final = refit_fine(prob, ext, last, win, t_arr, y_arr, None if held is None else held.motion, u_arr)
    # the σ of a residual that is not white, and of the carts' reading on their lattice (a stuck
    # cart's level: one error for the whole stuck stretch)
    after = 0.0 if lattice is None or lattice.levels > 0 else reading_noise(lattice)
    final = (final[0], with_reading_error(final[1], final[0].dt, final[0].y,
                                          0.0 if lattice is None else lattice.quantum_m, after))
    if held is not None:   # the held reading's error in the parameters' σ (errors in variables)
        steps_per_work = max(1, round(final[0].dt / float(t_arr[1] - t_arr[0])))
        final = (final[0], with_input_error(final[1], final[0].dt, final[0].y, held, steps_per_work))
    redated = redated_release(t_arr, y_arr, win, final[1])
    if redated is not None:   # a flick's let-go joined on the fitted model's free response
        win = dataclasses.replace(win, release_time_s=redated)
    effects = _ranked(prob, steps, y_arr[win.start:], final, base)
    cause = next((e.effect for e in effects if e.material), "none")
    report = _report(prob, win, t_arr, base, ext, first_round, effects, cause, ev, coherence, step_m,
                     source, time.perf_counter() - started, start_s is not None or stop_s is not None, final, read)
    if outputs.dropped:
        report = report.model_copy(update={"validation": f"{report.validation}; {outputs.note()}"})
    extrema = ev.extrema.copy()
    extrema[:, 0] += t_arr[win.start]
    return Diagnosis(report, t_arr[idx], prob.y, base.prediction, ext.prediction, prob.train, extrema)


def _stepwise(prob: Problem, ev: EvidenceResult, wn_modes: FloatArray, base: FitResult, carts: int) -> Selection:
    """Forward selection, backward elimination (`backward.settle`), and once more forward from
    the model the elimination left when it took effects out (their own return excluded): an
    effect a dropped one had excluded may then enter (static friction is not tried beside
    pre-sliding friction; testkit `coulomb+held_cart`, seed 51 case 40: pre-sliding stood in
    for the breakaway and the held cart's pull until the coupling came in, was dropped, and
    the fit ended 1.4 points under its noise floor with the coupling 56 % off), and eliminated
    again."""
    def without(trial: cands.Trial, result: FitResult, refit: int) -> FitResult:
        return cands.without(prob, trial, result, refit)

    def effects(current: FitResult, removed: frozenset[str]) -> list[str]:
        return [e for e in EFFECTS if e not in removed and cands.available(e, current.spec, prob, ev)
                and (e != "rest_drift" or slow_residual(prob, current.prediction))]

    def select(removed: frozenset[str], resume: Selection | None) -> Selection:
        return forward(
            resume.baseline if resume is not None else base, lambda cur: effects(cur, removed),
            lambda cur, e: _staged(f"diagnosis: screening {e}", lambda: cands.screen(prob, cur, e, ev, wn_modes)),
            lambda trial: _staged(f"diagnosis: fitting {trial.effect}", lambda: cands.refine(prob, trial)),
            carts, without, resume)

    def settled(selection: Selection) -> tuple[Selection, frozenset[str]]:
        """The selection after the elimination, and the effects it took out."""
        if selection.last is None or len(selection.steps) < 2:
            return selection, frozenset()
        progress.stage("diagnosis: backward elimination")
        elimination = settle(selection.steps, selection.last, without, carts)
        kept = {s.judgement.effect for s in elimination.steps}
        return (dataclasses.replace(selection, steps=elimination.steps, last=elimination.last),
                frozenset(s.judgement.effect for s in selection.steps) - kept)

    selection, removed = settled(select(frozenset(), None))
    if not removed:
        return selection
    resumed = select(removed, selection)
    if len(resumed.steps) == len(selection.steps):
        return selection
    return settled(resumed)[0]


def _readings_of(readings: FloatArray, y: FloatArray) -> FloatArray:
    """`readings` (M,) or (M, k) as (M, k) floats, k the columns of `y`."""
    arr = np.asarray(readings, dtype=np.float64)
    arr = arr[:, None] if arr.ndim == 1 else arr
    k = 1 if np.ndim(y) == 1 else int(np.shape(y)[1])
    if arr.ndim != 2 or arr.shape[1] != k:
        raise IdentDimensionError("readings", f"(M, {k}): the columns of y as read", f"shape {arr.shape}")
    return arr


def _with_drift(prob: Problem, base: FitResult, wn: float) -> tuple[Problem, FitResult]:
    """The problem and the baseline's model carrying the rest drift's spline basis (knots
    `drift.DRIFT_PERIODS` periods of the main mode apart), for one cart with no measured held
    cart or input; unchanged otherwise or when the window is too short for it."""
    if prob.carts != 1 or prob.held is not None or prob.inputs is not None:
        return prob, base
    spacing = drift_spacing(wn)
    basis = drift_basis(prob.tau, spacing)
    if basis is None:
        return prob, base
    prob = dataclasses.replace(prob, drift=basis, drift_spacing_s=spacing)
    spec = dataclasses.replace(base.spec, drift=basis, fixed={**base.spec.fixed, "drift_spacing_s": spacing})
    return prob, dataclasses.replace(base, spec=spec)


def _staged(label: str, work: Callable[[], _T]) -> _T:
    """`work()` with `label` shown by a command's progress display (a no-op in library use)."""
    progress.stage(label)
    return work()


def _work_problem(cut: Stretch, step_m: float | None) -> tuple[Problem, dict[str, float]]:
    """The fit's problem on the work grid of a stretch (its window decimated), and the rests it
    fixes (`_fixed_rest`)."""
    t_arr, y_arr, u_arr, win, dt = cut.t, cut.y, cut.u, cut.win, float(cut.t[1] - cut.t[0])
    idx = np.arange(win.start, t_arr.size, win.decimation)
    held = None if cut.other is None else cut.y_all[idx, cut.other] - cut.y_all[idx[0], cut.other]
    # a measured force input is held from sample to sample: so it is simulated, switching
    # within a work step where the record's samples switch it (each step's impulse kept); the
    # carts rest at a zero input (`ident.data.input_jumps`): a drive on from the first sample
    # acts from there (taken relative to that sample, the 2023 test_3_7's step was left to the
    # carts' fitted rest and its friction credited +0.07 points)
    work_u = None if u_arr is None else switched_input(u_arr[win.start:], win.decimation)
    prob = Problem(t_arr[idx] - t_arr[win.start], y_arr[idx], dt * win.decimation,
                   np.ones(idx.size, dtype=bool), cut.carts, float(np.max(np.ptp(y_arr[idx], axis=0))),
                   held, None if work_u is None else work_u[0],
                   anchor=anchor_of(win, dt, y_arr[win.start:], y_arr[idx]),
                   input_switch=None if work_u is None else work_u[1],
                   still_until=0 if work_u is None else still_until(work_u[0], y_arr[idx]))
    return prob, {**_fixed_rest(win, cut.carts, step_m), **still_start(prob)}


def _fixed_rest(win: Window, carts: int, step_m: float | None) -> dict[str, float]:
    if step_m is None:
        return {}
    rest = {"rest_1_m": float(win.hold[0] + step_m)}
    if carts == 2 and win.hold.size > 1:
        rest["rest_2_m"] = float(win.hold[1])
    return rest


def _fit_points(prob: Problem, res: FitResult) -> float:
    return _mean_defined(fit_percent(prob.y, res.prediction))


def _mean_defined(per_output: list[float]) -> float:
    """Mean fit % over the outputs that move: one that never moves (a held cart reading 0)
    has no fit % (`fit_percent` gives -inf), and must not turn the record's mean into -inf."""
    defined = [f for f in per_output if np.isfinite(f)]
    if not defined:
        raise IdentValueError("outputs", "at least one output that moves", "every output constant")
    return float(np.mean(defined))


def _candidate(prob: Problem, base: FitResult, j: Judgement) -> Candidate:
    params, std = cands.effect_parameters(j.result, j.effect)
    base_fit = _fit_points(prob, base)
    if not np.all(np.isfinite(j.result.prediction)):
        # a candidate whose simulation ran off (a strong cubic, two sticking carts' events):
        # listed as not fitted, never a gain (its NaN fit % had been read as 'every output
        # constant' and the whole diagnosis refused: red team two_cart_coulomb_y1 seed 502)
        return Candidate(effect=j.effect, parameters=params, parameter_std={}, fit_percent=base_fit,  # type: ignore[arg-type]
                         gain_points=0.0, extra_parameters=len(j.result.spec.names_of(j.effect)), lr_train=0.0,
                         lr_validation=0.0, threshold_train=j.threshold, threshold_validation=j.threshold,
                         significant=False, note="its simulation ran off (positions not finite): not fitted")
    fit_c = _fit_points(prob, j.result)
    return Candidate(effect=j.effect, parameters=params, parameter_std=std, fit_percent=fit_c,  # type: ignore[arg-type]
                     gain_points=fit_c - base_fit,
                     extra_parameters=len(j.result.spec.names_of(j.effect)), lr_train=j.lr_fit,
                     lr_validation=j.lr_cv, threshold_train=j.threshold, threshold_validation=j.threshold,
                     significant=j.passes)


def _no_lattice(prob: Problem, base: FitResult, read: Lattice | None = None) -> Candidate:
    """The quantization candidate when the samples lie on no lattice: nothing to model (`read`:
    the lattice of the readings the positions were resampled from, between its levels)."""
    th = threshold(len(effect_names("quantization", prob.carts)), False, base.n_train)
    return Candidate(effect="quantization", parameters={}, fit_percent=_fit_points(prob, base), gain_points=0.0,
                     extra_parameters=len(effect_names("quantization", prob.carts)), lr_train=0.0,
                     lr_validation=0.0, threshold_train=th, threshold_validation=th,
                     significant=False,
                     note="the measured positions lie on no lattice (no encoder steps)" if read is None else
                     f"the readings lie on a {1e6 * read.quantum_m:.4g} um lattice, but the positions were "
                     "resampled between them onto a uniform grid (ident.make_uniform): no staircase to model")


def _ranked(prob: Problem, steps: list[Step], window: FloatArray,
            refit: tuple[Problem, FitResult], baseline: FitResult) -> list[EffectFit]:
    """Accepted effects with their own gain, largest first (parameters from `refit`, the final
    model on its finer grid, `fine.refit_fine`); `window` (N, c) the readings of the window the
    fit % is taken on (an encoder lattice's worth in those points); whether each is material
    against the `baseline`'s misfit and the final model's (`is_material`)."""
    final = steps[-1].judgement.result if steps else None
    fine_prob, fine = refit
    rows = []
    for k, step in enumerate(steps, start=1):
        j = step.judgement
        gain = _fit_points(prob, j.result) - _fit_points(prob, step.before)
        assert final is not None
        params, std = cands.effect_parameters(fine, j.effect)
        if j.effect == "coulomb_friction" and one_encoder(prob):   # cart 2's friction as identifiable
            params, std = identifiable_friction(fine_prob, fine, typical_scale(fine_prob, fine), params, std)
        # an encoder lattice is credited with what it costs a perfect reading of the window
        # (the sensor reads all of it; in the points of the window's fit %: the lattice of a
        # pull-hold release had been counted over the stretch with its hold when the window
        # was not cut at a release `ident.releases` found, 0.047 for 0.058 points of the
        # window, and judged immaterial), not with what the staircase happened to gain on a
        # model that is itself off by some quanta (judged by its readings' likelihood, the
        # model with it can fit worse: the 2023 open-loop test_3_13 at -1.08 points)
        if j.effect == "quantization":
            gain = lattice_worth_points(window, params["quantum_m"])
        rows.append((gain, k, j, params, std, is_material(step, gain, final, baseline)))
    rows.sort(key=lambda r: -r[0])
    return [EffectFit(effect=j.effect, rank=rank, step=k, parameters=params, parameter_std=std,  # type: ignore[arg-type]
                      gain_points=gain, cv_ratio=j.lr_cv, cv_threshold=j.threshold, bic_drop=j.bic_drop,
                      material=material)
            for rank, (gain, k, j, params, std, material) in enumerate(rows, start=1)]


def _model_fit(prob: Problem, res: FitResult, name: str) -> ModelFit:
    per = fit_percent(prob.y, res.prediction)
    return ModelFit(model=name, fit_percent=_mean_defined(per),
                    fit_percent_per_output=[f if np.isfinite(f) else None for f in per],
                    parameters=res.parameters(), parameter_std=res.parameter_std())


def _report(prob: Problem, win: Window, t: FloatArray, base: FitResult, ext: FitResult,
            first_round: list[Judgement], effects: list[EffectFit], cause: str, ev: EvidenceResult,
            coherence: float, step_m: float | None, source: str, elapsed: float,
            stretch: bool, refit: tuple[Problem, FitResult], read: Lattice | None) -> DiagnosisReport:
    """The report: fit % on the work grid (`ext`), the final model's parameters from `refit`
    (the problem on its finer grid and the model fitted there, `fine.refit_fine`)."""
    carts = prob.carts
    n_lin = len(LINEAR_NAMES[carts])
    fine_prob, fine = refit
    rest = fine.theta[n_lin + 2 * carts:n_lin + 3 * carts]
    base_fit = _model_fit(prob, base, MODEL_NAMES[carts])
    names = " + ".join(e.effect for e in sorted(effects, key=lambda e: e.step))
    ext_fit = base_fit if not effects else _model_fit(prob, ext, f"{MODEL_NAMES[carts]} + {names}").model_copy(
        update={"parameters": fine.parameters(), "parameter_std": fine.parameter_std()})
    if one_encoder(prob):   # cart 2's friction as the friction effect reports it (identifiable)
        friction = next(((e.parameters, e.parameter_std) for e in effects if e.effect == "coulomb_friction"), None)
        params, std = identifiable_model(ext_fit.parameters, ext_fit.parameter_std, friction)
        ext_fit = ext_fit.model_copy(update={"parameters": params, "parameter_std": std})
    candidates = [_candidate(prob, base, j) for j in first_round]
    if not any(c.effect == "quantization" for c in candidates):
        candidates.append(_no_lattice(prob, base, read))
    corrected = explain.linear_summary(fine.theta[:n_lin], carts)
    evidence = Evidence(
        residual_rms_m=ev.residual_rms_m, noise_std_m=ev.noise_std_m,
        whiteness_fraction_outside=ev.whiteness_fraction_outside,
        residual_is_white=ev.residual_is_white, residual_peak_hz=ev.residual_peak_hz,
        residual_peak_to_baseline_ratio=ev.residual_peak_to_baseline_ratio,
        envelope_shape=ev.envelope_shape,  # type: ignore[arg-type]
        envelope_peaks=ev.envelope_peaks, envelope_step_m=ev.envelope_step_m,
        envelope_ratio=ev.envelope_ratio, frequency_drift_per_m2=ev.frequency_drift_per_m2,
        rest_offset_m=ev.rest_offset_m, stuck_for_s=ev.stuck_for_s,
        lattice_quantum_m=(ev.lattice.quantum_m if ev.lattice is not None
                           else read.quantum_m if read is not None else None),
        lattice_coherence=coherence, second_frequency_hz=ev.second_frequency_hz)
    report = DiagnosisReport(
        source=source, carts=carts, sample_rate_hz=1.0 / float(t[1] - t[0]),
        release_time_s=win.release_time_s, window_start_s=float(t[win.start]),
        window_end_s=float(t[-1]), step_m=[float(r - h) for r, h in zip(rest, win.hold)],
        step_estimated=step_m is None, baseline=base_fit, candidates=candidates, effects=effects,
        cause=cause,  # type: ignore[arg-type]
        extended=ext_fit, gain_points=ext_fit.fit_percent - base_fit.fit_percent,
        corrected_linear=corrected, evidence=evidence,
        validation=explain.validation_text(win.decimation, prob.train.size, prob.inputs is not None,
                                           win.tail_cut, (float(t[0]), float(t[-1])) if stretch else None,
                                           fine_prob.tau.size if fine_prob is not prob else None),
        explanation="", elapsed_s=elapsed)
    return report.model_copy(update={"explanation": explain.explanation(report, base.theta[:n_lin])})
