"""`ident releases` on a text export with a recorded drive: a force step on a dry-friction cart
at rest reads, in the positions alone, like a release from a still hold, and may be listed as
one; when a column named like a drive switches just before a listed release, a note on stderr
says so and names `ident diagnose --input` (red team motor pulses 402 and 404 were listed as
hand releases with no word of their drive).

The motor pulse is the red team's (`tools/redteam/cases11.py`, `coulomb+force_pulse`: its own
physics, written independently of `ident`); the hand release is drawn here from the physics of
a damped cart let go from a still hold, beside a drive column that never switches."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ident.cli import main
from testkit.redteam import redteam_module


def test_a_release_right_after_the_drive_switches_is_noted_with_the_input_to_give(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run11 = redteam_module("run11")
    path = tmp_path / "pulse.csv"
    run11.write_csv(run11.case_of("coulomb+force_pulse", 402), path)   # time,pos1,effort
    assert main(["releases", str(path), "--scale", "1"]) == 0
    out, err = capsys.readouterr()
    assert "2 release(s)" in out
    assert "column 'effort' switches" in err and "ms before release 1" in err and "ms before release 2" in err
    assert f"ident diagnose {path} --input 'effort'" in err


def test_a_hand_release_beside_a_drive_column_that_never_switches_has_no_note(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    t = np.arange(0.0, 7.0, 1.0 / 400.0)
    wn, zeta = 2 * np.pi * 3.0, 0.03
    wd = wn * np.sqrt(1 - zeta ** 2)
    tau = np.clip(t - 1.0, 0.0, None)    # held 30 mm out, let go at 1 s
    x = 0.03 * np.exp(-zeta * wn * tau) * (np.cos(wd * tau) + zeta * wn / wd * np.sin(wd * tau))
    y = np.round((x + np.random.default_rng(2).normal(0.0, 2e-6, t.size)) / 1e-5) * 1e-5
    path = tmp_path / "hand.csv"
    np.savetxt(path, np.column_stack([t, y, np.zeros_like(t)]), delimiter=",", header="time,pos1,effort",
               comments="", fmt="%.9g")
    assert main(["releases", str(path), "--scale", "1"]) == 0
    out, err = capsys.readouterr()
    assert "1 release(s)" in out and "note" not in err
