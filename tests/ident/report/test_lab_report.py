"""`ident report`: the lab report's files, content, self-contained HTML and the figure rules."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from matplotlib.figure import Figure

from ident.commands.report import write_lab_report
from ident.report import figures as figs
from ident.report.content import CaseResult
from testkit.lab_runs import record_lab_runs

FIGURE_STEMS = ("cart1-simple", "cart2-simple", "cart1-pem", "cart2-pem", "both-pem",
                "cart1-diagnosis", "cart2-diagnosis", "both-diagnosis",
                "cart1-envelope", "cart2-envelope", "both-envelope")

#: The matplotlib figures the report's fits drew, by "<run stem>/<kind>" (kept, not cleared).
DRAWN: dict[str, Figure] = {}


@pytest.fixture(scope="module")
def lab_runs(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    return record_lab_runs(tmp_path_factory.mktemp("runs"))


@pytest.fixture(scope="module")
def report(lab_runs: list[Path], tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[CaseResult]]:
    """The report of the three runs, fitted here; the figures drawn on the way are kept."""
    out = tmp_path_factory.mktemp("report")
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(figs, "close", lambda drawn: DRAWN.update(
            {f"{id(drawn)}/{kind}": fig for kind, fig in drawn.items()}))
        results = write_lab_report(lab_runs, out)
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
    methods = re.findall(r"^\| cart[12] \| [12] \| (RK4|Euler) \|", md, flags=re.M)
    assert sorted(methods) == ["Euler", "Euler", "RK4", "RK4"]
    both = results[2].report.pem
    assert both is not None and both.order == 4 and len(both.tfs) == 2


def test_reflection_is_two_to_three_paragraphs_quoting_the_results(
        report: tuple[Path, list[CaseResult]]) -> None:
    out, results = report
    md = (out / "report.md").read_text()
    reflection = md.split("## 6. Reflection", 1)[1].strip()
    paragraphs = [p for p in reflection.split("\n\n") if p.strip()]
    assert 2 <= len(paragraphs) <= 3
    quoted = {f"{m.wn_rad_s:.3f}" for r in results if r.report.pem for m in r.report.pem.modes}
    assert quoted and all(q in reflection for q in quoted)


def test_html_is_self_contained_with_inline_figures_and_the_figure_font(
        report: tuple[Path, list[CaseResult]]) -> None:
    out, _ = report
    page = (out / "index.html").read_text()
    external = [ref for ref in re.findall(r'(?:src|href)="([^"#][^"]*)"', page)]
    assert external == []
    assert page.count("<figure>") == len(FIGURE_STEMS)
    assert page.count("<svg") >= len(FIGURE_STEMS) + 6          # figures + drawn equations
    family, size = figs.style()
    assert f"font-family:'{family}'" in page and f"font-size:{size}pt" in page


def test_figures_follow_the_lab_plotting_rules(report: tuple[Path, list[CaseResult]]) -> None:
    kinds = sorted(name.split("/")[1] for name in DRAWN)
    assert kinds == sorted(stem.split("-")[1] for stem in FIGURE_STEMS)
    family, size = figs.style()
    for name, fig in DRAWN.items():
        assert figs.check_figure_rules(fig) == [], name
        if name.endswith("/envelope"):          # peaks only (ident.diagnose's figure)
            continue
        for ax in fig.axes:
            assert ax.get_title() == ""
            assert ax.get_xlabel() == "time (s)" and ax.get_ylabel().endswith("position (m)")
            lines = ax.get_lines()
            assert len(lines) >= 2 and all(line.get_linewidth() >= 2.0 for line in lines)
            assert lines[0].get_linestyle() == "-"
            assert all(line.get_linestyle() != "-" for line in lines[1:])   # estimates differ
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
