"""A rig's drive in the `ecp` stream: kept with every sample, and a run begun by it says so.

The ECP-210's Teensy streams `cart1pos:cart2pos:target:duty:time_ms`; in open loop a motor
pulse (`target` the duty's target) moves cart 1 to a new rest and back. In the positions alone
each edge of the pulse is a release from a still hold, so daq records a run at each; it had
dropped the drive, so nothing in the run said a motor moved the cart, and `ident diagnose
RUN.mcap` fitted the pulse's edge as a hand's release (the 2025 motor pulses: a 2.8 Hz "mode").

Here a motor pulse on a damped cart is written from its closed form (the step response of
`x'' + 2ζω x' + ω² x = ω² F/k`, the pulse the sum of a step up and a step down) as the Teensy's
lines, on its clock of 1 and 2 ms steps, and streamed through `replay://` into a `daq run`
process that records real MCAP files. Checked: a run at each edge, marked `trigger: drive`,
released at the first sample of the new drive; the samples carry the drive as sent; the
exports name its columns; `ident diagnose RUN.mcap`, `ident fit RUN.mcap` and the worker's fit
take the response to the drive, identify the cart and name no cart effect. A hand release in
the same dialect (the drive steady at 0) stays `hand`.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest

from daq.decode.text import encode_ecp
from daq.run_file import RunData, export_csv, export_json, load_run
from ident.cli import main as ident_main
from ident.commands.report import write_lab_report
from ident.errors import IdentValueError
from ident.fitrun import RunIdentity, complete, fit_first
from ident.io import load
from testkit.daq_process import daq_command
from testkit.mcap_runs import write_mcap_run
from testkit.repo import REPO

Array = npt.NDArray[np.float64]
COUNTS_PER_M = 56000.0
OMEGA = 2 * np.pi * 2.4   # rad/s: the ECP-210's cart 1 on its springs
ZETA = 0.04
REST_M = 0.03             # F/k: where the pulse moves the cart to
ON_S, OFF_S, END_S = 3.0, 8.0, 12.0
TARGET = 491.0            # 4096 · 0.6 V / 5
DUTY = TARGET / 4096.0


def _ecp_clock(seed: int) -> Array:
    """The Teensy's stamps (s): steps of 1 ms and, one in eight, 2 ms."""
    steps = np.where(np.random.default_rng(seed).random(int(END_S / 1e-3)) < 0.125, 2e-3, 1e-3)
    t = np.concatenate([[1e-3], 1e-3 + np.cumsum(steps)])
    return t[t <= END_S]


def _step(t: Array, t0: float, zeta: float = ZETA) -> Array:
    """Unit step response from rest at `t0` (0 before)."""
    tau = np.maximum(t - t0, 0.0)
    root = np.sqrt(1 - zeta**2)
    phase = OMEGA * root * tau
    out: Array = 1 - np.exp(-zeta * OMEGA * tau) * (np.cos(phase) + zeta / root * np.sin(phase))
    return np.where(t >= t0, out, 0.0)


def _hand(t: Array) -> Array:
    """A cart pulled 3 cm by hand over 0.4 s from 2 s, held still, let go at 4 s (m)."""
    ramp = np.clip((t - 2.0) / 0.4, 0.0, 1.0)
    held = REST_M * 0.5 * (1 - np.cos(np.pi * ramp))
    free = REST_M * (1 - _step(t, 4.0))   # the free response from the hold, to rest at 0
    return np.where(t < 4.0, held, free)


def _write_stream(path: Path, t: Array, x1: Array, drive: Array) -> None:
    """The lines the Teensy sends: cart 1 at `x1` (m), cart 2 held at 0, the drive as sent."""
    with path.open("wb") as out:
        for ti, xi, on in zip(t.tolist(), x1.tolist(), drive.tolist(), strict=True):
            out.write(encode_ecp(round(xi * COUNTS_PER_M), 0, round(on * TARGET), on * DUTY, ti * 1e3))


