"""The lab's plotting rules, checked on a saved figure file (matplotlib's SVG).

Rules (docs/report.md): one font family and size, matching the report's; data lines at
least 2 pt wide; an x and a y label with a unit in parentheses on every axis; no title
(the report's caption describes the figure: a caption or a title, never both); measured and
estimated traces in different line styles (no two data lines of one axes share a dash
pattern and marker).

Reads the SVG structure matplotlib writes (`svg.fonttype: none`, so text stays text):
`<g id="axes_N">` holds `matplotlib.axis_1|2` (ticks, then the label's `text_K`), the data
lines `line2d_K` (a `path` whose style gives stroke-width and stroke-dasharray), the legend,
and a title as a direct `text_K`. Pure apart from reading the file.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

_SVG = "{http://www.w3.org/2000/svg}"
MIN_LINE_WIDTH = 2.0


def _style(element: ET.Element) -> dict[str, str]:
    pairs = (item.split(":", 1) for item in element.get("style", "").split(";") if ":" in item)
    return {k.strip(): v.strip() for k, v in pairs}


def _children(group: ET.Element, prefix: str) -> list[ET.Element]:
    return [c for c in group if c.tag == f"{_SVG}g" and c.get("id", "").startswith(prefix)]


def _text_of(group: ET.Element) -> str:
    return "".join("".join(t.itertext()) for t in group.iter(f"{_SVG}text"))


def _line_signature(line: ET.Element) -> tuple[str, bool] | None:
    """(dash pattern, has markers) of a data line, None for a line without a path."""
    path = line.find(f"{_SVG}path")
    if path is None:
        return None
    return (_style(path).get("stroke-dasharray", "solid"), line.find(f".//{_SVG}use") is not None)


def _axes_problems(axes: ET.Element, name: str) -> list[str]:
    problems = []
    for title in _children(axes, "text_"):
        problems.append(f"{name}: a title {_text_of(title)!r} (the caption describes the figure)")
    for axis in _children(axes, "matplotlib.axis_"):
        which = "x" if axis.get("id", "").endswith("_1") else "y"
        labels = [_text_of(t) for t in _children(axis, "text_")]
        label = labels[-1] if labels else ""
        if not re.search(r"\([^)]+\)\s*$", label):
            problems.append(f"{name}: {which} label {label!r} has no unit in parentheses")
    signatures = []
    for line in _children(axes, "line2d_"):
        path = line.find(f"{_SVG}path")
        if path is None:
            continue
        width = float(_style(path).get("stroke-width", "1").removesuffix("px"))
        if width < MIN_LINE_WIDTH:
            problems.append(f"{name}: a data line of width {width:g} < {MIN_LINE_WIDTH:g}")
        signatures.append(_line_signature(line))
    if len(set(signatures)) < len(signatures):
        problems.append(f"{name}: two data lines share a line style {signatures}")
    if not signatures:
        problems.append(f"{name}: no data line")
    return problems


def check_svg(path: Path, font_family: str, font_size_pt: float) -> list[str]:
    """The rules the figure in `path` breaks (empty when it follows them)."""
    root = ET.parse(path).getroot()
    problems = []
    fonts = {(_style(t).get("font-family", "").strip("'\""), _style(t).get("font-size", ""))
             for t in root.iter(f"{_SVG}text")}
    wanted = (font_family, f"{font_size_pt:g}px")
    if fonts != {wanted}:
        problems.append(f"fonts {sorted(fonts)}, expected only {wanted}")
    axes = [g for g in root.iter(f"{_SVG}g") if g.get("id", "").startswith("axes_")]
    if not axes:
        problems.append("no axes")
    for group in axes:
        problems += _axes_problems(group, group.get("id", "axes"))
    return problems


__all__ = ["MIN_LINE_WIDTH", "check_svg"]
