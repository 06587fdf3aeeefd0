"""The lab's figure style, set in one place (the lab's figure rules, docs/report.md).

- font family and size set once (`apply_style`), matching the report;
- line width at least 2 (`LINE_WIDTH`);
- x and y labels with units on every axis (`label_axes`);
- a caption or a title, never both: figures here carry no title, the report's caption
  describes them;
- measured and estimated traces in different line styles (`MEASURED_STYLE`,
  `ESTIMATE_STYLES`).
Headless: figures are `matplotlib.figure.Figure` objects (no pyplot state), saved by `save`.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from matplotlib.figure import Figure

FONT_FAMILY = "DejaVu Sans"
FONT_SIZE_PT = 11.0
LINE_WIDTH = 2.0
MEASURED_STYLE: dict[str, Any] = {"linestyle": "-", "color": "0.15", "linewidth": LINE_WIDTH}
ESTIMATE_STYLES: list[dict[str, Any]] = [
    {"linestyle": "--", "color": "tab:red", "linewidth": LINE_WIDTH},
    {"linestyle": ":", "color": "tab:blue", "linewidth": LINE_WIDTH},
    {"linestyle": "-.", "color": "tab:green", "linewidth": LINE_WIDTH},
]


def apply_style() -> None:
    """Set font family and size, line width and SVG text once for every figure."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    matplotlib.rcParams.update({"font.family": FONT_FAMILY, "font.size": FONT_SIZE_PT,
                                "lines.linewidth": LINE_WIDTH, "svg.fonttype": "none",
                                "axes.grid": True, "grid.alpha": 0.3})


def new_figure(n_axes: int, width_in: float = 7.0, height_per_axis_in: float = 2.6) -> tuple[Figure, list[Any]]:
    """A styled figure with `n_axes` stacked axes (no title: the caption describes it)."""
    from matplotlib.figure import Figure as MplFigure

    apply_style()
    fig = MplFigure(figsize=(width_in, height_per_axis_in * n_axes + 0.6), layout="constrained")
    return fig, [fig.add_subplot(n_axes, 1, i + 1) for i in range(n_axes)]


def label_axes(ax: Any, x_label: str, y_label: str) -> None:
    """Both labels, each with its unit in parentheses, e.g. 'time (s)'."""
    if "(" not in x_label or "(" not in y_label:
        raise ValueError(f"axis labels need units in parentheses, got {x_label!r}, {y_label!r}")
    ax.set_xlabel(x_label)
    ax.set_ylabel(y_label)


def save(fig: Figure, path: Path) -> list[Path]:
    """Write `path` as PNG (150 dpi) and SVG beside it; return both paths."""
    path.parent.mkdir(parents=True, exist_ok=True)
    png, svg = path.with_suffix(".png"), path.with_suffix(".svg")
    fig.savefig(png, dpi=150)
    fig.savefig(svg)
    return [png, svg]
