"""The default fitter on runs that cannot be fitted: a failed report naming the reason."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ident.worker.job import FitJob
from ident.worker.pipeline import fit_to_completion as fit_run
from schemas.daq import RunFinished


def _job(path: Path, tmp_path: Path) -> FitJob:
    finished = RunFinished(bench="b", run_id=path.stem, status="complete", file=path.name,
                           n_samples=0, release_time_s=None, duration_s=0.0)
    return FitJob(finished, path, tmp_path / f"{path.stem}.fit", "w")


def _csv(path: Path, t: np.ndarray, pos: np.ndarray) -> Path:
    rows = "\n".join(f"{a:.4f},{b:.6f}" for a, b in zip(t, pos))
    path.write_text("time_s,pos1_m\n" + rows + "\n")
    return path


def test_too_short_run_fails_with_the_sample_count(tmp_path: Path) -> None:
    t = np.arange(10) * 0.01
    report = fit_run(_job(_csv(tmp_path / "short.csv", t, 0.15 * (t > 0.05)), tmp_path))
    assert report.status == "failed"
    assert "number of samples: expected at least 20, got 10" in (report.reason or "")


def test_run_without_a_release_fails_with_no_motion(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    t = np.arange(600) * 0.01
    report = fit_run(_job(_csv(tmp_path / "still.csv", t, rng.normal(0, 1e-4, t.size)), tmp_path))
    assert report.status == "failed" and "no motion" in (report.reason or "")
    assert report.figures == []


def test_unreadable_file_fails_naming_the_file(tmp_path: Path) -> None:
    path = tmp_path / "broken.mcap"
    path.write_bytes(b"not an mcap file at all")
    report = fit_run(_job(path, tmp_path))
    assert report.status == "failed" and "broken.mcap" in (report.reason or "")
