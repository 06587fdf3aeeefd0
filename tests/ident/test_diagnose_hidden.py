"""`ident diagnose` must find a hidden effect in runs it knows nothing about, through its files.

The runs come from the independent generator `testkit.effects` (its own physics and
integrator, no `ident` import): the single-effect families and `none`, one or two carts,
holds and flicks, 50–1000 Hz; written as the CSV `time_s,pos1_m[,pos2_m]` or a `daq` MCAP
run, and `diagnose` sees only that file. Required here: the right cause, every parameter within
15 %, no effect called on a linear run (issue 11's stricter targets on more cases:
`test_diagnose_effects.py` and `tools/bench_diagnose.py`), plus the report's contract fields,
figures and what friction does to the linear damping ratio.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from ident.cli import main
from ident.diagnose import diagnose
from ident.diagnose.figures import response_figure
from ident.io import load
from schemas.diagnosis import DiagnosisReport
from testkit.effects import SINGLE, Case, judge, make_case, write_csv
from testkit.mcap_runs import write_mcap_run

REL_TOL = 0.15
#: main missed these when the generator was ported (strict: remove the mark once they pass)
SET_SEED = 20261122
API_CASES = 16
CLI_CASES = 6


def _plan(n: int, offset: int) -> list[tuple[int, str]]:
    """n (seed, family) pairs: the family order is a seeded shuffle of a balanced list."""
    rng = np.random.default_rng(SET_SEED + offset)
    families = [SINGLE[i % len(SINGLE)] for i in range(n)]
    order = rng.permutation(n)
    return [(int(rng.integers(0, 2**31)), families[i]) for i in order]


def _wrong(case: Case, report: DiagnosisReport) -> str:
    """'' when the diagnosis is right (cause, listed immaterial effects, parameters within 15 %);
    a false positive on a linear run starts with 'FALSE POSITIVE'."""
    verdict = judge(case, report, REL_TOL)
    if verdict.right:
        return ""
    if verdict.false_positive:
        return f"FALSE POSITIVE seed {case.seed}: cause {report.cause}, found {list(verdict.found)}"
    errors = ", ".join(f"{k} {100 * e:.1f} %" for k, e in verdict.errors.items())
    return (f"seed {case.seed} {case.truth.family} carts={case.observed.carts} {case.truth.release} "
            f"{case.truth.rate_hz:.0f} Hz: cause {report.cause}, found {list(verdict.found)} {errors}")


def _csv_report(case: Case, path: Path) -> DiagnosisReport:
    data = load(write_csv(case, path))
    return diagnose(data.t, data.y, carts=case.observed.carts).report


@pytest.mark.slow
def test_hidden_effects_are_found_through_a_csv_file(tmp_path: Path) -> None:
    results = [(case, _csv_report(case, tmp_path / f"run_{seed}.csv"))
               for seed, family in _plan(API_CASES, 0) for case in [make_case(seed, family)]]
    assert {c.truth.family for c, _ in results} == set(SINGLE)
    assert {c.observed.carts for c, _ in results} == {1, 2}
    wrong = [msg for c, r in results if (msg := _wrong(c, r))]
    assert not [m for m in wrong if m.startswith("FALSE POSITIVE")], wrong
    assert len(wrong) <= int(0.05 * len(results)), wrong


@pytest.mark.slow
def test_hidden_effects_are_found_through_the_cli_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    wrong = []
    for seed, family in _plan(CLI_CASES, 1):
        case = make_case(seed, family)
        path = write_csv(case, tmp_path / f"run_{seed}.csv")
        assert main(["diagnose", str(path), "--carts", str(case.observed.carts), "--json"]) == 0
        report = DiagnosisReport.from_json_bytes(capsys.readouterr().out)
        if msg := _wrong(case, report):
            wrong.append(msg)
    assert not wrong, wrong


def test_a_clean_linear_run_names_no_cause_and_reports_the_contract_fields(tmp_path: Path,
                                                                          capsys: pytest.CaptureFixture[str]) -> None:
    case = make_case(7, "none", carts=1, release="hold")
    path = write_csv(case, tmp_path / "linear.csv")
    assert main(["diagnose", str(path), "--json"]) == 0
    raw = json.loads(capsys.readouterr().out)
    for key in ("release_time_s", "baseline", "candidates", "effects", "cause", "extended", "gain_points",
                "validation", "explanation"):
        assert key in raw
    assert raw["cause"] == "none" and raw["gain_points"] == 0.0
    assert not [e for e in raw["effects"] if e["material"]]
    assert {c["effect"] for c in raw["candidates"]} >= {"coulomb_friction", "quadratic_drag",
                                                        "cubic_stiffness", "coupled_mode"}
    assert raw["baseline"]["fit_percent"] > 99.0
    assert abs(raw["release_time_s"] - case.truth.release_time_s) < 0.005


def test_friction_corrects_the_damping_ratio_and_writes_figures(tmp_path: Path,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    case = make_case(11, "coulomb_friction", carts=1, release="hold")
    path = write_csv(case, tmp_path / "friction.csv")
    figures = tmp_path / "figures"
    assert main(["diagnose", str(path), "--figures", str(figures)]) == 0
    text = capsys.readouterr().out
    assert "coulomb_friction" in text and "gain" in text
    assert sorted(p.name for p in figures.iterdir()) == sorted(
        f"diagnosis_{n}.{e}" for n in ("response", "residuals", "envelope") for e in ("png", "svg"))
    report = diagnose(case.observed.t, case.observed.y).report
    assert report.cause == "coulomb_friction"
    # the linear model hides friction in viscous damping: its zeta is well above the corrected one
    assert report.baseline.parameters["zeta"] > 1.3 * report.corrected_linear["zeta"]
    friction = next(e for e in report.effects if e.effect == "coulomb_friction")
    assert friction.parameter_std["coulomb_accel_m_s2"] < 0.05 * friction.parameters["coulomb_accel_m_s2"]


def test_the_response_figure_names_every_accepted_effect() -> None:
    # the extended model drawn is the one with every accepted effect (here two): named so, at
    # the report's whole-window fit (it was labelled by the headline cause alone)
    case = make_case(12, "coulomb+quantization", carts=1, release="hold")
    result = diagnose(case.observed.t, case.observed.y)
    effects = [e.effect for e in result.report.effects]
    assert {"coulomb_friction", "quantization"} <= set(effects)
    figure = response_figure(result)
    (legend,) = figure.legends   # one legend above the axes, none inside them (they covered the data)
    assert all(ax.get_legend() is None for ax in figure.axes)
    entry = legend.get_texts()[-1].get_text().replace("\n", " ")
    assert all(name.replace("_", " ") in entry for name in effects)
    assert entry.endswith(f"fit {result.report.extended.fit_percent:.2f} %")


@pytest.mark.slow
def test_hidden_effects_are_found_when_the_hand_lets_go_while_the_cart_moves(tmp_path: Path) -> None:
    wrong = []
    for seed, family in _plan(len(SINGLE), 2):
        case = make_case(seed, family, release="flick")
        report = _csv_report(case, tmp_path / f"flick_{seed}.csv")
        # the free response is fitted from where the hand no longer acts, not from the onset
        assert report.window_start_s > case.truth.release_time_s - 0.1
        if msg := _wrong(case, report):
            wrong.append(msg)
    assert not [m for m in wrong if m.startswith("FALSE POSITIVE")], wrong
    assert len(wrong) <= 1, wrong


def test_a_daq_run_file_is_diagnosed_with_its_own_columns(tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    case = make_case(23, "quadratic_drag", carts=1)
    path = tmp_path / "r1.mcap"
    t, y = case.observed.t, case.observed.y
    write_mcap_run(path, [round(v * 1e9) for v in t], [float(v) for v in y[:, 0]], None)
    assert main(["diagnose", str(path), "--json"]) == 0
    report = DiagnosisReport.from_json_bytes(capsys.readouterr().out)
    assert _wrong(case, report) == ""
