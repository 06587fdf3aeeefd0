"""Figures of one run's analysis: measured vs estimated outputs, by the lab's plotting rules.

Rules (docs/report.md), through `ident.plotting` (the lab's style, shared with
`ident diagnose`): font family and size set once (the HTML report uses the same), line
width ≥ 2, x and y labels with units on every axis, no title (the report's caption
describes each figure: caption or title, never both), measured and estimated traces in
different line styles. Functions return `matplotlib.figure.Figure`
objects (testable) and `save` writes PNG and SVG. Matplotlib is used headless (Agg).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ident import plotting
from ident.data import FloatArray
from ident.fitrun.analysis import RunAnalysis
from ident.fitrun.envelope import coulomb_line, viscous_curve

if TYPE_CHECKING:
    from matplotlib.figure import Figure

MIN_LINE_WIDTH = 2.0


def style() -> tuple[str, float]:
    """Apply the lab's figure style (`ident.plotting`) once; return (font family, size in pt)."""
    plotting.apply_style()
    return plotting.FONT_FAMILY, float(plotting.FONT_SIZE_PT)


def measured_vs_estimated(t: FloatArray, y: FloatArray,
                          estimates: list[tuple[list[str], FloatArray]],
                          carts: tuple[int, ...]) -> Figure:
    """One axis per cart: the measured position (solid) and each estimate (dashed, dotted…).

    `t` (N,) s, `y` (N, n_carts) m, each estimate a label per cart and (N, n_carts) m,
    `carts` the cart numbers.
    """
    fig, axes = plotting.new_figure(len(carts))
    styles = plotting.ESTIMATE_STYLES
    for j, (ax, cart) in enumerate(zip(axes, carts)):
        ax.plot(t, y[:, j], label=f"measured, cart {cart}", **plotting.MEASURED_STYLE)
        for k, (labels, y_hat) in enumerate(estimates):
            ax.plot(t, y_hat[:, j], label=labels[j], **styles[k % len(styles)])
        plotting.label_axes(ax, "time (s)", f"cart {cart} position (m)")
        ax.legend(loc="best")
    return fig


