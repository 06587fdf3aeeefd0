"""A word wherever the report shows two estimates of one quantity, and the envelope's reading.

- RK4 vs Euler (`euler_words`): one model, two integrators. Explicit Euler at step `h`
  multiplies an undamped oscillation by `|1 + j wn h| = √(1 + (wn h)²)` per step, a
  negative damping of about `wn h / 2` in ζ, which a fit of Euler's simulation makes up for
  with a larger ζ.
- PEM vs the simple identification (`pem_vs_simple_words`): two estimators of one linear
  model, compared against their standard errors.
- ζ linear vs ζ corrected (`diagnosis_zeta_words`): the linear model fakes friction's
  decay with viscous damping; once friction is modelled, the viscous part left is smaller.
- The envelope (`envelope_words`): dry friction loses a constant amount per cycle (a
  straight line), viscous damping a constant ratio (an exponential).

Pure: records in, sentences out; every sentence quotes the numbers it is about.
"""

from __future__ import annotations

import math

from schemas.fit import EnvelopeRec, FitReport, SimpleFitRec


def _simple(report: FitReport, method: str) -> SimpleFitRec | None:
    return next((s for s in report.simple if s.method == method), None)


def _rel(a: float, b: float) -> float:
    return 100.0 * (a / b - 1.0) if b else float("nan")


def euler_words(report: FitReport) -> str:
    """Why the Euler fit's ζ (and wn) differ from RK4's, or that they agree."""
    rk4, euler = _simple(report, "rk4"), _simple(report, "euler")
    if rk4 is None or euler is None or not report.sample_rate_hz:
        return ""
    h = 1.0 / report.sample_rate_hz
    wnh = rk4.wn_rad_s * h
    dzeta, dwn = _rel(euler.zeta, rk4.zeta), _rel(euler.wn_rad_s, rk4.wn_rad_s)
    if math.isfinite(dzeta) and abs(dzeta) < 1.0 and abs(dwn) < 0.1:
        return (f"RK4 and Euler give the same model here (ζ within {abs(dzeta):.2f} %, wn within "
                f"{abs(dwn):.3f} %): the two simulations lie on top of each other (the Euler "
                "curve carries circles so that both show), and so do their residuals. At "
                f"wn·h = {wnh:.4f} an Euler step at the sample interval would add a negative "
                f"damping of about wn·h/2 = {wnh / 2:.4f} in ζ; the integration is finer than "
                "that, so Euler converges to RK4's answer.")
    return (f"The two integrators give two estimates of ζ: RK4 {rk4.zeta:.4f}, Euler "
            f"{euler.zeta:.4f} ({dzeta:+.1f} %), and of wn ({dwn:+.3f} %). They differ because "
            f"explicit Euler with step h = {h * 1e3:.3g} ms multiplies an undamped oscillation by "
            f"√(1 + (wn h)²) = {math.sqrt(1.0 + wnh ** 2):.5f} per step, a negative damping of "
            f"about wn·h/2 = {wnh / 2:.4f} in ζ that the Euler fit must cancel; RK4's error at "
            "this step is negligible, so its ζ is the one to quote." + (
                f" Both reach the same curve (fit {rk4.fit_percent:.2f} % and "
                f"{euler.fit_percent:.2f} %): the simulations coincide, their ζ do not."
                if abs(rk4.fit_percent - euler.fit_percent) < 0.05 else ""))