def _daq_runs(stream: Path, runs: Path) -> list[RunData]:
    proc = subprocess.run(daq_command("-v", "run", "--port", f"replay://{stream}?speed=max", "--dialect", "ecp",
                                      "--runs-dir", str(runs), "--no-zenoh", "--until-eof"),
                          cwd=REPO, capture_output=True, timeout=120, check=False)
    assert proc.returncode == 0, proc.stderr.decode()
    return [load_run(p) for p in sorted(runs.glob("*.mcap"))]


@pytest.fixture(scope="module")
def pulse(tmp_path_factory: pytest.TempPathFactory) -> tuple[Array, Array, list[Path]]:
    """The pulse's stamps (s), its drive (0/1) and the runs daq recorded of it."""
    root = tmp_path_factory.mktemp("pulse")
    t = _ecp_clock(3)
    drive = ((t >= ON_S) & (t < OFF_S)).astype(np.float64)
    # the force acts from the first sample that carries it
    first_on, first_off = t[np.argmax(t >= ON_S)], t[np.argmax(t >= OFF_S)]
    x1 = REST_M * (_step(t, first_on) - _step(t, first_off))
    _write_stream(root / "pulse.txt", t, x1, drive)
    _daq_runs(root / "pulse.txt", root / "runs")
    return t, drive, sorted((root / "runs").glob("*.mcap"))


def test_each_edge_of_a_motor_pulse_is_a_run_begun_by_the_drive_at_its_switch(
        pulse: tuple[Array, Array, list[Path]]) -> None:
    t, drive, paths = pulse
    runs = [load_run(p) for p in paths]
    switches = t[1:][np.diff(drive) != 0]
    assert len(runs) == len(switches) == 2
    for run, switch in zip(runs, switches, strict=True):
        meta = run.metadata
        assert meta is not None and meta.trigger == "drive"
        assert meta.release_t_ns == round(switch * 1e9)   # the first sample of the new drive
        assert meta.pulled_cart == 1
        # the drive as the device sent it, sample by sample
        assert run.drive is not None
        sent = np.interp(run.t_ns / 1e9, t, drive)
        np.testing.assert_array_equal(run.drive[:, 0], np.round(sent * TARGET))
        np.testing.assert_allclose(run.drive[:, 1], sent * DUTY, atol=5e-5)


def test_a_driven_run_s_exports_carry_its_drive(pulse: tuple[Array, Array, list[Path]]) -> None:
    run = load_run(pulse[2][0])
    header = next(line for line in export_csv(run).splitlines() if not line.startswith("#"))
    assert header == "time_s,pos1_m,pos2_m,target,duty"
    assert "# trigger: drive" in export_csv(run)
    body = json.loads(export_json(run, pulse[2][0]))
    assert max(body["target"]) == TARGET and len(body["duty"]) == len(body["time_s"])


@pytest.mark.parametrize("edge", [0, 1], ids=["on", "off"])
def test_ident_diagnose_fits_a_driven_run_as_the_response_to_its_drive(
        pulse: tuple[Array, Array, list[Path]], edge: int, capsys: pytest.CaptureFixture[str]) -> None:
    path = pulse[2][edge]
    assert ident_main(["diagnose", str(path), "--json"]) == 0
    out, err = capsys.readouterr()
    assert "the rig's drive switched" in err and "--input duty" in err
    report = json.loads(out)
    assert report["carts"] == 1
    assert report["window_start_s"] < 0.01   # from the run's first sample: the rest before the edge too
    assert report["baseline"]["fit_percent"] > 99.0
    assert report["cause"] == "none", report["effects"]


@pytest.mark.parametrize("edge", [0, 1], ids=["on", "off"])
def test_ident_fit_identifies_the_cart_from_a_driven_run(
        pulse: tuple[Array, Array, list[Path]], edge: int, capsys: pytest.CaptureFixture[str]) -> None:
    """PEM on the response to the drive; the off-edge's run starts with the drive on and the cart
    at rest under it (zeroed there by daq): taken as switched on at the first sample, it had
    fitted 49 %."""
    assert ident_main(["fit", str(pulse[2][edge]), "--json", "--method", "pem"]) == 0
    pem = json.loads(capsys.readouterr().out)["pem"]
    assert pem["fit_percent"][0] > 99.0
    assert pem["modes"][0]["wn_rad_s"] == pytest.approx(OMEGA, rel=0.01)
    assert pem["modes"][0]["zeta"] == pytest.approx(ZETA, rel=0.05)


