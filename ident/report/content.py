"""The lab report's content, as document blocks, from the fit reports of the three lab cases.

Sections follow the handout's submission list: the hand derivation of both transfer
functions (the derivation of `ident.physics`, with its equations), the identified transfer
functions (simple ID with RK4 and Euler, PEM of order 2 for each cart, PEM of order 4) each
with the Python that computed it (`ident.report.code`), numbered figures of measured vs
estimated output referred to from the text, the diagnosis with the effects it found and
their gains, the peak envelopes with both friction laws, and a draft reflection written from
the numbers (`ident.report.reflection`) for the student to edit. Pure: records in, blocks out.
"""

from __future__ import annotations

from dataclasses import dataclass

from ident.report import code
from ident.report.document import (
    Block,
    Code,
    Equation,
    Figure,
    Heading,
    Para,
    Table,
    number_figures,
)
from ident.report.reflection import reflection
from ident.report.wording import (
    diagnosis_zeta_words,
    envelope_words,
    euler_words,
    pem_vs_simple_words,
)
from schemas.fit import LAB_CASES, FitReport, LabCase

CASE_TITLES: dict[str, str] = {
    "cart1": "cart 1 pulled, cart 2 pinned",
    "cart2": "cart 2 pulled, cart 1 pinned",
    "both": "cart 1 pulled, both carts free",
}


@dataclass(frozen=True)
class CaseResult:
    """The report of one lab case and the stems of its figures in the report directory."""

    case: LabCase
    report: FitReport
    figures: dict[str, str]   # kind ("simple", "pem", ...) -> stem
    data_file: str | None = None   # the exported samples, relative to the report; None: no code
    forced: bool = False           # the samples' input is a recorded force (a run begun by the drive)


def _f(value: float | None, digits: int = 4) -> str:
    return "–" if value is None else f"{value:.{digits}g}"


def zetas(parameters: dict[str, float]) -> str:
    """The damping ratio(s) in a parameter map (`zeta`, or `zeta_mode1`, `zeta_mode2`)."""
    found = [f"{v:.4g}" for k, v in sorted(parameters.items()) if k.startswith("zeta")]
    return ", ".join(found) or "–"


def _pct(value: float | None) -> str:
    return "–" if value is None else f"{value:.2f} %"


def derivation_blocks() -> list[Block]:
    """Part 1: the hand derivation (as in `ident.physics`), with the equations."""
    return [
        Heading(2, "1. Hand derivation of the transfer functions"),
        Heading(3, "1.1 One cart, the other pinned"),
        Para("Newton's second law on the cart (mass `m`, kg), tied to its anchor at position "
             "`r` (m) by a spring of stiffness `k` (N/m) and damped viscously by `c` (N·s/m):"),
        Equation(r"m\ddot{x} = -k\,(x - r) - c\,\dot{x} \quad\Leftrightarrow\quad "
                 r"m\ddot{x} + c\dot{x} + k x = k\,r", "equation of motion"),
        Para("Laplace transform with zero initial conditions, `(m s² + c s + k) X(s) = k R(s)`:"),
        Equation(r"G(s) = \frac{X(s)}{R(s)} = \frac{k}{m s^2 + c s + k} = "
                 r"\frac{\omega_n^2}{s^2 + 2\zeta\omega_n s + \omega_n^2}", "single-cart transfer function"),
        Equation(r"\omega_n = \sqrt{k/m}, \qquad \zeta = \frac{c}{2\sqrt{k m}}, \qquad G(0) = 1",
                 "natural frequency (rad/s), damping ratio, DC gain"),
        Para("With cart 2 pinned, cart 1 is held by `k1` (to the wall) and `k2` (to the pinned "
             "cart) in parallel, so `k = k1 + k2`; with cart 1 pinned, cart 2 sees `k = k2 + k3`. "
             "In the lab the cart is held at `-d` (the zeroed frame reads 0 there, `d = 0.15 m`) "
             "and released at `t_r`: the same `G(s)` driven by the step `r = d·H(t - t_r)`."),
        Heading(3, "1.2 Two carts"),
        Para("`wall –k1– m1 –k2– m2 –k3– wall`, dampers `c1`, `c2` from each cart to ground. "
             "With `x = (x1, x2)`, `M = diag(m1, m2)`, `C = diag(c1, c2)` and "
             "`K = [[k1 + k2, -k2], [-k2, k2 + k3]]`, releasing cart 1 from `-d` gives, in the "
             "zeroed frame, `M x'' + C x' + K (x - e r) = 0` with `e = (1, 0)`: the step enters "
             "through `f = K e = (k1 + k2, -k2)`."),
        Equation(r"M\ddot{x} + C\dot{x} + K x = f\,r, \qquad Z(s) = M s^2 + C s + K",
                 "two-cart equations of motion"),
        Equation(r"\mathrm{det}\,Z(s) = (m_1 s^2 + c_1 s + k_1 + k_2)(m_2 s^2 + c_2 s + k_2 + k_3)"
                 r" - k_2^2", "characteristic polynomial (order 4: two modes)"),
        Equation(r"\frac{X_1(s)}{R(s)} = \frac{(m_2 s^2 + c_2 s + k_2 + k_3)(k_1 + k_2) - k_2^2}"
                 r"{\mathrm{det}\,Z(s)}", "cart 1: DC gain 1, relative degree 2"),
        Equation(r"\frac{X_2(s)}{R(s)} = \frac{-k_2\,(m_1 s^2 + c_1 s)}{\mathrm{det}\,Z(s)}",
                 "cart 2: DC gain 0, relative degree 2"),
        Para("So cart 1 settles at `+d` and cart 2 returns to 0; both transfer functions share "
             "the fourth-order denominator, whose two pole pairs are the in-phase and "
             "anti-phase modes. These structural facts (relative degree 2, DC gains 1 and 0) "
             "are what the PEM fits below impose. The same derivation, with the anchor and "
             "force inputs of other rigs, is in the docstring of `ident.physics`."),
    ]


