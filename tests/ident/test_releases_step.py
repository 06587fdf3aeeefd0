"""The release step of a raw record follows the release: a cart let go on either side of its
rest has a positive gain (issue 10: `ident report` showed a negative gain for hand releases
to the positive side, its step being +0.15 m whatever the side).

Written from the physics: one cart (ω_n ∈ [8, 16] rad/s, ζ ∈ [0.01, 0.04]) at rest, pulled
by hand to s·d (s = ±1, d ∈ [3, 10] cm) in 0.6 s, held 0.5 s and let go; the free response
from rest at s·d is the damped oscillator's, ringing out over 6 s. The record is a raw CSV
(no release time): `ident.fitrun.load_run` cuts it to the release the finder finds, with
the release's own step (rest - let-go position = -s·d), and the simple identification
returns the physical gain 1 for both sides.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ident.fitrun import RunFileOptions, load_run
from ident.simple import fit_simple

QUANTUM_M = 1.0 / 56000.0


def _csv(path: Path, side: float, seed: int) -> tuple[Path, float]:
    rng = np.random.default_rng(seed)
    wn, zeta, d = rng.uniform(8.0, 16.0), rng.uniform(0.01, 0.04), rng.uniform(0.03, 0.10)
    t = np.arange(0.0, 8.0, 0.005)
    start, release = 0.5, 1.6
    s = np.clip((t - start) / 0.6, 0.0, 1.0)
    x = side * d * (10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5)
    tau = t[t >= release] - release
    wd = wn * np.sqrt(1.0 - zeta ** 2)
    x[t >= release] = side * d * np.exp(-zeta * wn * tau) * (np.cos(wd * tau) + zeta * wn / wd * np.sin(wd * tau))
    y = QUANTUM_M * np.round(x / QUANTUM_M)
    rows = "\n".join(f"{ti:.4f},{yi:.8f}" for ti, yi in zip(t, y, strict=True))
    path.write_text("time_s,pos1_m\n" + rows + "\n")
    return path, side * d


@pytest.mark.parametrize("side", [-1.0, 1.0])
@pytest.mark.parametrize("seed", [1, 2])
def test_a_hold_released_on_either_side_has_its_own_step_and_gain_one(tmp_path: Path, side: float,
                                                                    seed: int) -> None:
    path, held_at = _csv(tmp_path / "hold.csv", side, seed)
    data = load_run(path, RunFileOptions())
    assert data.step_amplitude == pytest.approx(-held_at, rel=0.03)
    fit = fit_simple(data, "rk4")
    assert fit.gain == pytest.approx(1.0, abs=0.03)


def test_a_given_step_is_the_step_of_a_raw_record(tmp_path: Path) -> None:
    """`--step-m` (`RunFileOptions.step_m`) is the step when given, not the release's own."""
    path, held_at = _csv(tmp_path / "hold.csv", -1.0, 3)
    own = fit_simple(load_run(path, RunFileOptions()), "rk4").gain
    given = load_run(path, RunFileOptions(step_m=-4.0 * held_at))
    assert given.step_amplitude == pytest.approx(-4.0 * held_at)
    assert fit_simple(given, "rk4").gain == pytest.approx(own / 4.0, rel=0.03)
    picked = load_run(path, RunFileOptions(step_m=-4.0 * held_at), release=1)
    assert picked.step_amplitude == pytest.approx(-4.0 * held_at)
