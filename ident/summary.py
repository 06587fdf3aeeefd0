"""Short MATLAB-like summaries of `ident` objects: a title and a few labelled lines, as text
(`repr`/`print`) and as an HTML table (`_repr_html_`, what notebooks show).

Only formatting: callers pass already-computed strings. No numerics, no I/O.
"""

from __future__ import annotations

import html
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

Rows = Sequence[tuple[str, str]]


def text(title: str, rows: Rows) -> str:
    """`title` then one `  label: value` line per row, labels aligned."""
    width = max((len(label) for label, _ in rows), default=0)
    return "\n".join([title, *(f"  {label:<{width}} : {value}" for label, value in rows)])


def html_table(title: str, rows: Rows) -> str:
    """The same summary as a small HTML table (escaped)."""
    body = "".join(f"<tr><th style='text-align:left'>{html.escape(label)}</th>"
                   f"<td style='text-align:left'>{html.escape(value)}</td></tr>" for label, value in rows)
    return f"<table><caption style='text-align:left'><b>{html.escape(title)}</b></caption>{body}</table>"


def number(value: float | None, digits: int = 4, unit: str = "") -> str:
    """`value` to `digits` significant digits with its unit, 'n/a' for None or NaN."""
    if value is None or not np.isfinite(value):
        return "n/a"
    return f"{value:.{digits}g}{(' ' + unit) if unit else ''}"


def with_std(value: float, std: float, digits: int = 4, unit: str = "") -> str:
    """`value ± std unit` (the ± part only when the standard error is known)."""
    core = number(value, digits)
    spread = f" ± {std:.2g}" if np.isfinite(std) else ""
    return f"{core}{spread}{(' ' + unit) if unit else ''}"


def percents(values: Sequence[float]) -> str:
    """'98.7 % (y1), 95.2 % (y2)'."""
    return ", ".join(f"{v:.1f} % (y{j + 1})" for j, v in enumerate(values))


def span(values: NDArray[np.float64], unit: str) -> str:
    """'min … max unit' of an array."""
    return f"{np.min(values):.4g} … {np.max(values):.4g} {unit}"