def test_the_worker_s_fit_of_a_driven_run_is_the_response_to_its_drive(
        pulse: tuple[Array, Array, list[Path]]) -> None:
    """`ident worker` fits a finished run by `fit_first` and `complete`: PEM and the diagnosis
    both on the response to the drive."""
    report = complete(fit_first(pulse[2][1], RunIdentity())).report
    assert report.status == "ok" and report.pem is not None and report.diagnosis is not None
    assert report.pem.fit_percent[0] > 99.0
    assert report.diagnosis.window_start_s < 0.01 and report.diagnosis.cause == "none"


@pytest.mark.timeout(300)
def test_a_lab_report_of_a_driven_run_and_its_notebook_take_the_drive(
        pulse: tuple[Array, Array, list[Path]], tmp_path: Path) -> None:
    """`ident report RUN.mcap`: the fits and the diagnosis are of the response to the drive, the
    exported samples carry it as the input, and the notebook's diagnosis, run beside them, gives
    the same numbers."""
    import nbformat
    from nbclient import NotebookClient

    out = tmp_path / "report"
    [result] = write_lab_report([pulse[2][1]], out, run_notebook=False)
    diagnosis = result.report.diagnosis
    assert result.case == "cart1" and diagnosis is not None and result.forced
    assert diagnosis.window_start_s < 0.01 and diagnosis.cause == "none"
    table = np.loadtxt(out / "data" / "cart1.csv", delimiter=",", skiprows=1)
    assert set(np.unique(table[:, 1])) == {0.0, -round(DUTY, 4)}   # the duty as sent, from its value at the start
    notebook = nbformat.read(out / "report.ipynb", as_version=4)
    NotebookClient(notebook, timeout=240, kernel_name="python3",
                   resources={"metadata": {"path": str(out)}}).execute()
    numbers = json.loads(notebook.cells[-1].outputs[0]["text"])
    assert numbers["cart1"]["diagnosis"]["cause"] == diagnosis.cause
    assert numbers["cart1"]["diagnosis"]["gain"] == pytest.approx(diagnosis.gain_points, rel=1e-6, abs=1e-9)


def test_a_small_drive_step_that_swings_back_toward_its_hold_is_still_the_drive_s_run(tmp_path: Path) -> None:
    """A 2.5 mm step (the 2023 open-loop steps are 2.9 mm) overshoots past the detector's 3 mm
    trigger and swings back within it: by a hand's rules a nudge that came back, so no run was
    recorded; the drive switched there, so it is the drive's step."""
    t = _ecp_clock(7)
    drive = (t < ON_S).astype(np.float64)   # on from the start, switched off at ON_S
    first_off = t[np.argmax(t >= ON_S)]
    _write_stream(tmp_path / "step.txt", t, 0.0025 * _step(t, first_off, zeta=0.2), drive)
    runs = _daq_runs(tmp_path / "step.txt", tmp_path / "runs")
    assert len(runs) == 1
    meta = runs[0].metadata
    assert meta is not None and meta.trigger == "drive" and meta.release_t_ns == round(first_off * 1e9)


def test_a_hand_release_with_the_drive_at_rest_is_a_hand_s_run(tmp_path: Path) -> None:
    t = _ecp_clock(5)
    _write_stream(tmp_path / "hand.txt", t, _hand(t), np.zeros_like(t))
    runs = _daq_runs(tmp_path / "hand.txt", tmp_path / "runs")
    assert len(runs) == 1
    meta = runs[0].metadata
    assert meta is not None and meta.trigger == "hand"
    assert abs(meta.release_t_ns / 1e9 - 4.0) < 2e-3
    assert runs[0].drive is not None and not np.any(runs[0].drive)


def test_an_input_asked_of_a_run_without_a_drive_is_refused_by_name(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    t_ns = list(range(0, 2_000_000_000, 10_000_000))
    write_mcap_run(path, t_ns, [0.01 * np.cos(15.0 * k * 1e-9) for k in t_ns], 0.0)
    with pytest.raises(IdentValueError, match="'duty' in a run without one"):
        load(path, input_col="duty")