def simple_figure(analysis: RunAnalysis) -> Figure | None:
    """RK4 and Euler told apart: above, the measured position (solid), the RK4 simulation
    (dashed) and the Euler simulation (dotted, with markers); below, each one's residual
    `y - ŷ` in mm (where the two differ, it shows)."""
    if not analysis.simple:
        return None
    t, y = analysis.data.t, analysis.data.y[:, 0]
    cart = analysis.outputs[0]
    fig, (top, bottom) = plotting.new_figure(2)
    top.plot(t, y, label=f"measured, cart {cart}", **plotting.MEASURED_STYLE)
    mark_every = max(1, t.size // 40)
    for k, r in enumerate(analysis.simple):
        style = dict(plotting.ESTIMATE_STYLES[k % len(plotting.ESTIMATE_STYLES)])
        if r.method == "euler":
            style.update(marker="o", markersize=4, markevery=mark_every, markerfacecolor="none")
        name = "RK4" if r.method == "rk4" else "Euler"
        top.plot(t, r.y_hat[:, 0], label=f"{name} simulation, fit {r.fit_percent:.2f} %", **style)
        bottom.plot(t, 1e3 * (y - r.y_hat[:, 0]), label=f"{name} residual", **style)
    plotting.label_axes(top, "time (s)", f"cart {cart} position (m)")
    plotting.label_axes(bottom, "time (s)", "measured - simulated (mm)")
    top.legend(loc="best")
    bottom.legend(loc="best")
    return fig


def pem_figure(analysis: RunAnalysis) -> Figure | None:
    if analysis.pem is None or analysis.pem_y_hat is None:
        return None
    labels = [f"PEM order {analysis.pem.order} simulation, fit {f:.1f} %"
              for f in analysis.pem.fit_percent]
    return measured_vs_estimated(analysis.data.t, analysis.data.y, [(labels, analysis.pem_y_hat)],
                                 analysis.outputs)


def _percent(fit: float | None) -> str:
    return "n/a (never moves)" if fit is None else f"{fit:.2f} %"


def diagnosis_figure(analysis: RunAnalysis) -> Figure | None:
    """Measured vs the linear baseline and the extended model, on the diagnosis window."""
    traces, report = analysis.diagnosis_traces, analysis.diagnosis
    if traces is None or report is None:
        return None
    carts = analysis.outputs[: traces.y.shape[1]]
    per_cart = report.baseline.fit_percent_per_output or [report.baseline.fit_percent] * len(carts)
    ext_cart = report.extended.fit_percent_per_output or [report.extended.fit_percent] * len(carts)
    linear = [f"linear model, fit {_percent(f)}" for f in per_cart]
    cause = report.cause.replace("_", " ")
    extended = [f"with {cause}, fit {_percent(f)}" for f in ext_cart]
    estimates: list[tuple[list[str], FloatArray]] = [(linear, traces.baseline)]
    if report.cause != "none":
        estimates.append((extended, traces.extended))
    return measured_vs_estimated(traces.t, traces.y, estimates, carts)


def envelope_figure(analysis: RunAnalysis) -> Figure | None:
    """The half-cycle peaks (markers, solid) with both reference laws fitted to them: the
    straight line of dry (Coulomb) friction (dashed) and the exponential of viscous damping
    (dotted). One free cart only (None for two carts, whose peaks beat)."""
    env = analysis.envelope
    if env is None:
        return None
    fig, (ax,) = plotting.new_figure(1, height_per_axis_in=3.2)
    dense = np.linspace(env.t_s[0], env.t_s[-1], 200)
    ax.plot(env.t_s, 1e3 * np.asarray(env.peak_m), marker="o", label="measured half-cycle peaks",
            **plotting.MEASURED_STYLE)
    ax.plot(dense, 1e3 * coulomb_line(env, dense),
            label=f"Coulomb: straight line, RMS {1e3 * env.coulomb_rms_m:.2f} mm",
            **plotting.ESTIMATE_STYLES[0])
    ax.plot(dense, 1e3 * viscous_curve(env, dense),
            label=f"viscous: exponential, RMS {1e3 * env.viscous_rms_m:.2f} mm",
            **plotting.ESTIMATE_STYLES[1])
    ax.set_ylim(bottom=0.0)
    plotting.label_axes(ax, "time (s)", f"cart {analysis.outputs[0]} peak |x - rest| (mm)")
    ax.legend(loc="best")
    return fig


def save(fig: Figure, directory: Path, stem: str) -> list[str]:
    """Write `<stem>.png` (150 dpi) and `<stem>.svg`; return the file names."""
    return [path.name for path in plotting.save(fig, directory / stem)]


def figures_of(analysis: RunAnalysis) -> dict[str, Figure]:
    """Every figure of a run by file stem: `simple`, `pem`, `diagnosis`, `envelope`."""
    out: dict[str, Figure] = {}
    for stem, fig in (("simple", simple_figure(analysis)), ("pem", pem_figure(analysis)),
                      ("diagnosis", diagnosis_figure(analysis)),
                      ("envelope", envelope_figure(analysis))):
        if fig is not None:
            out[stem] = fig
    return out


def write_figures(analysis: RunAnalysis, directory: Path) -> list[str]:
    """Draw every figure of `analysis` into `directory` (PNG + SVG); the file names."""
    drawn = figures_of(analysis)
    names: list[str] = []
    for stem, fig in drawn.items():
        names += save(fig, directory, stem)
    close(drawn)
    return names


def check_figure_rules(fig: Figure) -> list[str]:
    """The lab's rules a figure breaks (empty when it follows them), for tests and CI."""
    problems = []
    has_title = bool(fig.get_suptitle()) if hasattr(fig, "get_suptitle") else False
    for i, ax in enumerate(fig.axes):
        has_title = has_title or bool(ax.get_title())
        for axis_name, label in (("x", ax.get_xlabel()), ("y", ax.get_ylabel())):
            if not label or "(" not in label or ")" not in label:
                problems.append(f"axis {i}: {axis_name} label {label!r} has no unit in parentheses")
        styles = set()
        for line in ax.get_lines():
            if line.get_linewidth() < MIN_LINE_WIDTH:
                problems.append(f"axis {i}: line {line.get_label()!r} width {line.get_linewidth()}")
            styles.add(line.get_linestyle())
        if len(ax.get_lines()) > 1 and len(styles) < len(ax.get_lines()):
            problems.append(f"axis {i}: {len(ax.get_lines())} traces share line styles {styles}")
    if has_title:
        problems.append("figure has a title: the report's caption describes it (never both)")
    return problems


def close(figures: dict[str, Figure]) -> None:
    for fig in figures.values():
        fig.clear()


__all__ = ["check_figure_rules", "close", "diagnosis_figure", "envelope_figure", "figures_of",
           "measured_vs_estimated", "pem_figure", "save", "simple_figure", "style",
           "write_figures"]
