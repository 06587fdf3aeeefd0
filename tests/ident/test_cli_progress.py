"""Progress on the `ident` commands: shown on a terminal (stderr), silent otherwise or with -q."""

from __future__ import annotations

import io
import os
import pty
import select
import subprocess
import sys
from pathlib import Path

import pytest
from rich.console import Console

from ident import progress
from testkit.ident_synth import cart1_run

REPO = Path(__file__).resolve().parents[2]


def _terminal() -> tuple[Console, io.StringIO]:
    buffer = io.StringIO()
    return Console(file=buffer, force_terminal=True, width=120), buffer


def test_stages_show_on_a_terminal() -> None:
    console, buffer = _terminal()
    with progress.progress("ident diagnose run.csv", console=console):
        progress.stage("loading")
        progress.stage("fitting")
    text = buffer.getvalue()
    assert "ident diagnose run.csv" in text and "fitting" in text


def test_counted_steps_show_done_of_total() -> None:
    console, buffer = _terminal()
    with progress.progress("ident report", total=3, console=console):
        progress.advance("run 2")
        progress.advance("run 3")
    assert "2/3" in buffer.getvalue()


@pytest.mark.parametrize("quiet", [True, False])
def test_silent_when_quiet_or_not_a_terminal(quiet: bool) -> None:
    buffer = io.StringIO()
    console = Console(file=buffer, force_terminal=True) if quiet else Console(file=buffer)
    with progress.progress("ident fit x", quiet=quiet, console=console):
        progress.stage("loading")
        progress.advance()
    assert buffer.getvalue() == ""


def test_calls_without_a_display_do_nothing() -> None:
    progress.stage("nobody listens")
    progress.advance("nor here")


def _csv(tmp_path: Path) -> Path:
    run = cart1_run(100.0, seed=21, duration=5.0)
    path = tmp_path / "cart1.csv"
    rows = "\n".join(f"{t:.6f},{y:.9f}" for t, y in zip(run.t.tolist(), run.y[:, 0].tolist(), strict=True))
    path.write_text("time_s,pos1_m\n" + rows + "\n")
    return path


def _run_on_pty(args: list[str]) -> tuple[int, str]:
    """Run with stderr on a pseudo-terminal; return the exit code and what the terminal got."""
    master, slave = pty.openpty()
    env = {**os.environ, "COLUMNS": "120", "TERM": "xterm"}
    proc = subprocess.Popen(args, cwd=REPO, stdout=subprocess.DEVNULL, stderr=slave, env=env)
    os.close(slave)
    chunks = []
    while True:
        ready, _, _ = select.select([master], [], [], 120.0)
        if not ready:
            proc.kill()
            break
        try:
            data = os.read(master, 4096)
        except OSError:   # the pty closes when the process ends
            break
        if not data:
            break
        chunks.append(data)
    os.close(master)
    return proc.wait(timeout=60), b"".join(chunks).decode(errors="replace")


def test_ident_fit_shows_progress_on_a_terminal_and_not_in_a_pipe(tmp_path: Path) -> None:
    path = _csv(tmp_path)
    command = [sys.executable, "-m", "ident.cli", "fit", str(path), "--method", "pem"]
    code, terminal = _run_on_pty(command)
    assert code == 0 and "ident fit" in terminal
    code, quiet = _run_on_pty([*command, "--quiet"])
    assert code == 0 and "ident fit" not in quiet
    piped = subprocess.run(command, cwd=REPO, capture_output=True, text=True, timeout=120, check=False)
    assert piped.returncode == 0 and piped.stderr == ""   # nothing but the report, on stdout
    assert "mode 1: wn = 7.3" in piped.stdout   # the cart's wn = √(k/m) = 7.32 rad/s


def test_the_fit_use_case_reports_each_stage_it_runs() -> None:
    from ident.data import IdData, step_input
    from ident.fitrun.analysis import FitSettings, analyse_fits

    run = cart1_run(100.0, seed=22, duration=5.0)
    data = IdData(run.t, step_input(run.t, 0.9, 0.15), run.y)
    console, buffer = _terminal()
    with progress.progress("ident fit run.csv", console=console):
        analysis = analyse_fits(data, FitSettings(methods=("rk4", "pem")))
    shown = buffer.getvalue()
    assert analysis.pem is not None
    assert ": simple" in shown and ": pem" in shown   # the stages of _timed, as they ran