def runs_table(results: list[CaseResult]) -> Table:
    rows = []
    for r in results:
        rep = r.report
        rows.append((r.case, CASE_TITLES[r.case], rep.bench, f"`{rep.run_id}`",
                     _f(rep.sample_rate_hz, 4) + " Hz", _f(rep.duration_s, 3) + " s",
                     _f(rep.release_time_s, 5) + " s", rep.status))
    return Table(("case", "what", "bench", "run", "rate", "length", "release t_r", "fit"),
                 tuple(rows))


def code_setup_blocks(results: list[CaseResult]) -> list[Block]:
    """The imports, and each case's exported samples loaded (`data/<case>.csv`)."""
    blocks: list[Block] = [
        Heading(2, "The Python of this report"),
        Para("Every number below was computed by cartlab's public API; the code blocks are "
             "that code. The samples each fit used are exported beside this report "
             "(`data/<case>.csv`: time (s), the input (the release step, m; for a run begun by "
             "the rig's drive, that drive as recorded), positions (m); "
             "`data/<case>.json`: release time, pulled cart). `report.ipynb` holds the same "
             "code as a notebook: run it top to bottom and it prints the same numbers."),
        Code(code.SETUP),
    ]
    for r in results:
        if r.data_file is None:
            blocks.append(Para(f"The samples of the {CASE_TITLES[r.case]} run were not at hand "
                               "(only its fit): its code is left out."))
            continue
        blocks.append(Para(f"Load the {CASE_TITLES[r.case]} run (`{r.report.run_id}`):"))
        blocks.append(Code(code.load(r.case)))
    return blocks


