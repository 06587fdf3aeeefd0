"""`ident report`: the lab report's files, content, self-contained HTML and the figure rules."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from matplotlib.figure import Figure

from ident.commands.report import write_lab_report
from ident.report import figures as figs
from ident.report.content import CaseResult
from ident.report.figure_rules import check_svg
from testkit.lab_runs import record_lab_runs

FIGURE_STEMS = ("cart1-simple", "cart2-simple", "cart1-pem", "cart2-pem", "both-pem",
                "cart1-diagnosis", "cart2-diagnosis", "both-diagnosis",
                "cart1-envelope", "cart2-envelope")     # no envelope for two beating carts

#: The matplotlib figures the report's fits drew, by "<case number>/<kind>" (kept, not cleared).
DRAWN: dict[str, Figure] = {}


def _keep(drawn: dict[str, Figure]) -> None:
    """Keep one case's figures under its own number (an object's id may be reused once freed)."""
    case = len({name.split("/")[0] for name in DRAWN})
    DRAWN.update({f"{case}/{kind}": fig for kind, fig in drawn.items()})


@pytest.fixture(scope="module")
def lab_runs(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    return record_lab_runs(tmp_path_factory.mktemp("runs"))


@pytest.fixture(scope="module")
def report(lab_runs: list[Path], tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[CaseResult]]:
    """The report of the three runs, fitted here; the figures drawn on the way are kept."""
    out = tmp_path_factory.mktemp("report")
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(figs, "close", _keep)
        results = write_lab_report(lab_runs, out, run_notebook=False)   # run by its own test
    return out, results


def test_report_has_every_file_the_submission_needs(report: tuple[Path, list[CaseResult]]) -> None:
    out, results = report
    assert [r.case for r in results] == ["cart1", "cart2", "both"]
    for name in ("index.html", "report.md", "fits.json"):
        assert (out / name).stat().st_size > 1000
    for stem in FIGURE_STEMS:
        assert (out / f"{stem}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert b"<svg" in (out / f"{stem}.svg").read_bytes()[:2000]


def test_report_text_holds_derivation_identified_models_and_numbers(
        report: tuple[Path, list[CaseResult]]) -> None:
    out, results = report
    md = (out / "report.md").read_text()
    for equation in (r"\frac{\omega_n^2}{s^2 + 2\zeta\omega_n s + \omega_n^2}",
                     r"\frac{X_1(s)}{R(s)}", r"\frac{X_2(s)}{R(s)}", r"\mathrm{det}\,Z(s)"):
        assert equation in md
    for r in results:
        assert r.report.pem is not None
        for tf in r.report.pem.tfs:
            assert tf.text in md                       # every identified PEM TF is shown
        for s in r.report.simple:
            assert s.tf.text in md
    methods = re.findall(r"^\| cart[12] \| [12] \| (RK4|Euler) \|", md, flags=re.MULTILINE)
    assert sorted(methods) == ["Euler", "Euler", "RK4", "RK4"]
    both = results[2].report.pem
    assert both is not None and both.order == 4 and len(both.tfs) == 2


def test_reflection_is_two_to_three_paragraphs_quoting_the_results(
        report: tuple[Path, list[CaseResult]]) -> None:
    out, results = report
    md = (out / "report.md").read_text()
    reflection = md.split("## 6. Reflection (draft)", 1)[1].split("\n## ", 1)[0].strip()
    draft, *paragraphs = [p for p in reflection.split("\n\n") if p.strip()]
    assert draft.startswith("**Draft — edit before you hand it in.**")
    assert 2 <= len(paragraphs) <= 3
    quoted = {f"{m.wn_rad_s:.3f}" for r in results if r.report.pem for m in r.report.pem.modes}
    assert quoted and all(q in reflection for q in quoted)


def test_html_is_self_contained_with_inline_figures_and_the_figure_font(
        report: tuple[Path, list[CaseResult]]) -> None:
    out, _ = report
    page = (out / "index.html").read_text()
    external = [ref for ref in re.findall(r'(?:src|href)="([^"#][^"]*)"', page)]
    assert external == []
    assert page.count("<figure id='figure-") == len(FIGURE_STEMS)
    assert page.count("<svg") >= len(FIGURE_STEMS) + 6          # figures + drawn equations
    family, size = figs.style()
    assert f"font-family:'{family}'" in page and f"font-size:{size}pt" in page


def test_figures_follow_the_lab_plotting_rules(report: tuple[Path, list[CaseResult]]) -> None:
    kinds = sorted(name.split("/")[1] for name in DRAWN)
    assert kinds == sorted(stem.split("-")[1] for stem in FIGURE_STEMS)
    family, size = figs.style()
    for name, fig in DRAWN.items():
        assert figs.check_figure_rules(fig) == [], name
        for ax in fig.axes:
            assert ax.get_title() == ""
            assert ax.get_xlabel() == "time (s)" and ax.get_ylabel().endswith(("(m)", "(mm)"))
            lines = ax.get_lines()
            assert len(lines) >= 2 and all(line.get_linewidth() >= 2.0 for line in lines)
            styles = [(line.get_linestyle(), line.get_marker()) for line in lines]
            assert len(set(styles)) == len(styles)                  # every trace its own style
            if "position" in ax.get_ylabel():                       # measured solid, estimates not
                assert lines[0].get_linestyle() == "-"
                assert all(line.get_linestyle() != "-" for line in lines[1:])
            assert ax.xaxis.label.get_fontsize() == pytest.approx(size)
            assert ax.xaxis.label.get_fontfamily()[0] == family


def test_rule_checker_flags_title_thin_lines_missing_units_and_same_styles() -> None:
    fig = Figure()
    ax = fig.add_subplot()
    ax.plot([0, 1], [0, 1], linewidth=1.0, linestyle="-")
    ax.plot([0, 1], [1, 0], linewidth=2.5, linestyle="-")
    ax.set_title("a title")
    ax.set_xlabel("time")
    problems = figs.check_figure_rules(fig)
    assert any("width 1.0" in p for p in problems)
    assert any("x label 'time'" in p for p in problems)
    assert any("y label ''" in p for p in problems)
    assert any("share line styles" in p for p in problems)
    assert any("title" in p for p in problems)


def test_ident_report_command_reuses_existing_fits_and_prints_the_summary(
        report: tuple[Path, list[CaseResult]], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from ident.cli import main

    out, results = report
    fit_dirs = sorted((out / "fits").glob("*.fit"))
    assert len(fit_dirs) == 3
    code = main(["report", *map(str, fit_dirs[:2]), "-o", str(tmp_path / "two")])
    printed = capsys.readouterr().out
    assert code == 0 and "(2 of 3 lab cases)" in printed
    lines = [line for line in printed.splitlines() if line.startswith(("cart1", "cart2", "both"))]
    assert [line.split()[0] for line in lines] == ["cart1", "cart2"]
    assert results[0].report.pem is not None
    assert results[0].report.pem.tfs[0].text in lines[0]
    md = (tmp_path / "two" / "report.md").read_text()
    assert "**Missing lab cases:** both" in md and "No two-cart run was identified" in md
    assert main(["report", str(tmp_path / "nothing-here"), "-o", str(tmp_path / "x")]) == 2


# --- issue 12: numbered figures checked from their files, the code, the notebook ------------------

def test_every_figure_file_follows_the_lab_rules_and_is_numbered_and_referenced(
        report: tuple[Path, list[CaseResult]]) -> None:
    out, _ = report
    family, size = figs.style()
    svgs = sorted(out.glob("*.svg"))
    assert sorted(p.stem for p in svgs) == sorted(FIGURE_STEMS)
    for svg in svgs:
        assert check_svg(svg, family, size) == [], svg.name
        assert svg.with_suffix(".png").is_file()
    md = (out / "report.md").read_text()
    captions = re.findall(r"^\*Figure (\d+): .*\* \(vector: \[([a-z0-9-]+)\.svg\]", md, flags=re.MULTILINE)
    assert [int(n) for n, _ in captions] == list(range(1, len(FIGURE_STEMS) + 1))
    assert sorted(stem for _, stem in captions) == sorted(FIGURE_STEMS)
    text = "\n".join(line for line in md.splitlines()
                     if not line.startswith(("*Figure", "![Figure")))
    for n, _ in captions:
        assert re.search(rf"\bFigure {n}\b", text), f"Figure {n} is never referred to"


def test_the_rule_checker_reads_a_bad_figure_file_and_names_each_broken_rule(tmp_path: Path) -> None:
    from matplotlib.figure import Figure as MplFigure

    fig = MplFigure()
    ax = fig.add_subplot()
    ax.plot([0, 1], [0, 1], linewidth=1.0, linestyle="-")
    ax.plot([0, 1], [1, 0], linewidth=2.5, linestyle="-")
    ax.set_title("a title", fontsize=15)
    ax.set_xlabel("time")
    fig.savefig(tmp_path / "bad.svg")
    problems = check_svg(tmp_path / "bad.svg", "DejaVu Sans", 11.0)
    assert any("title 'a title'" in p for p in problems)
    assert any("x label 'time'" in p for p in problems)
    assert any("y label ''" in p for p in problems)
    assert any("width 1 < 2" in p for p in problems)
    assert any("share a line style" in p for p in problems)
    assert any(p.startswith("fonts ") for p in problems)


def test_report_md_holds_the_python_of_each_identification(report: tuple[Path, list[CaseResult]]) -> None:
    out, _ = report
    md = (out / "report.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", md, flags=re.DOTALL)
    code = "\n".join(blocks)
    for step in ('np.loadtxt("data/cart1.csv"', 'np.loadtxt("data/both.csv"', "ident.IdData(",
                 'ident.fit_simple(data, "rk4")', 'ident.fit_simple(data, "euler")',
                 "ident.pem(data, 2)", "ident.pem(data, 4)", "model.tf", "model.simulate(data.u)",
                 "plt.show()", "diagnose(data.t, np.column_stack([data.y, held["):
        assert step in code, step
    for block in blocks:
        compile(block, "report.md", "exec")                  # each block is valid Python


@pytest.mark.timeout(300)
def test_notebook_runs_headless_beside_its_data_and_prints_the_reports_numbers(
        report: tuple[Path, list[CaseResult]], tmp_path: Path) -> None:
    import json
    import shutil

    import nbformat
    from nbclient import NotebookClient

    out, results = report
    shutil.copy(out / "report.ipynb", tmp_path / "report.ipynb")
    shutil.copytree(out / "data", tmp_path / "data")          # nothing else beside it
    notebook = nbformat.read(tmp_path / "report.ipynb", as_version=4)
    assert {c.cell_type for c in notebook.cells} == {"markdown", "code"}
    assert any("$$" in c.source for c in notebook.cells if c.cell_type == "markdown")
    NotebookClient(notebook, timeout=240, kernel_name="python3",
                   resources={"metadata": {"path": str(tmp_path)}}).execute()
    outputs = [o for c in notebook.cells if c.cell_type == "code" for o in c.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    assert any(o.output_type == "display_data" and "image/png" in o.data for o in outputs)
    printed = notebook.cells[-1].outputs[0]["text"]
    numbers = json.loads(printed)
    for r in results:
        got = numbers[r.case]
        for s in r.report.simple:
            assert got[s.method]["fit"] == pytest.approx(s.fit_percent, rel=1e-9)
            assert got[s.method]["zeta"] == pytest.approx(s.zeta, rel=1e-9)
            assert got[s.method]["wn"] == pytest.approx(s.wn_rad_s, rel=1e-9)
        assert r.report.pem is not None
        assert got["pem"]["fit"] == pytest.approx(r.report.pem.fit_percent, rel=1e-9)
        assert got["pem"]["wn"] == pytest.approx([m.wn_rad_s for m in r.report.pem.modes], rel=1e-9)
        assert r.report.diagnosis is not None
        assert got["diagnosis"]["cause"] == r.report.diagnosis.cause
        assert got["diagnosis"]["gain"] == pytest.approx(r.report.diagnosis.gain_points, rel=1e-6)
    md = (out / "report.md").read_text()                    # and the report prints them so
    for r in results:
        for s in r.report.simple:
            assert f"{numbers[r.case][s.method]['fit']:.2f} %" in md


def test_the_text_states_the_friction_signatures_and_a_draft_reflection(
        report: tuple[Path, list[CaseResult]]) -> None:
    out, results = report
    md = (out / "report.md").read_text()
    assert "Dry friction takes a constant amount off each cycle" in md
    assert "viscous damping keeps a constant ratio" in md
    for hit in re.finditer("constant ratio", md):          # always said of viscous damping
        assert "viscous" in md[max(0, hit.start() - 80):hit.end() + 80], md[hit.start() - 80:hit.end() + 80]
    for hit in re.finditer("constant amount", md):         # always said of dry friction
        assert "friction" in md[max(0, hit.start() - 80):hit.end() + 80]
    for r in results[:2]:                   # single carts: RK4 vs Euler, PEM vs RK4 explained
        rk4, euler = (next(s for s in r.report.simple if s.method == m) for m in ("rk4", "euler"))
        assert f"RK4 {rk4.zeta:.4f}, Euler {euler.zeta:.4f}" in md
    assert "PEM and the simple identification estimate the same quantities" in md
    d = results[0].report.diagnosis
    assert d is not None
    for c in d.candidates:                  # every effect tried, with its gain
        assert f"{c.effect.replace('_', ' ')} {c.gain_points:+.3f}" in md
    assert "No envelope is drawn for two free carts" in md


def test_equations_in_the_html_are_drawn_as_paths_so_the_radical_renders_whole() -> None:
    from ident.report.document import equation_svg

    svg = equation_svg(r"\omega_n = \sqrt{k/m}, \qquad \zeta = \frac{c}{2\sqrt{k m}}", 12.0)
    assert svg is not None and "<path" in svg
    assert "<text" not in svg           # no glyph left for the browser's own font to set
