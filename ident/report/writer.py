"""`ident report RUN... -o DIR`: gather the fits of the lab cases and write the lab report.

A RUN is a `daq` run file (`<run_id>.mcap`; its `<run_id>.fit/` beside it is reused when a
worker already fitted it, else it is fitted here), a fit directory or its `report.json`,
or a text export (fitted here). One run per lab case is used (the first given that
fitted). Written to DIR: `report.md`, `index.html` (self-contained: figures inlined as
SVG, equations drawn as SVG), the figures as `<case>-<kind>.png|svg`, and `fits.json`.
"""

from __future__ import annotations

import re
import shutil
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

from schemas import topics
from schemas.daq import RunFinished
from schemas.fit import LAB_CASES, FitReport
from ident.errors import DataFileError
from ident.report.content import CaseResult, report_blocks
from ident.report.document import to_html, to_markdown
from ident.worker.runs_dir import FIT_SUFFIX, REPORT_NAME, read_finished, read_report, write_report


@dataclass(frozen=True)
class FittedRun:
    """A run's final report and the directory holding its figures."""

    report: FitReport
    fit_dir: Path
    source: Path


def _safe_id(stem: str) -> str:
    cleaned = re.sub(r"[^A-Za-z0-9_.-]", "-", stem).lstrip(".-") or "run"
    return cleaned[:128]


def _fit_here(path: Path, fit_dir: Path) -> FitReport:
    from ident.worker.pipeline import fit_to_completion
    from ident.worker.service import FitJob

    finished = read_finished(path) if path.suffix == topics.RUN_SUFFIX else None
    if finished is None:
        finished = RunFinished(bench="local", run_id=_safe_id(path.stem), status="complete",
                               file=path.name, n_samples=0, release_time_s=None, duration_s=0.0)
    report = fit_to_completion(FitJob(finished, path, fit_dir, "ident-report"))
    write_report(fit_dir, report)
    return report


def gather(paths: list[Path], work_dir: Path) -> list[FittedRun]:
    """The final report of each RUN, fitting those that have none (into `work_dir`)."""
    runs = []
    for path in paths:
        if path.is_dir() or path.name == REPORT_NAME:
            fit_dir = path if path.is_dir() else path.parent
            report = read_report(fit_dir)
            if report is None:
                raise DataFileError(f"expected a final {REPORT_NAME} in {fit_dir}, got none")
            runs.append(FittedRun(report, fit_dir, path))
            continue
        if not path.is_file():
            raise DataFileError(f"expected a run file, fit directory or report, got {str(path)!r}")
        beside = path.with_name(path.name.removesuffix(topics.RUN_SUFFIX) + FIT_SUFFIX)
        report = read_report(beside) if path.suffix == topics.RUN_SUFFIX else None
        if report is not None:
            runs.append(FittedRun(report, beside, path))
            continue
        fit_dir = work_dir / f"{_safe_id(path.stem)}{FIT_SUFFIX}"
        runs.append(FittedRun(_fit_here(path, fit_dir), fit_dir, path))
    return runs


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


def write_lab_report(paths: list[Path], out_dir: Path) -> list[CaseResult]:
    """Gather (fitting where needed, into `out_dir/fits/`) and write the report."""
    runs = gather(paths, out_dir / "fits")
    return write_report_dir(runs, out_dir)


__all__ = ["FittedRun", "copy_figures", "gather", "pick_cases", "write_lab_report",
           "write_report_dir"]
