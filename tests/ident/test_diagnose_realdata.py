"""`ident diagnose` on the real hand-release runs of the ECP-210 rig (UCSD, 2023).

Cart 1 is moved by hand and cart 2 (encoder 2) rings and stops dead off-centre: dry
friction by the rig's own documentation (shared/realdata PROVENANCE.md). Skipped when
../shared/realdata is absent; the files are read in place, never copied. Counts to metres
as the students' scripts: 1 count = 1/560 cm.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from ident.cli import main
from schemas.diagnosis import DiagnosisReport

M_PER_COUNT = 1.0 / 560 / 100
FILES = [f"DOF1_en2_manual2_test{i}.csv" for i in range(1, 6)]


@pytest.mark.slow
@pytest.mark.parametrize("name", FILES)
def test_hand_release_runs_name_a_cause_with_a_positive_gain(realdata_dir: Path, name: str,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    path = realdata_dir / "ECP210_UCSD_2023_Parker-Knopf" / "Open_Loop" / name
    if not path.exists():
        pytest.skip(f"{name} not in the real-data folder")
    code = main(["diagnose", str(path), "--time", "Time", "--pos", "Encoder 2 Pos",
                 "--scale", repr(M_PER_COUNT), "--json"])
    assert code == 0
    report = DiagnosisReport.from_json_bytes(capsys.readouterr().out)
    print(f"{name}: cause {report.cause}, fit {report.baseline.fit_percent:.2f} -> "
          f"{report.extended.fit_percent:.2f} % (+{report.gain_points:.2f}), "
          f"zeta {report.baseline.parameters['zeta']:.4f} -> {report.corrected_linear['zeta']:.4f}, "
          f"parameters {report.extended.parameters}")
    assert report.cause != "none"
    assert report.gain_points > 0.0
    # the encoder's count is seen as the measurement lattice
    assert report.evidence.lattice_quantum_m == pytest.approx(M_PER_COUNT, rel=1e-6)
    # the cart ends motionless (test4 is bumped near the end: half a second is asked)
    assert report.evidence.stuck_for_s > 0.5
    assert report.cause == "coulomb_friction"
    assert 0.02 < report.extended.parameters["coulomb_accel_m_s2"] < 1.0
    assert report.corrected_linear["zeta"] < 0.75 * report.baseline.parameters["zeta"]


@pytest.mark.slow
def test_the_hand_steps_unread_held_cart_drift_is_named_and_the_steps_reach_97_5(
        realdata_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # cart 1 is held by the hand that moved it (PROVENANCE.md) and is not read: its slow wander
    # moves cart 2's rest through the spring (`rest_drift`); without it the first cycles leave a
    # 0.4-0.6 mm hump and 3 of the 5 steps stayed below 97.5 % (95.90, 97.02, 95.02)
    folder = realdata_dir / "ECP210_UCSD_2023_Parker-Knopf" / "Open_Loop"
    paths = [folder / name for name in FILES if (folder / name).exists()]
    if len(paths) < len(FILES):
        pytest.skip("the 2023 hand steps are not all in the real-data folder")
    fits, drift, lines = [], 0, []
    for path in paths:
        assert main(["diagnose", str(path), "--time", "Time", "--pos", "Encoder 2 Pos",
                     "--scale", repr(M_PER_COUNT), "--json"]) == 0
        report = DiagnosisReport.from_json_bytes(capsys.readouterr().out)
        effects = {e.effect: e for e in report.effects}
        fits.append(report.extended.fit_percent)
        if "rest_drift" in effects:
            drift += 1
            knots = [v for k, v in effects["rest_drift"].parameters.items() if k.startswith("drift_knot_")]
            assert max(abs(v) for v in knots) < 2e-3      # a held cart's wander: under 2 mm of rest
            assert effects["rest_drift"].cv_ratio > effects["rest_drift"].cv_threshold
        lines.append(f"{path.name} {report.extended.fit_percent:.2f} % "
                     f"{[(e.effect, round(e.gain_points, 2)) for e in report.effects]}")
    with capsys.disabled():
        print("\n".join(lines))
    assert drift >= 3
    assert sum(f >= 97.5 for f in fits) >= 4


@pytest.mark.slow
@pytest.mark.parametrize(("name", "columns"), [("DOF1_en1_input1_test4.csv", ["Encoder 1 Pos"]),
                                               ("DOF2_en12_input1_test3.csv", ["Encoder 1 Pos", "Encoder 2 Pos"]),
                                               ("test_3_7.csv", ["Encoder 1 Pos", "Encoder 2 Pos"])])
def test_motor_steps_with_their_recorded_input_name_dry_friction_and_not_the_lattice(
        realdata_dir: Path, name: str, columns: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    """The 2023 open-loop motor steps (0.5 V, reversed at 3 s) with `--input "Control Effort"`.
    test4 starts on its step: a block's refit took a step whose Jacobian was not finite and
    raised LinAlgError, and the input's 'onset' was dated at the reversal (3.0 s). On test3 a
    refit after the encoder lattice found a better optimum of the friction (SSE 5.5e-6 ->
    2.0e-6 m²), which was credited to the 17.9 µm lattice (+1.38 points) and made it the cause.
    test4 and test_3_7 read their drive from the first sample: the force was taken relative to
    it, zero until the reversal, the step left to the carts' rest (test4's fitted 2.9 mm off
    where the cart sat; test_3_7 +0.46 points in all, the friction +0.07). The carts rest at a
    zero input where they sat before the drive (the records start at 0)."""
    path = realdata_dir / "ECP210_UCSD_2023_Parker-Knopf" / "Open_Loop" / name
    if not path.exists():
        pytest.skip(f"{name} not in the real-data folder")
    code = main(["diagnose", str(path), "--time", "Time", "--pos", *columns, "--scale", repr(M_PER_COUNT),
                 "--input", "Control Effort", "--json"])
    assert code == 0
    report = DiagnosisReport.from_json_bytes(capsys.readouterr().out)
    effects = {e.effect: e for e in report.effects}
    print(name, report.cause, [(e.effect, round(e.gain_points, 3)) for e in report.effects])
    assert report.cause in ("coulomb_friction", "presliding")
    assert report.gain_points > 1.0
    if "quantization" in effects:   # one encoder count: a few tenths of a point at most
        assert effects["quantization"].gain_points < 0.5
    assert report.release_time_s == pytest.approx(0.0, abs=0.01)   # the input acts from (nearly) the start
    rests = [v for k, v in report.extended.parameters.items() if k.startswith("rest_")]
    assert rests and all(abs(r) < 0.5e-3 for r in rests)
    assert report.validation.startswith("The whole record")


@pytest.mark.slow
def test_the_polimi_pulse_record_is_diagnosed_on_a_grid_that_resolves_its_modes(
        realdata_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The PoliMi rig's 49.6 s of five current pulses at 200 Hz (chunks of one logger record,
    no header: i_real, ..., x1_reale in col3, x2_reale in col5, 560 counts/cm): decimated to
    500 work samples over the whole record its grid was 10 Hz under a 5.9 Hz mode (the linear
    chain 92.4 %); cut where a grid of 6 samples a period runs out, its first pulse and the
    ring after it (12.5 s): 93.2 %, dry friction first, both modes fitted."""
    folder = realdata_dir / "PoliMi_2cart_spring_PULSE35"
    chunks = sorted(folder.glob("data000*.txt"))
    if not chunks:
        pytest.skip("PoliMi record not present")
    record = tmp_path / "polimi.txt"
    record.write_text("".join(c.read_text() for c in chunks))
    assert main(["diagnose", str(record), "--rate-hz", "200", "--pos", "col3", "col5", "--input", "col0",
                 "--scale", "0.01", "--json"]) == 0
    report = DiagnosisReport.from_json_bytes(capsys.readouterr().out)
    assert report.validation.startswith("The record's first 2500 samples")
    assert report.baseline.fit_percent > 92.5 and report.gain_points > 1.0
    assert report.cause == "coulomb_friction"
    wn = sorted(v for k, v in report.corrected_linear.items() if k.startswith("wn_mode"))
    assert wn[1] > 30.0   # the second mode (36 rad/s in PEM at the full rate), not aliased
