"""Words for the diagnosis: the corrected linear parameters, how fit % was measured, and a
short paragraph a student can put in a report. No numerics beyond formatting, no I/O."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ident.diagnose.fine import FINE_NFEV
from ident.diagnose.fitting import BLOCKS, CV_ITERATIONS
from ident.diagnose.stretch import MIN_SAMPLES_PER_PERIOD
from ident.physics.chain import modes
from schemas.diagnosis import DiagnosisReport

FloatArray = NDArray[np.float64]

_WHAT = {
    "coulomb_friction": "dry (Coulomb) friction",
    "quadratic_drag": "quadratic (velocity-squared) drag",
    "cubic_stiffness": "a hardening (cubic) spring",   # κ > 0; a softening one is named in `explanation`
    "quantization": "encoder quantization",
    "coupled_mode": "a second resonance (an imperfectly pinned cart or a track mode)",
    "presliding": "pre-sliding (Dahl) friction: a stiff, saturating friction at small amplitude",
    "static_friction": "static friction above the kinetic level: a stopped cart breaks away only under a larger pull",
    "held_cart_motion": "the held cart's motion, driving the free cart through the spring",
    "rest_drift": ("a slow drift of the cart's rest: the other, hand-held cart wanders (not read) and "
                   "pulls through the spring"),
}


#: The peak envelope's shape in words: dry friction loses a constant amount per cycle,
#: viscous damping a constant ratio (so a friction run may still show a ratio: both act).
ENVELOPE_WORDS = {
    "constant_ratio": "the peaks keep a constant ratio per cycle, the viscous signature, so "
                      "viscous damping acts too",
    "constant_step": "the peaks lose a constant amount per cycle, the dry-friction signature",
    "amplitude_dependent": "large peaks lose a larger fraction than small ones",
    "undetermined": "too few peaks to tell",
}


#: A cart still for less than this at the end of a record has not come to rest (s).
MIN_REST_S = 0.1


def rest_words(stuck_for_s: float, rest_offset_m: float) -> str:
    """Where the run ends, in words: at rest for how long and how far off, or still moving."""
    if stuck_for_s < MIN_REST_S:
        return f"still moving at the end of the record, {1e3 * rest_offset_m:.2f} mm from the fitted rest"
    return f"at rest for the last {stuck_for_s:.2f} s, {1e3 * rest_offset_m:.2f} mm from the fitted rest"


def _signs(report: DiagnosisReport) -> str:
    """The evidence behind the named cause, in words, from the measured run."""
    ev = report.evidence
    shape = ENVELOPE_WORDS.get(ev.envelope_shape, ev.envelope_shape.replace("_", " "))
    if report.carts == 2:      # two carts beat: the peaks of one follow no envelope law
        shape = "not read for two carts, whose two modes beat"
    if report.cause == "coulomb_friction" and ev.stuck_for_s >= MIN_REST_S:
        return (f"the cart stops dead {1e3 * abs(ev.rest_offset_m):.2f} mm from the linear model's rest "
                f"and stays there for the last {ev.stuck_for_s:.2f} s while the linear model keeps "
                f"ringing, which no viscous damping can do (peak envelope: {shape})")
    if report.cause == "coulomb_friction":   # the record ends before the cart comes to rest
        return (f"the swings die out in a way no viscous damping reproduces (peak envelope: {shape}); "
                "the record ends while the cart still moves")
    if report.cause == "quadratic_drag":
        return f"large swings lose a larger fraction of their amplitude than small ones (peak envelope: {shape})"
    if report.cause == "cubic_stiffness":
        return ("the oscillation frequency changes with the amplitude "
                f"(relative drift {ev.frequency_drift_per_m2:.3g} per m² of amplitude²)")
    if report.cause == "quantization":
        q = ev.lattice_quantum_m or 0.0
        return f"every measured position lies on a staircase of {1e6 * q:.3g} µm steps"
    if report.cause == "static_friction":
        return "a stopped cart stays put under a pull larger than its sliding friction"
    if report.cause == "presliding":
        return "the last small cycles ring faster than the first large ones"
    if report.cause == "held_cart_motion":
        return "the held cart moves with the free one and drives it back through the spring"
    if report.cause == "rest_drift":
        return "the cart swings about a centre that moves slowly, far slower than it rings"
    # the fitted mode's frequency: the residual's spectrum may show none (a mode that decays
    # within a period) and its peak is then a slow drift's
    mode = next((e.parameters.get("mode_hz") for e in report.effects if e.effect == "coupled_mode"), None)
    hz = mode or ev.second_frequency_hz or ev.residual_peak_hz
    return f"the residual of the linear model rings at a second frequency (near {hz:.3g} Hz)"


def linear_summary(lin: FloatArray, carts: int) -> dict[str, float]:
    """wn (rad/s) and zeta of each mode: `wn_rad_s`, `zeta` (one cart) or `_mode1/2`."""
    found = modes(lin[None, :], carts)
    if carts == 1:
        return {"wn_rad_s": found[0][0], "zeta": found[0][1]}
    out: dict[str, float] = {}
    for i, (wn, zeta) in enumerate(found, start=1):
        out[f"wn_mode{i}_rad_s"], out[f"zeta_mode{i}"] = wn, zeta
    return out


def validation_text(decimation: int, n_work: int, forced: bool = False, tail_cut: bool = False,
                    span: tuple[float, float] | None = None, n_fine: int | None = None) -> str:
    """`forced`: the model takes a measured force input, and the window is the whole record (or
    the `span` (s) asked for); `tail_cut`: the carts' still tail was cut (`stretch.still_tail_cut`,
    or sooner to resolve the fitted modes: `stretch.resolving_decimation`),
    or a forced record where its work grid no longer resolved its modes (`stretch.modes_resolved_cut`);
    `n_fine`: the samples the final model was refitted on for its parameters (`fine.refit_fine`)."""
    which = "every sample" if decimation == 1 else f"one sample in {decimation}"
    if forced:
        cut = (f"first {n_work * decimation} samples (cut where a work grid of {MIN_SAMPLES_PER_PERIOD} "
               "samples a period of its fastest mode runs out)")
        if span is None:
            window = "The whole record" if not tail_cut else f"The record's {cut}"
        else:
            window = f"The record from {span[0]:.3f} s to {span[1]:.3f} s" + (f", its {cut}" if tail_cut else "")
        window += ", the measured force input driving the model"
    else:
        window = ("Window from the end of the hand's influence to the end of the free response"
                  + (" (cut where the work samples run out: decimated only as much as the carts' motion, a "
                     f"still tail as long and {MIN_SAMPLES_PER_PERIOD} samples a period of the fitted modes allow)"
                     if tail_cut else ""))
    return (f"{window}, {which} "
            f"({n_work} work samples). Every model is fitted (simulated output error) on the whole "
            "window and fit % (MATLAB compare, simulated output) is measured there. Effects are added "
            f"one at a time by forward selection: each is judged by blocked cross-validation ({BLOCKS} "
            f"contiguous blocks; the model refitted without a block, {CV_ITERATIONS} damped Gauss-Newton steps (the "
            "better of two such refits), and "
            "simulated through the whole window, the cost taken inside the block); it is kept only "
            "when n ln(CV_before/CV_after) and the whole-window ratio exceed the chi-square noise "
            "bound (alpha 1e-3, plus a look-elsewhere term for a searched frequency) and the BIC drops."
            + ("" if n_fine is None else f" The final model's parameters and their uncertainties are from its "
               f"refit on {n_fine} samples of the window (the work grid's model fitted on, {FINE_NFEV} "
               "evaluations at most)."))


def explanation(report: DiagnosisReport, base_lin: FloatArray) -> str:
    """A short paragraph for a student's report."""
    base = linear_summary(base_lin, report.carts)
    key = "zeta" if report.carts == 1 else "zeta_mode1"
    if report.cause == "none":
        return (f"The linear model explains the run to within the measurement noise: its held-out fit is "
                f"{report.baseline.fit_percent:.2f} % and no physical extension (dry friction, quadratic "
                f"drag, cubic spring, encoder quantization, second mode) improved it by more than noise "
                f"explains. Damping ratio {base[key]:.4f}.")
    what, sign = _WHAT[report.cause], _signs(report)
    chosen = next(e for e in report.effects if e.effect == report.cause)
    if report.cause == "cubic_stiffness" and chosen.parameters.get("cubic_per_m2_s2", 0.0) < 0.0:
        what = "a softening (cubic) spring"   # κ < 0: the spring's stiffness falls with the stretch
    params = ", ".join(f"{k} = {v:.4g}" for k, v in chosen.parameters.items()
                       if not k.startswith(("mode_cos", "mode_sin", "lattice_offset")))
    others = [e for e in report.effects if e.effect != report.cause]
    also = ("" if not others else " Also found: " + ", ".join(
        f"{e.effect} ({e.gain_points:+.3g} points{'' if e.material else ', immaterial'})" for e in others) + ".")
    text = (f"The linear simulation misses {what}: {sign}. Adding it ({params}) gains "
            f"{chosen.gain_points:+.3g} points, more than noise explains on held-out blocks.{also} "
            f"Whole-window fit: {report.baseline.fit_percent:.2f} % (linear) -> "
            f"{report.extended.fit_percent:.2f} % (every accepted effect). ")
    corrected = report.corrected_linear.get(key)
    if corrected is not None and report.cause in ("coulomb_friction", "quadratic_drag"):
        text += (f"The linear fit absorbed this loss into viscous damping: its damping ratio "
                 f"{base[key]:.4f} becomes {corrected:.4f} once the effect is modelled.")
    elif corrected is not None:
        text += f"Damping ratio {base[key]:.4f} (linear) and {corrected:.4f} (extended model)."
    return text