def simple_blocks(results: list[CaseResult]) -> list[Block]:
    blocks: list[Block] = [
        Heading(2, "2. Simple identification (RK4 and Euler simulation)"),
        Para("The physical model `x'' + 2ζ wn x' + wn² (x - g r) = 0` is simulated with "
             "fourth-order Runge-Kutta and with explicit Euler on the sample grid, from the "
             "cart's state at the release `t_r` (the state-space recursion from initial "
             "conditions), and `wn`, `ζ` and the gain `g` are fitted by minimising the output "
             "error. A cart held still and released starts from rest (its release time is then "
             "fitted too); a flicked cart is let go moving, so the model starts at the release "
             "the data state from the cart's position there with an estimated velocity `v0`. "
             "The gain is the fitted travel to the spring's rest over the pull `r` the release "
             "states: a free response alone cannot tell the DC gain, and with a pull measured "
             "from the same record `g ≈ 1` only says the fitted rest is the record's. "
             "Fit % is MATLAB `compare`'s `100 (1 - |y - ŷ| / |y - mean(y)|)`, from the release on. "
             "The model's `t_r` is where each simulation starts: the release the data state "
             "(the runs table's) for a flick, the fitted one for a release from rest."),
    ]
    rows = [(r.case, str(s.output), s.method.upper() if s.method == "rk4" else "Euler",
             f"`{s.tf.text}`", _f(s.wn_rad_s), _f(s.zeta, 3), _f(s.gain),
             "–" if s.release_time_s is None else f"{s.release_time_s:.4f} s", _pct(s.fit_percent))
            for r in results for s in r.report.simple]
    if rows:
        blocks.append(Table(("case", "cart", "method", "G(s)", "wn (rad/s)", "ζ", "gain",
                             "model's t_r", "fit"), tuple(rows)))
    else:
        blocks.append(Para("No simple identification succeeded on these runs."))
    for r in results:
        if not r.report.simple:
            continue
        cart = r.report.simple[0].output
        blocks.append(Heading(3, f"2.{results.index(r) + 1} {CASE_TITLES[r.case]}"))
        if r.data_file:
            blocks.append(Code(code.simple(r.case)))
        words = euler_words(r.report)
        ref = f"{{fig:simple-{r.case}}}" if "simple" in r.figures else "The fit"
        blocks.append(Para(f"{ref} shows the measured position of cart {cart} with both "
                           "simulations (Euler with markers), and below them each one's "
                           "residual. " + words))
        if "simple" in r.figures:
            blocks.append(Figure(r.figures["simple"],
                                 f"Simple identification, {CASE_TITLES[r.case]}. Above: measured "
                                 f"position of cart {cart} (solid), the RK4 simulation (dashed) "
                                 "and the Euler simulation (dotted, circles) of the fitted model. "
                                 "Below: measured minus simulated, in mm, for each.",
                                 f"simple-{r.case}"))
    return blocks


def pem_blocks(results: list[CaseResult]) -> list[Block]:
    blocks: list[Block] = [Heading(2, "3. PEM, second order, one cart at a time")]
    singles = [r for r in results if r.case != "both" and r.report.pem is not None]
    rows = []
    for r in singles:
        pem = r.report.pem
        assert pem is not None
        for tf, fit in zip(pem.tfs, pem.fit_percent, strict=False):
            mode = pem.modes[0] if pem.modes else None
            rows.append((r.case, str(tf.output), f"`{tf.text}`",
                         _f(mode.wn_rad_s if mode else None), _f(mode.zeta if mode else None, 3),
                         _pct(fit)))
    if rows:
        blocks.append(Table(("case", "cart", "G(s) (continuous, from PEM)", "wn (rad/s)", "ζ",
                             "fit"), tuple(rows)))
    else:
        blocks.append(Para("No single-cart run was identified by PEM."))
    for r in singles:
        blocks.append(Heading(3, f"3.{singles.index(r) + 1} {CASE_TITLES[r.case]}"))
        if r.data_file:
            blocks.append(Code(code.pem(r.case, 2)))
            blocks.append(Code(code.simulate_and_plot(r.case, bool(r.report.simple))))
        ref = f"{{fig:pem-{r.case}}}" if "pem" in r.figures else "The simulation"
        blocks.append(Para(f"{ref} compares the simulated PEM model with the measurement. "
                           + pem_vs_simple_words(r.report)))
        if "pem" in r.figures:
            blocks.append(Figure(r.figures["pem"], f"PEM (order 2), {CASE_TITLES[r.case]}: "
                                 "measured position (solid) and the simulated identified model "
                                 "(dashed).", f"pem-{r.case}"))
    blocks.append(Heading(2, "4. PEM, fourth order, two carts"))
    both = [r for r in results if r.case == "both" and r.report.pem is not None]
    if not both:
        blocks.append(Para("No two-cart run was identified by PEM."))
        return blocks
    r = both[0]
    pem = r.report.pem
    assert pem is not None
    blocks.append(Table(("output", "G(s) = X_i(s)/R(s)", "fit"),
                        tuple((f"cart {tf.output}", f"`{tf.text}`", _pct(fit))
                              for tf, fit in zip(pem.tfs, pem.fit_percent, strict=False))))
    blocks.append(Table(("mode", "wn (rad/s)", "f (Hz)", "ζ"),
                        tuple((str(i + 1), _f(m.wn_rad_s), _f(m.wn_rad_s / 6.283185307179586),
                               _f(m.zeta, 3)) for i, m in enumerate(pem.modes))))
    if r.data_file:
        blocks.append(Code(code.pem(r.case, 4)))
        blocks.append(Code(code.simulate_and_plot(r.case, False)))
    if "pem" in r.figures:
        blocks.append(Para("{fig:pem-both} shows both carts with the simulated fourth-order "
                           "model: the two modes beat, so neither cart rings as one decaying "
                           "sine."))
        blocks.append(Figure(r.figures["pem"], "PEM (order 4), both carts free after cart 1 is "
                             "released: measured positions (solid) and the simulated identified "
                             "model (dashed), one panel per cart.", "pem-both"))
    return blocks


