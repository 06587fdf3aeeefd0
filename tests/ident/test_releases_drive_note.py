"""`ident releases` on a text export with a recorded drive: a force step on a dry-friction cart
at rest reads, in the positions alone, like a release from a still hold, and may be listed as
one; when a column named like a drive switches just before a listed release, a note on stderr
says so and names `ident diagnose --input` (red team motor pulses 402 and 404 were listed as
hand releases with no word of their drive).

The motor pulse is the red team's (`tools/redteam/cases11.py`, `coulomb+force_pulse`: its own
physics, written independently of `ident`); the hand release is drawn here from the physics of
a damped cart let go from a still hold, beside a drive column that never switches; the driven
record without a release is a damped cart's response to a force pulse, from its closed form.

A record with no release whose drive column switches is refused by `ident diagnose` (without
`--input`), naming the column and the command that fits it (`ident fit`'s error names them
too): fitted as a free response from where it first moved, the 2025 ECP-210 motor pulses had
been given a 0.19 Hz "coupled mode" at 12 % fit."""

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
    assert f"ident diagnose {path} --scale 1.0 --input effort" in err


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


def _pulse_response(tmp_path: Path) -> Path:
    """A cart (2.5 Hz, ζ 0.05) at rest pushed by a drive pulse from 2 s to 6 s that would hold it
    6 mm out: its two rings stay below a release's centimetre. Read at 500 Hz on a 10 µm lattice,
    beside the drive's duty column (`time,pos1,effort`)."""
    t = np.arange(0.0, 9.0, 1.0 / 500.0)
    wn, zeta = 2 * np.pi * 2.5, 0.05
    wd = wn * np.sqrt(1 - zeta ** 2)

    def step(t0: float) -> np.ndarray:   # unit static deflection from rest at t0
        tau = np.clip(t - t0, 0.0, None)
        return 1.0 - np.exp(-zeta * wn * tau) * (np.cos(wd * tau) + zeta * wn / wd * np.sin(wd * tau))

    x = 0.006 * (step(2.0) - step(6.0))
    y = np.round((x + np.random.default_rng(5).normal(0.0, 2e-6, t.size)) / 1e-5) * 1e-5
    duty = np.where((t >= 2.0) & (t < 6.0), 491.0, 0.0)
    path = tmp_path / "pulse.csv"
    np.savetxt(path, np.column_stack([t, y, duty]), delimiter=",", header="time,pos1,effort", comments="",
               fmt="%.9g")
    return path


def test_a_driven_record_without_a_release_is_noted_and_not_diagnosed_without_its_drive(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = _pulse_response(tmp_path)
    assert main(["releases", str(path), "--scale", "1"]) == 0
    out, err = capsys.readouterr()
    assert "no release found" in out
    assert "no hand release; column 'effort' switches at 2.00, 6.00 s" in err
    assert f"ident diagnose {path} --scale 1.0 --input effort" in err
    assert main(["diagnose", str(path), "--scale", "1"]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert "no release found, and column 'effort' switches at 2.00, 6.00 s" in err
    assert f"ident diagnose {path} --scale 1.0 --input effort" in err
    assert main(["fit", str(path), "--scale", "1"]) == 2
    err = capsys.readouterr().err
    assert "none found; column 'effort' switches at 2.00, 6.00 s" in err
    assert f"ident fit {path} --scale 1.0 --input effort" in err
    # given the drive, the record is the response to it
    assert main(["diagnose", str(path), "--scale", "1", "--input", "effort", "--json"]) == 0
    assert '"cause"' in capsys.readouterr().out
