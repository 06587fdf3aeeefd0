"""The simple identification of a flicked release: the cart let go moving (issue 10/11).

Real students flick the cart and let go of it while it moves, near the first extreme. The
model then starts at the release the data state from the cart's state there (position and an
estimated velocity), simulated by the handout's RK4 / Euler recursion from those initial
conditions. Before, the model was a step from rest: it moved its release to the first
extreme and sat still while the cart was still moving (wn and ζ several % off here).

The records are written from the physics, not by the code under test: the analytic free
response of a damped spring-mass from (x0, v0), and for dry friction its exact piecewise
solution (each half-cycle a damped ring about the rest shifted by f/wn² against the motion).
Ranges: wn 8-25 rad/s, ζ 0.02-0.1, swings 1-5 cm on either side, let go 30° after to 70°
before the first extreme, 100-1000 Hz, noise 0.2 % of the swing.
"""

from __future__ import annotations

import numpy as np
import pytest

from ident.data import IdData
from ident.simple import fit_simple
from testkit.free_ring import coulomb_ring, ring

SEEDS = range(10)
WN_MAX, ZETA_MIN = 25.0, 0.02
LENGTH_S = 8.0


def flick(seed: int, friction: bool = False) -> tuple[IdData, dict[str, float]]:
    """A flicked release: the window starts one sample before the release (as `ident.releases`
    cuts it), the release time is where the free response begins, u steps there by the pull
    the record states (its rest, the mean of its last second, less the level at the release)."""
    rng = np.random.default_rng(seed)
    wn, zeta = float(rng.uniform(8.0, WN_MAX)), float(rng.uniform(ZETA_MIN, 0.1))
    swing = float(rng.uniform(0.01, 0.05)) * float(rng.choice([-1.0, 1.0]))
    phase = np.deg2rad(float(rng.uniform(-30.0, 70.0)))   # > 0: let go before the extreme
    rest = float(rng.uniform(-0.02, 0.02))
    x0, v0 = rest + swing * np.cos(phase), swing * wn * np.sin(phase)
    rate = float(rng.choice([100.0, 200.0, 500.0, 1000.0]))
    release = 2.0 + float(rng.uniform(0.05, 0.95)) / rate
    t = 2.0 + np.arange(0.0, LENGTH_S, 1.0 / rate, dtype=np.float64) - 1.0 / rate + 0.0
    tau = t - release
    f = float(rng.uniform(0.02, 0.15)) * abs(swing) * wn**2 / np.pi if friction else 0.0
    clean = (coulomb_ring(np.clip(tau, 0.0, None), x0, v0, rest, wn, zeta, f) if friction
             else ring(tau, x0, v0, rest, wn, zeta))
    clean[tau < 0] = ring(tau[tau < 0], x0, v0, rest, wn, zeta)   # the hand's last sample: still moving
    y = clean + rng.normal(0.0, 0.002 * abs(swing), t.size)
    pull = float(np.mean(y[t > t[-1] - 1.0])) - float(np.interp(release, t, y))
    u = np.where(t > release, pull, 0.0)
    truth = {"wn": wn, "zeta": zeta, "v0": v0, "x0": x0, "rest": rest, "friction": f, "rate": rate, "swing": swing}
    return IdData(t, u, y[:, None], release_time_s=release), truth


@pytest.mark.parametrize("seed", SEEDS)
def test_rk4_recovers_a_flicked_release_within_1_percent(seed: int) -> None:
    data, truth = flick(seed)
    fit = fit_simple(data, "rk4")
    assert fit.wn == pytest.approx(truth["wn"], rel=0.01)
    assert fit.zeta == pytest.approx(truth["zeta"], rel=0.01)
    _follows_the_cart(data, truth, fit.y_hat[:, 0])
    assert fit.offset + fit.gain * data.step_amplitude == pytest.approx(truth["rest"], abs=2e-4)
    assert fit.fit_percent[0] > 95.0
    if fit.initial_state == "estimate":
        assert fit.release_time_s == data.release_time_s   # the data's release: not moved to the extreme
        assert fit.release_velocity == pytest.approx(truth["v0"], abs=0.01 * abs(truth["swing"]) * truth["wn"])
    # else: let go at or after the extreme, the same ring as a release from rest at that extreme


def _follows_the_cart(data: IdData, truth: dict[str, float], y_hat: np.ndarray) -> None:
    """From the release on, the model is the cart's response within 1 % of the swing: it does
    not sit still while the cart moves (the step from rest did, up to the first extreme)."""
    release = float(data.release_time_s or 0.0)
    after = data.t >= release
    clean = ring(data.t[after] - release, truth["x0"], truth["v0"], truth["rest"], truth["wn"],
                 truth["zeta"])
    assert np.max(np.abs(y_hat[after] - clean)) < 0.01 * abs(truth["swing"])


@pytest.mark.parametrize("seed", SEEDS)
def test_euler_with_substeps_recovers_a_flicked_release_within_1_percent(seed: int) -> None:
    data, truth = flick(seed)
    h = float(np.median(np.diff(data.t)))
    substeps = int(np.ceil(WN_MAX * h / (0.01 * ZETA_MIN)))   # Euler's ζ bias wn·h/2 below 0.5 % of ζ
    fit = fit_simple(data, "euler", substeps=substeps)
    assert fit.wn == pytest.approx(truth["wn"], rel=0.01)
    assert fit.zeta == pytest.approx(truth["zeta"], rel=0.01)
    _follows_the_cart(data, truth, fit.y_hat[:, 0])


def test_a_release_from_rest_keeps_the_step_from_rest() -> None:
    """v0 = 0: the pull-hold-release is the step from rest, its release fitted as before."""
    rng = np.random.default_rng(3)
    wn, zeta, pull, rate = 14.0, 0.05, 0.03, 200.0
    t = np.arange(0.0, 8.0, 1.0 / rate, dtype=np.float64)
    release = 1.0 + 0.4 / rate
    y = np.where(t < release, 0.0, ring(t - release, 0.0, 0.0, pull, wn, zeta)) + rng.normal(0.0, 6e-5, t.size)
    u = np.where(t > release, pull, 0.0)
    fit = fit_simple(IdData(t, u, y[:, None], release_time_s=release + 0.002), "rk4")
    assert fit.initial_state == "rest" and fit.release_velocity == 0.0
    assert abs(fit.release_time_s - release) < 0.2 / rate
    assert fit.gain == pytest.approx(1.0, rel=0.01)
