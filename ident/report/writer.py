"""Write the lab report of fitted runs (the runs are gathered by `ident report`,
`ident/commands/report.py`). Renders only: nothing is fitted here.

One run per lab case is used (the first given that fitted). Written to DIR: `report.md`,
`index.html` (self-contained: figures inlined as SVG, equations drawn as SVG), the figures
as `<case>-<kind>.png|svg`, `fits.json`, the samples each fit used (`data/<case>.csv`, with
the release time and pulled cart in `data/<case>.json`) and `report.ipynb`, the same report
as a notebook whose code recomputes the numbers from `data/` (executed here, so it holds
its outputs, unless `run_notebook` is False).
"""

from __future__ import annotations

import json
import shutil
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from ident import __version__
from ident.data import FloatArray, IdData
from ident.errors import IdentError
from ident.report import notebook as nb
from ident.report.content import CaseResult, report_blocks
from ident.report.document import to_html, to_markdown
from ident.report.figures import style
from schemas.fit import LAB_CASES, FitReport


@dataclass(frozen=True)
class FittedRun:
    """A run's final report, the directory holding its figures, and the samples its fits
    used (`data`: the fitted carts' columns; None when the run file is not at hand), with the
    other carts' positions (N, k) on `data.t` its diagnosis took as inputs (`held`: a held
    cart's motion; k may be 0); `forced`: `data.u` is a recorded force input (a run begun by
    the rig's drive), which the diagnosis took too."""

    report: FitReport
    fit_dir: Path
    source: Path
    data: IdData | None = None
    held: FloatArray | None = None
    forced: bool = False


class NotebookError(IdentError, RuntimeError):
    """The report's notebook failed to run; the other files were written."""


def export_data(run: FittedRun, out_dir: Path) -> str | None:
    """Write `data/<case>.csv` (time_s, u_m, x<cart>_m…, then held<k>_m…: the other carts'
    positions the diagnosis took as inputs; full precision) and its `.json`."""
    data, case = run.data, run.report.case
    if data is None or case is None:
        return None
    outputs = run.report.pem.outputs if run.report.pem else [s.output for s in run.report.simple[:1]]
    folder = out_dir / "data"
    folder.mkdir(parents=True, exist_ok=True)
    held = np.zeros((data.n_samples, 0)) if run.held is None else run.held
    names = [*(f"x{c}_m" for c in outputs), *(f"held{k + 1}_m" for k in range(held.shape[1]))]
    header = ",".join(["time_s", "u_m", *names])
    table = [[t, u, *y, *h] for t, u, y, h in zip(data.t, data.u, data.y, held, strict=True)]
    lines = [header] + [",".join(repr(float(v)) for v in row) for row in table]
    (folder / f"{case}.csv").write_text("\n".join(lines) + "\n")
    meta = {"run_id": run.report.run_id, "case": case, "outputs": outputs,
            "release_time_s": data.release_time_s, "pulled_cart": data.pulled_cart}
    (folder / f"{case}.json").write_text(json.dumps(meta, indent=2) + "\n")
    return f"data/{case}.csv"


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


def write_report_dir(runs: list[FittedRun], out_dir: Path,
                     run_notebook: bool = True) -> list[CaseResult]:
    """Write report.md, index.html, report.ipynb, figures, data and fits.json for the chosen
    runs. Raises `NotebookError` (after writing everything) when the notebook fails to run."""
    out_dir.mkdir(parents=True, exist_ok=True)
    chosen = pick_cases(runs)
    results = [CaseResult(r.report.case, r.report, copy_figures(r, out_dir),  # type: ignore[arg-type]
                          export_data(r, out_dir), r.forced) for r in chosen]
    stamp = f"{__version__} on {datetime.now(UTC):%Y-%m-%d %H:%M} UTC"
    unused = [r.report for r in runs if r not in chosen]
    blocks = report_blocks(results, stamp, unused)
    font_family, font_size = style()
    (out_dir / "report.md").write_text(to_markdown(blocks))
    (out_dir / "index.html").write_text(
        to_html(blocks, "Spring-cart system identification: lab report", out_dir, font_family,
                font_size))
    fits = "[\n" + ",\n".join(r.report.model_dump_json(indent=2) for r in runs) + "\n]\n"
    (out_dir / "fits.json").write_text(fits)
    notebook = nb.to_notebook(blocks)
    try:
        if run_notebook and all(r.data_file for r in results):
            nb.execute(notebook, out_dir)
    except Exception as exc:      # nbclient's CellExecutionError, a dead kernel, a timeout
        nb.write(notebook, out_dir / "report.ipynb")
        raise NotebookError(f"report.ipynb did not run to the end: {str(exc)[-2000:]}") from exc
    nb.write(notebook, out_dir / "report.ipynb")
    return results


__all__ = ["FittedRun", "NotebookError", "copy_figures", "export_data", "pick_cases",
           "write_report_dir"]
