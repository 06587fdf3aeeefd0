"""`ident fit --method euler --friction`: the simple fit with dry friction from the command line
(the red team's `ident fit --method euler` had no way to ask for it and fitted ζ 10× too large).

The record is written from the physics (`testkit.free_ring.coulomb_ring`: the piecewise-exact
ring with viscous and dry friction, static = kinetic), a CSV with a known release (`--release-s`)
and pull (`--step-m`), as a lab user types it; wn 8-20 rad/s, ζ 0.01-0.04, 5-20 cycles to the
stick, 100 Hz, 1 µm noise.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from ident.cli import main as ident_main
from testkit.free_ring import coulomb_ring


def _record(path: Path, seed: int) -> tuple[list[str], dict[str, float]]:
    rng = np.random.default_rng([7, seed])
    wn, zeta, pull = rng.uniform(8.0, 20.0), rng.uniform(0.01, 0.04), rng.uniform(0.03, 0.12)
    friction = wn**2 * pull / (4.0 * rng.uniform(5.0, 20.0))
    release = 0.8 + 0.37 / 100.0
    t = np.arange(0.0, 10.0, 0.01)
    x = np.full(t.size, -pull)
    after = t >= release
    x[after] = coulomb_ring(t[after] - release, -pull, 0.0, 0.0, wn, zeta, friction)
    y = x + pull + rng.normal(0.0, 1e-6, t.size)
    path.write_text("time_s,pos1_m\n" + "\n".join(f"{a:.4f},{b:.8f}" for a, b in zip(t, y, strict=True)) + "\n")
    args = [str(path), "--method", "euler", "--release-s", f"{release}", "--step-m", f"{pull}", "--json"]
    return args, {"wn": wn, "zeta": zeta, "friction": friction}


@pytest.mark.parametrize("seed", [0, 1])
def test_ident_fit_friction_returns_the_physical_parameters(tmp_path: Path, seed: int,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    args, truth = _record(tmp_path / "friction.csv", seed)
    assert ident_main(["fit", *args, "--friction"]) == 0
    euler = json.loads(capsys.readouterr().out)["simple"][0]
    assert euler["wn_rad_s"] == pytest.approx(truth["wn"], rel=0.01)
    assert euler["zeta"] == pytest.approx(truth["zeta"], rel=0.01)
    assert euler["coulomb_accel_m_s2"] == pytest.approx(truth["friction"], rel=0.01)
    assert ident_main(["fit", *args]) == 0   # without it: the linear model, its ζ inflated by the dry friction
    linear = json.loads(capsys.readouterr().out)["simple"][0]
    assert linear["coulomb_accel_m_s2"] is None and linear["zeta"] > 1.5 * truth["zeta"]
