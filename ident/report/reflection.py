"""The report's reflection: two to three paragraphs written from the measured numbers.

Each sentence is chosen by the results (which method agrees with which, whether Euler's
damping is biased, what the diagnosis found, whether the two-cart modes bracket the
single-cart frequencies as the physics says) and quotes them; nothing here is boilerplate
that would read the same for any data. Pure: fit reports in, strings out.
"""

from __future__ import annotations

import math

from schemas.fit import FitReport, SimpleFitRec

CART_OF_CASE = {"cart1": 1, "cart2": 2}


def _simple(report: FitReport, method: str) -> SimpleFitRec | None:
    return next((s for s in report.simple if s.method == method), None)


def _by_case(reports: list[FitReport]) -> dict[str, FitReport]:
    out: dict[str, FitReport] = {}
    for report in reports:
        if report.case is not None and report.status == "ok":
            out.setdefault(report.case, report)
    return out


def methods_paragraph(cases: dict[str, FitReport]) -> str | None:
    sentences = []
    for case in ("cart1", "cart2"):
        report = cases.get(case)
        if report is None or report.pem is None or not report.pem.modes:
            continue
        cart = CART_OF_CASE[case]
        mode, fit = report.pem.modes[0], report.pem.fit_percent[0]
        rk4, euler = _simple(report, "rk4"), _simple(report, "euler")
        text = (f"For cart {cart} (the other pinned) PEM of order 2 finds wn = "
                f"{mode.wn_rad_s:.3f} rad/s and ζ = {mode.zeta:.4f} with a {fit:.1f} % fit")
        if rk4 is not None:
            dwn = 100.0 * (rk4.wn_rad_s / mode.wn_rad_s - 1.0)
            agree = "agrees with it" if abs(dwn) < 0.5 else "differs from it"
            text += (f"; the RK4 simulation fit ({rk4.fit_percent:.1f} %) {agree} on the "
                     f"frequency ({dwn:+.2f} %) and gives ζ = {rk4.zeta:.4f}")
        sentences.append(text + ".")
        if rk4 is not None and euler is not None and report.sample_rate_hz:
            wnh = rk4.wn_rad_s / report.sample_rate_hz
            dz = 100.0 * (euler.zeta / rk4.zeta - 1.0) if rk4.zeta else float("nan")
            if math.isfinite(dz) and abs(dz) >= 1.0:
                sentences.append(
                    f"Explicit Euler returns ζ = {euler.zeta:.4f}, {dz:+.1f} % against RK4: at "
                    f"wn·h = {wnh:.3f} each Euler step scales the oscillation by √(1 + (wn h)²) ≈ "
                    f"{math.sqrt(1 + wnh ** 2):.5f}, energy the fit must cancel with extra damping.")
            else:
                sentences.append(
                    f"Euler and RK4 agree on ζ within {abs(dz):.1f} % here: at wn·h = {wnh:.3f} "
                    "Euler's growth per step is too small to bias the damping visibly.")
    return " ".join(sentences) if sentences else None


