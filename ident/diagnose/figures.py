"""Figures of a diagnosis: measured vs baseline and extended simulation, residuals, envelope.

Built with `ident.plotting` (the lab's rules: one font, line width ≥ 2, units on every axis,
no title, measured and estimated in different line styles). Returns `Figure` objects;
`write_figures` saves them (the only I/O, called by the command).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from ident import plotting
from ident.diagnose.run import Diagnosis

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def response_figure(d: Diagnosis) -> Figure:
    """Measured positions with the linear and the extended simulations, one axis per cart."""
    carts = d.y.shape[1]
    fig, axes = plotting.new_figure(carts)
    rep = d.report
    for j, ax in enumerate(axes):
        ax.plot(d.t, d.y[:, j], label="measured", **plotting.MEASURED_STYLE)
        ax.plot(d.t, d.baseline[:, j], label=f"linear model, fit {rep.baseline.fit_percent:.2f} %",
                **plotting.ESTIMATE_STYLES[0])
        if rep.cause != "none":
            ax.plot(d.t, d.extended[:, j],
                    label=f"with {rep.cause.replace('_', ' ')}, fit {rep.extended.fit_percent:.2f} %",
                    **plotting.ESTIMATE_STYLES[1])
        plotting.label_axes(ax, "time (s)", f"cart {j + 1} position (m)")
        ax.legend(loc="best")
    return fig


def residual_figure(d: Diagnosis) -> Figure:
    """Residuals (measured minus simulated) of both models, in mm."""
    carts = d.y.shape[1]
    fig, axes = plotting.new_figure(carts)
    for j, ax in enumerate(axes):
        ax.plot(d.t, 1e3 * (d.y[:, j] - d.baseline[:, j]), label="linear model", **plotting.ESTIMATE_STYLES[0])
        if d.report.cause != "none":
            ax.plot(d.t, 1e3 * (d.y[:, j] - d.extended[:, j]), label="extended model",
                    **plotting.ESTIMATE_STYLES[1])
        plotting.label_axes(ax, "time (s)", f"cart {j + 1} residual (mm)")
        ax.legend(loc="best")
    return fig


def envelope_figure(d: Diagnosis) -> Figure:
    """Half-cycle peaks |x - rest| against time: straight line = friction, exponential = viscous."""
    fig, (ax,) = plotting.new_figure(1)
    if d.extrema.size:
        ax.plot(d.extrema[:, 0], 1e3 * d.extrema[:, 1], marker="o", label="measured peaks",
                **plotting.MEASURED_STYLE)
        ax.set_ylim(bottom=0.0)
    plotting.label_axes(ax, "time (s)", "peak |x - rest| (mm)")
    if d.extrema.size:
        ax.legend(loc="best")
    return fig


def write_figures(d: Diagnosis, directory: Path) -> list[Path]:
    """Save the three figures as PNG and SVG in `directory`; return the paths."""
    written: list[Path] = []
    for name, build in (("diagnosis_response", response_figure), ("diagnosis_residuals", residual_figure),
                        ("diagnosis_envelope", envelope_figure)):
        written += plotting.save(build(d), directory / name)
    return written