def _effects(r: CaseResult) -> str:
    """Every effect the diagnosis tried, with its held-out gain; the accepted ones in bold."""
    d = r.report.diagnosis
    assert d is not None
    parts = []
    for c in sorted(d.candidates, key=lambda c: -c.gain_points):
        text = f"{c.effect.replace('_', ' ')} {c.gain_points:+.3f}"
        parts.append(f"**{text}**" if c.significant else text)
    return ", ".join(parts) or "–"


def diagnosis_blocks(results: list[CaseResult]) -> list[Block]:
    blocks: list[Block] = [Heading(2, "5. What the linear simulation gets wrong")]
    diagnosed = [r for r in results if r.report.diagnosis is not None]
    if not diagnosed:
        blocks.append(Para("No diagnosis is available for these runs."))
        return blocks
    blocks.append(Para("Each extension of the linear model is fitted to the same run and "
                       "judged on samples it was not fitted to; its gain is the change of "
                       "held-out fit % it brings. Effects the noise cannot explain are in bold; "
                       "the largest is the cause."))
    rows = []
    for r in diagnosed:
        d = r.report.diagnosis
        assert d is not None
        extra = ", ".join(f"`{k}` = {v:.4g}" for k, v in d.extended.parameters.items()
                          if k not in d.baseline.parameters) or "–"
        linear = zetas(d.baseline.parameters)
        if linear == "–" and r.report.pem is not None:    # two carts: the PEM modes' ζ
            linear = ", ".join(f"{m.zeta:.4g}" for m in r.report.pem.modes)
        rows.append((r.case, f"**{d.cause}**", _pct(d.baseline.fit_percent),
                     _pct(d.extended.fit_percent), f"{d.gain_points:+.3f}", _effects(r), extra,
                     linear, zetas(d.corrected_linear)))
    blocks.append(Table(("case", "cause", "linear fit", "extended fit", "gain (points)",
                         "effects tried (gain, points)", "extension parameters", "ζ linear",
                         "ζ corrected"), tuple(rows)))
    for r in diagnosed:
        d = r.report.diagnosis
        assert d is not None
        ev = d.evidence
        blocks.append(Heading(3, f"5.{diagnosed.index(r) + 1} {CASE_TITLES[r.case]}"))
        if r.data_file:
            blocks.append(Code(code.diagnosis(r.case, 2 if r.case == "both" else 1, r.forced)))
        blocks.append(Para(d.explanation))
        refs = f"{{fig:diagnosis-{r.case}}} " if "diagnosis" in r.figures else ""
        blocks.append(Para(
            (f"{refs}shows the linear and the extended simulations on the window after "
             "the release. " if refs else "") + "The residual of the linear fit is "
            f"{'white' if ev.residual_is_white else 'not white'} "
            f"({ev.whiteness_fraction_outside * 100:.0f} % of lags outside the bounds, RMS "
            f"{ev.residual_rms_m * 1000:.2f} mm against noise {ev.noise_std_m * 1000:.3f} mm); the "
            f"cart comes to rest {ev.rest_offset_m * 1000:+.2f} mm from the linear model's "
            f"rest and stays still for the last {ev.stuck_for_s:.2f} s. Validation: "
            f"{d.validation.rstrip('.')}. " + diagnosis_zeta_words(r.report)))
        if "diagnosis" in r.figures:
            blocks.append(Figure(r.figures["diagnosis"], f"Diagnosis, {CASE_TITLES[r.case]}: "
                                 "measured position (solid), the linear model (dashed) and the "
                                 f"model extended with {d.cause.replace('_', ' ')} (dotted), on "
                                 "the window after the release.", f"diagnosis-{r.case}"))
        env = r.report.envelope
        if env is not None and "envelope" in r.figures:
            blocks.append(Para(f"{{fig:envelope-{r.case}}} shows the half-cycle peaks with both "
                               "reference laws fitted to them. " + envelope_words(env)))
            blocks.append(Figure(r.figures["envelope"], f"Peak envelope, {CASE_TITLES[r.case]}: "
                                 f"half-cycle peaks of |x - rest| of cart {env.output} (circles) "
                                 "with the two laws fitted to them: a straight line, dry "
                                 "(Coulomb) friction losing a constant amount per cycle "
                                 "(dashed), and an exponential, viscous damping losing a "
                                 "constant ratio per cycle (dotted).", f"envelope-{r.case}"))
        elif r.case == "both":
            blocks.append(Para("No envelope is drawn for two free carts: their two modes beat, "
                               "so the peaks of one cart rise and fall with the beat and follow "
                               "neither law; the diagnosis fits the friction of both carts "
                               "directly."))
    return blocks