def pem_vs_simple_words(report: FitReport) -> str:
    """PEM's wn and ζ against the RK4 simple identification's, in standard errors."""
    rk4 = _simple(report, "rk4")
    pem = report.pem
    if rk4 is None or pem is None or not pem.modes:
        return ""
    mode = pem.modes[0]
    parts = []
    for name, a, sa, b, sb, fmt in (("wn", mode.wn_rad_s, mode.wn_std, rk4.wn_rad_s, rk4.wn_std, ".4f"),
                                    ("ζ", mode.zeta, mode.zeta_std, rk4.zeta, rk4.zeta_std, ".4f")):
        sigma = math.hypot(sa or 0.0, sb or 0.0)
        if sigma > 0:
            k = abs(a - b) / sigma
            judged = (f"within their standard errors ({k:.1f} σ)" if k <= 2.0
                      else f"{k:.0f} standard errors apart")
        else:
            judged = "(no standard errors)"
        parts.append(f"{name} {a:{fmt}} (PEM) and {b:{fmt}} (RK4), {_rel(a, b):+.2f} %, {judged}")
    apart = any("apart" in p for p in parts)
    why = (" Two estimators of one linear model land apart when the model does not describe "
           "the run exactly: each weighs the misfit its own way (PEM also fits the output "
           "offset and the input delay). Section 5 shows what the linear model misses."
           if apart else "")
    return "PEM and the simple identification estimate the same quantities: " + \
        "; ".join(parts) + "." + why


def diagnosis_zeta_words(report: FitReport) -> str:
    """Why ζ of the linear model and ζ corrected (friction modelled) differ."""
    d = report.diagnosis
    if d is None:
        return ""
    linear = [v for k, v in sorted(d.baseline.parameters.items()) if k.startswith("zeta")]
    corrected = [v for k, v in sorted(d.corrected_linear.items()) if k.startswith("zeta")]
    if not linear or not corrected:
        return ""
    a, b = linear[0], corrected[0]
    if abs(_rel(b, a)) < 1.0:
        return (f"ζ hardly changes once {d.cause.replace('_', ' ')} is modelled "
                f"({a:.4g} → {b:.4g}).")
    return (f"The table shows two damping ratios for this run: ζ linear = {a:.4g} is what the "
            f"linear model needs to mimic the whole decay; ζ corrected = {b:.4g} is the viscous "
            f"part left once {d.cause.replace('_', ' ')} is modelled ({_rel(b, a):+.0f} %). The "
            "difference is decay the linear model had to fake as viscous damping.")


def envelope_words(env: EnvelopeRec) -> str:
    """What the peaks say: a constant loss per cycle (dry friction) or a constant ratio."""
    loss_mm = 1e3 * env.coulomb_loss_per_cycle_m
    ratio = env.viscous_ratio_per_cycle
    better = "straight line" if env.better_law == "coulomb" else "exponential"
    reading = ("over these peaks dry friction's constant amount describes the decay better "
               "than the viscous constant ratio" if better == "straight line" else
               "over these peaks the viscous law (a constant ratio) describes the decay better "
               "than dry friction's constant amount")
    return (f"Dry friction takes a constant amount off each cycle, {loss_mm:.2f} mm here if it "
            f"acted alone (the straight line, RMS misfit {env.coulomb_rms_m * 1e3:.2f} mm); "
            f"viscous damping keeps a constant ratio, {ratio:.3f} per cycle here if it acted "
            f"alone (the exponential, RMS misfit {env.viscous_rms_m * 1e3:.2f} mm). "
            f"The {better} fits the {len(env.peak_m)} peaks better, so {reading}. Taking "
            "both at once, each peak against the one before gives A(k+1) = "
            f"{env.mixed_ratio_per_half:.3f}·A(k) - {env.mixed_loss_m_per_half * 1e3:.2f} mm: "
            f"a viscous ratio of {env.mixed_ratio_per_half:.3f} and a dry-friction loss of "
            f"{env.mixed_loss_m_per_half * 1e3:.2f} mm per half-cycle." + _crossover(env))


def _crossover(env: EnvelopeRec) -> str:
    """Where both act, the amplitude below which friction takes more than viscous damping:
    `(1 - q) A = b` gives `A* = b / (1 - q)`."""
    q, b = env.mixed_ratio_per_half, env.mixed_loss_m_per_half
    if not (0.0 < q < 1.0 and b > 0.0):
        return ""
    a_star = b / (1.0 - q)
    return (f" Both act: above about {a_star * 1e3:.1f} mm viscous damping takes more per "
            "half-cycle, below it dry friction does, and friction alone brings the cart to a stop.")


__all__ = ["diagnosis_zeta_words", "envelope_words", "euler_words", "pem_vs_simple_words"]
