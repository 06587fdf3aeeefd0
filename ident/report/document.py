"""A tiny document model rendered twice: Markdown (`report.md`) and one self-contained HTML page.

Blocks: `Heading`, `Para`, `Equation`, `Table`, `Figure`, `Code`. Inline markup in `Para` and
table cells is limited to `` `code` `` and `**bold**`, which both renderers understand.
Figures are numbered in order (`number_figures`): a caption reads "Figure N: …" and a
paragraph refers to a figure as `{fig:LABEL}`, replaced by "Figure N" (a dangling reference
raises). Equations
are TeX (matplotlib mathtext subset): `$$...$$` in Markdown, inline SVG drawn by matplotlib
in HTML, so the page needs no network and no MathJax. Figures are referenced by file in
Markdown and embedded as SVG in HTML. No I/O except reading the figure files given.
"""

from __future__ import annotations

import html
import io
import re
from dataclasses import dataclass
from pathlib import Path

_CODE = re.compile(r"`([^`]+)`")
_BOLD = re.compile(r"\*\*([^*]+)\*\*")


@dataclass(frozen=True)
class Heading:
    level: int
    text: str


@dataclass(frozen=True)
class Para:
    text: str


@dataclass(frozen=True)
class Equation:
    """`tex` in matplotlib's mathtext subset (no matrices); `label` is a short caption."""

    tex: str
    label: str = ""


@dataclass(frozen=True)
class Table:
    header: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]


@dataclass(frozen=True)
class Figure:
    """`stem` names `<stem>.png` and `<stem>.svg` in the report directory; `number` is set
    by `number_figures`; `label` (default: the stem) is what `{fig:LABEL}` refers to."""

    stem: str
    caption: str
    label: str = ""
    number: int = 0


@dataclass(frozen=True)
class Code:
    """Python source: a fenced block in Markdown, `<pre>` in HTML, a code cell in a notebook."""

    source: str


Block = Heading | Para | Equation | Table | Figure | Code

_REF = re.compile(r"\{fig:([A-Za-z0-9_.-]+)\}")


def number_figures(blocks: list[Block]) -> list[Block]:
    """Number the figures in order and resolve every `{fig:LABEL}` in paragraphs."""
    numbers: dict[str, int] = {}
    out: list[Block] = []
    for block in blocks:
        if isinstance(block, Figure):
            numbers[block.label or block.stem] = len(numbers) + 1
            block = Figure(block.stem, block.caption, block.label or block.stem, len(numbers))
        out.append(block)

    def resolve(match: re.Match[str]) -> str:
        if match.group(1) not in numbers:
            raise KeyError(f"reference to figure {match.group(1)!r}, which the report does not hold")
        return f"Figure {numbers[match.group(1)]}"

    return [Para(_REF.sub(resolve, b.text)) if isinstance(b, Para) else
            Table(b.header, tuple(tuple(_REF.sub(resolve, c) for c in row) for row in b.rows))
            if isinstance(b, Table) else b for b in out]


def caption_of(figure: Figure) -> str:
    return f"Figure {figure.number}: {figure.caption}" if figure.number else figure.caption


# -- Markdown ---------------------------------------------------------------------------------
def to_markdown(blocks: list[Block]) -> str:
    out: list[str] = []
    for block in blocks:
        if isinstance(block, Heading):
            out.append(f"{'#' * block.level} {block.text}")
        elif isinstance(block, Para):
            out.append(block.text)
        elif isinstance(block, Equation):
            out.append(f"$$\n{block.tex}\n$$" + (f"\n\n*{block.label}*" if block.label else ""))
        elif isinstance(block, Table):
            out.append(_md_table(block))
        elif isinstance(block, Figure):
            out.append(f"![{_plain(caption_of(block))}]({block.stem}.png)\n\n"
                       f"*{caption_of(block)}* (vector: [{block.stem}.svg]({block.stem}.svg))")
        elif isinstance(block, Code):
            out.append(f"```python\n{block.source.rstrip()}\n```")
    return "\n\n".join(out) + "\n"


def _md_table(table: Table) -> str:
    def row(cells: tuple[str, ...]) -> str:
        return "| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |"

    lines = [row(table.header), "|" + "---|" * len(table.header)]
    lines += [row(r) for r in table.rows]
    return "\n".join(lines)


