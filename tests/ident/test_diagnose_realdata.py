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
