"""Figures of a diagnosis: measured vs baseline and extended simulation, residuals, envelope.

Built with `ident.plotting` (the lab's rules: one font, line width ≥ 2, units on every axis,
no title, measured and estimated in different line styles). Returns `Figure` objects;
`write_figures` saves them (the only I/O, called by the command).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from ident import plotting
from ident.diagnose.run import Diagnosis

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from schemas.diagnosis import DiagnosisReport


def _cart(j: int, cart_numbers: tuple[int, ...] | None) -> int:
    """The cart the j-th fitted column reads (its column's number, else j + 1)."""
    return cart_numbers[j] if cart_numbers is not None and j < len(cart_numbers) else j + 1


def response_figure(d: Diagnosis, cart_numbers: tuple[int, ...] | None = None) -> Figure:
    """Measured positions with the linear and the extended simulations, one axis per cart
    (labelled by `cart_numbers`, the carts the fitted columns read; default 1, 2)."""
    carts = d.y.shape[1]
    fig, axes = plotting.new_figure(carts)
    rep = d.report
    for j, ax in enumerate(axes):
        ax.plot(d.t, d.y[:, j], label="measured", **plotting.MEASURED_STYLE)
        ax.plot(d.t, d.baseline[:, j], label=f"linear model, fit {rep.baseline.fit_percent:.2f} %",
                **plotting.ESTIMATE_STYLES[0])
        if rep.effects:
            ax.plot(d.t, d.extended[:, j], label=f"{extended_label(rep)}, fit {rep.extended.fit_percent:.2f} %",
                    **plotting.ESTIMATE_STYLES[1])
        plotting.label_axes(ax, "time (s)", f"cart {_cart(j, cart_numbers)} position (m)")
    _legend_above(fig, axes[0])
    return fig


def _legend_above(fig: Figure, ax: Any) -> None:
    """One legend for the stacked axes (their curves are the same), above them: inside an axis
    it covered the first swing of a two-cart motor step, where every curve is."""
    handles, labels = ax.get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside upper center", ncols=2, frameon=False)


def extended_label(rep: DiagnosisReport) -> str:
    """The extended model's legend: every accepted effect, ranked (two to a line)."""
    names = [e.effect.replace("_", " ") for e in rep.effects]
    lines = [" + ".join(names[k:k + 2]) for k in range(0, len(names), 2)]
    return "with " + " +\n".join(lines)


def residual_figure(d: Diagnosis, cart_numbers: tuple[int, ...] | None = None) -> Figure:
    """Residuals (measured minus simulated) of both models, in mm."""
    carts = d.y.shape[1]
    fig, axes = plotting.new_figure(carts)
    for j, ax in enumerate(axes):
        ax.plot(d.t, 1e3 * (d.y[:, j] - d.baseline[:, j]), label="linear model", **plotting.ESTIMATE_STYLES[0])
        if d.report.cause != "none":
            ax.plot(d.t, 1e3 * (d.y[:, j] - d.extended[:, j]), label="extended model",
                    **plotting.ESTIMATE_STYLES[1])
        plotting.label_axes(ax, "time (s)", f"cart {_cart(j, cart_numbers)} residual (mm)")
    _legend_above(fig, axes[0])
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


def write_figures(d: Diagnosis, directory: Path, cart_numbers: tuple[int, ...] | None = None) -> list[Path]:
    """Save the three figures as PNG and SVG in `directory` (axes labelled by `cart_numbers`,
    the carts the fitted columns read); return the paths."""
    written = plotting.save(response_figure(d, cart_numbers), directory / "diagnosis_response")
    written += plotting.save(residual_figure(d, cart_numbers), directory / "diagnosis_residuals")
    written += plotting.save(envelope_figure(d), directory / "diagnosis_envelope")
    return written