def diagnosis_paragraph(cases: dict[str, FitReport]) -> str | None:
    sentences = []
    for case, report in cases.items():
        d = report.diagnosis
        if d is None:
            continue
        where = {"cart1": "cart 1 alone", "cart2": "cart 2 alone", "both": "the two-cart run"}[case]
        zeta_lin = _first_zeta(d.baseline.parameters)
        if zeta_lin is None and report.pem is not None and report.pem.modes:
            zeta_lin = report.pem.modes[0].zeta        # two carts: the linear PEM model's
        zeta_cor = _first_zeta(d.corrected_linear)
        if d.cause == "none":
            sentences.append(
                f"For {where} no extension beat the noise (best gain {d.gain_points:+.3f} "
                f"points on held-out data), so the linear model is adequate there.")
            continue
        text = (f"For {where} the diagnosis names **{d.cause.replace('_', ' ')}**: the extended "
                f"model reaches {d.extended.fit_percent:.2f} % against {d.baseline.fit_percent:.2f} % "
                f"for the linear one ({d.gain_points:+.3f} points on held-out data)")
        if zeta_lin is not None and zeta_cor is not None and zeta_lin > 0:
            which = "the damping ratio" if case != "both" else "the first mode's damping ratio"
            change = "falls" if zeta_cor < zeta_lin else "rises"
            text += (f", and {which} {change} from {zeta_lin:.4f} to {zeta_cor:.4f} once "
                     f"the effect is modelled ({100 * (zeta_cor / zeta_lin - 1):+.0f} %)")
        sentences.append(text + ".")
    if not sentences:
        return None
    friction = [r.diagnosis for r in cases.values()
                if r.diagnosis is not None and r.diagnosis.cause == "coulomb_friction"]
    if friction:
        steps = [d for d in friction if d.evidence.envelope_shape == "constant_step"]
        stuck = max(d.evidence.stuck_for_s for d in friction)
        how = ("the peaks shrink by a constant step rather than a constant ratio"
               if steps else "the oscillation dies out faster at small amplitude than viscous "
               "damping allows")
        sentences.append(
            f"Dry friction explains what a linear model cannot: {how}, and the carts stop dead "
            f"(still for up to {stuck:.2f} s at the end) while the linear simulation keeps "
            "ringing; a linear fit absorbs the friction into a damping ratio that is too high.")
    return " ".join(sentences)


def _first_zeta(parameters: dict[str, float]) -> float | None:
    """`zeta`, or the first mode's (`zeta_mode1`) for two carts."""
    for name in ("zeta", "zeta_mode1"):
        if name in parameters:
            return parameters[name]
    return None


def coupling_paragraph(cases: dict[str, FitReport]) -> str | None:
    both = cases.get("both")
    if both is None or both.pem is None or len(both.pem.modes) < 2:
        return None
    modes = sorted(m.wn_rad_s for m in both.pem.modes)
    text = (f"With both carts free, PEM of order 4 finds two modes, {modes[0]:.3f} and "
            f"{modes[1]:.3f} rad/s (fits " +
            ", ".join(f"cart {o} {f:.1f} %" for o, f in zip(both.pem.outputs, both.pem.fit_percent))
            + ").")
    singles = [(c, r.pem.modes[0].wn_rad_s) for c, r in cases.items()
               if c in CART_OF_CASE and r.pem is not None and r.pem.modes]
    if singles:
        inside = all(modes[0] < wn < modes[1] for _, wn in singles)
        listed = ", ".join(f"{wn:.3f} rad/s (cart {CART_OF_CASE[c]})" for c, wn in singles)
        if inside:
            text += (f" The single-cart frequencies {listed} lie between them, as the chain's "
                     "physics requires: pinning one cart is a constraint, and a constrained "
                     "system's frequency interlaces with the free system's.")
        else:
            text += (f" The single-cart frequencies {listed} do not all lie between them, which "
                     "the chain's physics forbids for one rig: the runs were probably taken on "
                     "different set-ups or the springs changed between them.")
    tf2 = next((tf for tf in both.pem.tfs if tf.output == 2), None)
    if tf2 is not None and tf2.den[-1] != 0.0:
        gain = tf2.num[-1] / tf2.den[-1] if tf2.num else 0.0
        text += (f" Cart 2's identified DC gain is {gain:+.3f} (the derivation predicts 0: it "
                 "returns to its rest).")
    return text


def reflection(reports: list[FitReport]) -> list[str]:
    """Two to three paragraphs; fewer only when the runs hold too little to say more."""
    cases = _by_case(reports)
    paragraphs = [p for p in (methods_paragraph(cases), diagnosis_paragraph(cases),
                              coupling_paragraph(cases)) if p]
    if not paragraphs:
        failed = [r for r in reports if r.status != "ok"]
        paragraphs.append(
            f"None of the {len(reports)} run(s) could be identified "
            + (f"({'; '.join(r.reason or '?' for r in failed)})" if failed else "")
            + ", so there is nothing to reflect on yet: record the three lab cases again.")
    return paragraphs


__all__ = ["coupling_paragraph", "diagnosis_paragraph", "methods_paragraph", "reflection"]