def _plain(text: str) -> str:
    return _BOLD.sub(r"\1", _CODE.sub(r"\1", text)).replace("[", "(").replace("]", ")")


# -- HTML ---------------------------------------------------------------------------------------
def _inline(text: str) -> str:
    escaped = html.escape(text, quote=False)
    escaped = _CODE.sub(r"<code>\1</code>", escaped)
    return _BOLD.sub(r"<strong>\1</strong>", escaped)


def equation_svg(tex: str, fontsize: float) -> str | None:
    """The equation drawn by matplotlib mathtext as inline SVG, or None if it cannot parse."""
    from matplotlib import rc_context
    from matplotlib.font_manager import FontProperties
    from matplotlib.mathtext import math_to_image

    buffer = io.BytesIO()
    display = tex.replace(r"\frac", r"\dfrac")    # display-size fractions, as on paper
    # glyphs as paths: as text, the browser would set the radical and the big delimiters in
    # its own font, whose metrics do not match mathtext's layout (a broken √)
    try:
        with rc_context({"svg.fonttype": "path"}):
            math_to_image(f"${display}$", buffer, prop=FontProperties(size=fontsize), format="svg")
    except ValueError:
        return None
    return _strip_xml_header(buffer.getvalue().decode())


def _strip_xml_header(svg: str) -> str:
    start = svg.find("<svg")
    return svg[start:] if start >= 0 else svg


def to_html(blocks: list[Block], title: str, figure_dir: Path, font_family: str,
            font_size_pt: float) -> str:
    """One page; figures read from `figure_dir/<stem>.svg` and inlined."""
    body: list[str] = []
    for block in blocks:
        if isinstance(block, Heading):
            level = min(max(block.level, 1), 6)
            body.append(f"<h{level}>{_inline(block.text)}</h{level}>")
        elif isinstance(block, Para):
            body.append(f"<p>{_inline(block.text)}</p>")
        elif isinstance(block, Equation):
            svg = equation_svg(block.tex, font_size_pt * 1.15)
            shown = svg if svg is not None else f"<code>{html.escape(block.tex)}</code>"
            label = f"<div class='eqlabel'>{_inline(block.label)}</div>" if block.label else ""
            body.append(f"<div class='equation'>{shown}{label}</div>")
        elif isinstance(block, Table):
            head = "".join(f"<th>{_inline(c)}</th>" for c in block.header)
            rows = "".join("<tr>" + "".join(f"<td>{_inline(c)}</td>" for c in r) + "</tr>"
                           for r in block.rows)
            body.append(f"<table><thead><tr>{head}</tr></thead><tbody>{rows}</tbody></table>")
        elif isinstance(block, Figure):
            svg_path = figure_dir / f"{block.stem}.svg"
            svg = _strip_xml_header(svg_path.read_text()) if svg_path.is_file() else \
                f"<p>(missing figure {html.escape(block.stem)})</p>"
            body.append(f"<figure id='figure-{block.number}'>{svg}<figcaption>"
                        f"{_inline(caption_of(block))}</figcaption></figure>")
        elif isinstance(block, Code):
            body.append(f"<pre><code class='language-python'>{html.escape(block.source.rstrip())}"
                        "</code></pre>")
    css = (f"body{{font-family:'{font_family}',sans-serif;font-size:{font_size_pt}pt;"
           "max-width:60em;margin:2em auto;padding:0 1em;line-height:1.45;color:#222}"
           "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #bbb;"
           "padding:.25em .6em;text-align:left;vertical-align:top}th{background:#f0f0f0}"
           "figure{margin:1.5em 0}figure svg{max-width:100%;height:auto}"
           "figcaption{font-style:italic}.equation{margin:1em 0 1em 2em}"
           ".eqlabel{font-style:italic;font-size:90%}code{font-size:95%}"
           "pre{background:#f6f6f6;border:1px solid #ddd;padding:.6em;overflow-x:auto;"
           "font-size:85%;line-height:1.3}")
    return ("<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'>"
            f"<title>{html.escape(title)}</title><style>{css}</style></head><body>\n"
            + "\n".join(body) + "\n</body></html>\n")


__all__ = ["Block", "Code", "Equation", "Figure", "Heading", "Para", "Table", "caption_of",
           "equation_svg", "number_figures", "to_html", "to_markdown"]