def notes_blocks(results: list[CaseResult], unused: list[FitReport]) -> list[Block]:
    """Stages that failed in the runs used, and the runs left out (failed or repeated)."""
    lines = []
    for r in results:
        errors = r.report.extra.get("stage_errors", {})
        for stage, message in errors.items() if isinstance(errors, dict) else []:
            lines.append(f"`{r.report.run_id}` ({r.case}): the {stage} stage failed: {message}")
    for rep in unused:
        why = f"could not be fitted: {rep.reason}" if rep.status == "failed" else \
            f"not used (another {rep.case} run was)"
        lines.append(f"`{rep.run_id}`: {why}")
    return [Para("**Notes.** " + " ".join(f"{line}." for line in lines))] if lines else []


def report_blocks(results: list[CaseResult], generated: str,
                  unused: list[FitReport] | None = None) -> list[Block]:
    """The whole report, in the handout's order; `unused` are the runs not in it."""
    missing = [c for c in LAB_CASES if c not in {r.case for r in results}]
    blocks: list[Block] = [
        Heading(1, "Spring-cart system identification: lab report"),
        Para(f"Generated by cartlab {generated} from {len(results)} run(s). Every number "
             "below comes from those runs; the simulated output of each identified model is "
             "compared with the measured positions."),
        runs_table(results),
    ]
    if missing:
        blocks.append(Para(f"**Missing lab cases:** {', '.join(missing)}: the sections that "
                           "need them say so."))
    blocks += notes_blocks(results, unused or [])
    blocks += derivation_blocks()
    blocks += code_setup_blocks(results)
    blocks += simple_blocks(results)
    blocks += pem_blocks(results)
    blocks += diagnosis_blocks(results)
    blocks.append(Heading(2, "6. Reflection (draft)"))
    blocks.append(Para("**Draft — edit before you hand it in.** cartlab wrote the paragraphs "
                       "below from the numbers above; they are a starting point, not your "
                       "reflection. Check each claim against the figures and rewrite it in "
                       "your own words."))
    blocks += [Para(text) for text in reflection([r.report for r in results])]
    blocks.append(Heading(2, "Appendix: the numbers, recomputed"))
    blocks.append(Para("The notebook ends by printing every number it computed; they equal "
                       "the ones above."))
    blocks.append(Code(code.NUMBERS))
    return number_figures(blocks)


def summary_rows(results: list[CaseResult]) -> list[tuple[str, ...]]:
    """One row per case for a terminal table: case, TFs, wn, ζ, fit %, cause, gain."""
    rows: list[tuple[str, ...]] = []
    for r in results:
        rep = r.report
        pem = rep.pem
        simple = next((s for s in rep.simple if s.method == "rk4"), None)
        tfs = " ; ".join(tf.text for tf in pem.tfs) if pem else "–"
        wn = ", ".join(f"{m.wn_rad_s:.3f}" for m in pem.modes) if pem else "–"
        zeta = ", ".join(f"{m.zeta:.4f}" for m in pem.modes) if pem else "–"
        fits = ", ".join(f"{f:.1f}" for f in pem.fit_percent) if pem else "–"
        if simple is not None:
            fits += f" (RK4 {simple.fit_percent:.1f})"
        d = rep.diagnosis
        rows.append((r.case, tfs, wn, zeta, fits, d.cause if d else "–",
                     f"{d.gain_points:+.3f}" if d else "–"))
    return rows


__all__ = ["CASE_TITLES", "CaseResult", "code_setup_blocks", "derivation_blocks", "notes_blocks", "report_blocks",
           "summary_rows"]
