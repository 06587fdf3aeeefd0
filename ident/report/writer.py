"""Write the lab report of fitted runs (the runs are gathered by `ident report`,
`ident/commands/report.py`). Renders only: nothing is fitted here.

One run per lab case is used (the first given that fitted). Written to DIR: `report.md`,
`index.html` (self-contained: figures inlined as SVG, equations drawn as SVG), the figures
as `<case>-<kind>.png|svg`, and `fits.json`.
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

from ident.report.content import CaseResult, report_blocks
from ident.report.document import to_html, to_markdown
from schemas.fit import LAB_CASES, FitReport


@dataclass(frozen=True)
class FittedRun:
    """A run's final report and the directory holding its figures."""

    report: FitReport
    fit_dir: Path
    source: Path


def pick_cases(runs: list[FittedRun]) -> list[FittedRun]:
    """The first successfully fitted run of each lab case, in the handout's order."""
    chosen = []
    for case in LAB_CASES:
        match = next((r for r in runs if r.report.case == case and r.report.status == "ok"), None)
        if match is not None:
            chosen.append(match)
    return chosen


def copy_figures(run: FittedRun, out_dir: Path) -> dict[str, str]:
    """Copy `<kind>.png|svg` of a fit to `<case>-<kind>.png|svg`; return kind -> stem."""
    stems: dict[str, str] = {}
    for name in run.report.figures:
        source = run.fit_dir / name
        if not source.is_file():
            continue
        kind = Path(name).stem
        stem = f"{run.report.case}-{kind}"
        shutil.copyfile(source, out_dir / f"{stem}{source.suffix}")
        if (out_dir / f"{stem}.png").exists() and (out_dir / f"{stem}.svg").exists():
            stems[kind] = stem
    return stems


def write_report_dir(runs: list[FittedRun], out_dir: Path) -> list[CaseResult]:
    """Write report.md, index.html, figures and fits.json for the chosen runs."""
    import ident
    from ident.report.figures import style

    out_dir.mkdir(parents=True, exist_ok=True)
    chosen = pick_cases(runs)
    results = [CaseResult(r.report.case, r.report, copy_figures(r, out_dir))  # type: ignore[arg-type]
               for r in chosen]
    stamp = f"{ident.__version__} on {datetime.now(UTC):%Y-%m-%d %H:%M} UTC"
    unused = [r.report for r in runs if r not in chosen]
    blocks = report_blocks(results, stamp, unused)
    font_family, font_size = style()
    (out_dir / "report.md").write_text(to_markdown(blocks))
    (out_dir / "index.html").write_text(
        to_html(blocks, "Spring-cart system identification: lab report", out_dir, font_family,
                font_size))
    fits = "[\n" + ",\n".join(r.report.model_dump_json(indent=2) for r in runs) + "\n]\n"
    (out_dir / "fits.json").write_text(fits)
    return results


__all__ = ["FittedRun", "copy_figures", "pick_cases", "write_report_dir"]
